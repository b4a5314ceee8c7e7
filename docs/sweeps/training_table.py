"""End to end against step by step, every pair of committed archives (reproduction.md, "End to end against step by step").

Each pair names the archive of end-to-end runs and the archive of the step-by-step runs they pair with by seed (None:
the same archive holds both); ``synthcal table docs/results/A --against docs/results/B --paired training=end-to-end
training=step-by-step [--metric iou_weighted]`` prints each pair's cells. This script prints them all as the report's
one Markdown table, a row per cell with both readings, sorted by dataset, loss, matching score and model. The
report's table is this script's output (tests/eval/test_committed_archives.py checks it), so a new pair goes here,
then the script's output replaces the table.

Run it from anywhere: ``python docs/sweeps/training_table.py`` (it finds ``docs/results`` beside itself).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

import synthcal
from synthcal.eval.archive import read_archive

RESULTS = Path(__file__).resolve().parents[1] / "results"

#: (end-to-end archive, step-by-step archive or None), in the order they were measured.
PAIRS: list[tuple[str, str | None]] = [
    ("runs_twentyfirst.csv", "runs_eighteenth.csv"),
    ("runs_twentyfirst.csv", "runs_tenth.csv"),
    ("runs_seventeenth.csv", "runs_tenth.csv"),
    ("runs_tenth.csv", "runs_thirteenth.csv"),
    ("runs_twentyfirst_gpu.csv", "runs_eleventh.csv"),
    ("runs_twentyninth.csv", "runs_eleventh.csv"),
    ("runs_twentyninth.csv", "runs_twelfth.csv"),
    ("runs_twentyninth.csv", "runs_twentyseventh.csv"),
    ("runs_twentyninth.csv", "runs_twentyeighth.csv"),
    ("runs_twentythird.csv", "runs_twentysecond.csv"),
    ("runs_twentyfourth.csv", "runs_twentysecond.csv"),
    ("runs_twentyfifth.csv", "runs_twentysecond.csv"),
    ("runs_twentysixth.csv", "runs_twentysecond.csv"),
    ("runs_twentyfifth_worldcup.csv", None),
    ("runs_thirtysecond.csv", "runs_eighteenth.csv"),
    ("runs_thirtysecond.csv", "runs_twentieth.csv"),
    ("runs_thirtysecond.csv", "runs_sixteenth.csv"),
    ("runs_thirtysecond.csv", "runs_seventeenth.csv"),
    ("runs_thirtythird.csv", "runs_fifteenth.csv"),
    ("runs_thirtythird.csv", "runs_fourteenth.csv"),
    ("runs_twentyninth.csv", "runs_thirtyfourth.csv"),
    ("runs_thirtyfourth.csv", "runs_fourteenth.csv"),
    ("runs_twentyninth.csv", "runs_thirtyfifth.csv"),
]

DATASETS = ["intersection-1", "intersection-2", "intersection-3", "intersection-4", "intersection-5",
            "mixed-1", "mixed-4", "mixed-5", "worldcup2014"]
LOSSES = {"top-mse": "Top-MSE", "mse": "MSE", "top-dice": "Top-Dice", "dice": "Dice"}
MODELS = ["proposed", "sha2020"]
A, B = "training=end-to-end", "training=step-by-step"


def signed(value: float) -> str:
    """``+2.34`` / ``−3.05``: a difference as the report prints it (a true minus sign)."""
    return f"{value:+.2f}".replace("-", "\u2212")


def interval(cell: pd.Series) -> str:
    """``−0.35 [−1.47, +0.78]``: a paired difference and its 95 % t interval."""
    return f"{signed(cell['mean'])} [{signed(cell['t_low'])}, {signed(cell['t_high'])}]"


def verdict(cell: pd.Series) -> str:
    """The cell's verdict, the undecided one in the report's short form."""
    return str(cell["verdict"]).replace("consistent with the paper (and with no difference)",
                                        "consistent (and with no difference)")


def devices(archive: Path) -> set[str]:
    """The devices an archive's runs trained on (``cpu``, ``cuda``)."""
    return set(read_archive(archive)["device"].dropna())


def provenance(archive: str, against: str | None) -> str:
    """``twentyninth − eleventh (CPU, one clone)``: the pair's archives, short, and where their runs ran."""
    short = {name: name.removeprefix("runs_").removesuffix(".csv") for name in (archive, against) if name}
    if against is None:
        return f"{short[archive]} (CPU, one archive)"
    gpu = ["GPU" if "cuda" in devices(RESULTS / name) else "CPU" for name in (archive, against)]
    where = "CPU, one clone" if gpu == ["CPU", "CPU"] else " − ".join(gpu)
    return f"{short[archive]} − {short[against]} ({where})"


def pair_cells(archive: str, against: str | None) -> pd.DataFrame:
    """Every judged cell of one pair, both readings side by side (suffixes ``_iou``, ``_iou_weighted``)."""
    readings = [
        synthcal.paired_differences(RESULTS / archive, A, B, metric=metric,
                                    against=None if against is None else RESULTS / against)
        .set_index(["dataset", "model", "loss", "matching_score"]).add_suffix(f"_{metric}")
        for metric in ("iou", "iou_weighted")
    ]
    cells = readings[0].join(readings[1], how="inner").reset_index()
    return cells.assign(archives=provenance(archive, against))


def table(pairs: list[tuple[str, str | None]] = PAIRS) -> list[str]:
    """The report's Markdown table of end-to-end − step-by-step, a line per row (its header first)."""
    cells = pd.concat([pair_cells(archive, against) for archive, against in pairs], ignore_index=True)
    several_matchings = cells.groupby(["dataset", "model"])["matching_score"].transform("nunique") > 1
    order = [cells["dataset"].map(DATASETS.index), cells["loss"].map(list(LOSSES).index),
             cells["matching_score"].map(list(LOSSES).index), cells["model"].map(MODELS.index)]
    cells = cells.assign(several_matchings=several_matchings, _d=order[0], _l=order[1], _m=order[2], _o=order[3])
    cells = cells.sort_values(["_d", "_l", "_m", "_o"], kind="stable")
    lines = [
        "| cell | archives, end to end − step by step | paper | `iou` [95 % CI] | verdict | `iou_weighted` [95 % CI] "
        "| verdict |",
        "|:---|:---|---:|---:|:---|---:|:---|",
    ]
    for _, cell in cells.iterrows():
        dataset = cell["dataset"] if cell["dataset"].startswith("intersection-") else f"`{cell['dataset']}`"
        loss = LOSSES[cell["loss"]]
        if cell["several_matchings"]:
            loss += f" (matching {LOSSES[cell['matching_score']]})"
        iou, weighted = (pd.Series({key: cell[f"{key}_{metric}"] for key in ("mean", "t_low", "t_high", "verdict")})
                         for metric in ("iou", "iou_weighted"))
        lines.append(
            f"| {dataset}, {loss}, {cell['model']} | {cell['archives']} | {signed(cell['paper_iou'])} "
            f"| {interval(iou)} | {verdict(iou)} | {interval(weighted)} | {verdict(weighted)} |"
        )
    return lines


if __name__ == "__main__":
    print("\n".join(table()))
