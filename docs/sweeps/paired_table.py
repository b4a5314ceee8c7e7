"""The report's tables of paired differences across committed archives (reproduction.md).

Four tables, each a list of archive pairs: ``training`` ("End to end against step by step": end to end − step by
step of the same model, seed, split and settings), ``matching`` ("The matching score": the proposed model with
Top-MSE matching − with MSE matching), ``top-mse-loss`` and ``top-dice-loss`` ("The topological loss against its
conventional version", under MSE matching: Top-MSE − MSE and Top-Dice − Dice). A pair names the archive of side A's
runs and the archive of side B's (None: the same archive holds both); ``synthcal table docs/results/A --against
docs/results/B --paired A_KEY B_KEY [--metric iou_weighted]`` prints its cells. This script prints a table's cells
of every pair as one Markdown table, a row per cell with both readings. The report's tables are this script's output
(tests/eval/test_committed_archives.py checks them), so a new pair goes in the list below, then the script's output
replaces the table. Where two pairs give the same cell, the later pair's is printed (a rerun of both sides on one
clone, listed after the pair across devices it supersedes).

Run it from anywhere: ``python docs/sweeps/paired_table.py training|matching|top-mse-loss|top-dice-loss`` (it finds
``docs/results`` beside itself).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pandas as pd
from report_figures import interval, signed

import synthcal
from synthcal.eval.archive import read_archive

RESULTS = Path(__file__).resolve().parents[1] / "results"

DATASETS = ["intersection-1", "intersection-2", "intersection-3", "intersection-4", "intersection-5",
            "mixed-1", "mixed-4", "mixed-5", "worldcup2014"]
LOSSES = {"top-mse": "Top-MSE", "mse": "MSE", "top-dice": "Top-Dice", "dice": "Dice"}
TRAININGS = {"step-by-step": "step by step", "end-to-end": "end to end"}
MODELS = ["proposed", "sha2020"]
CELL_KEYS = ["dataset", "model", "loss", "matching_score", "training"]


@dataclass(frozen=True)
class PairedTable:
    """A report table: the two sides compared, the archive pairs, and how its rows are labelled."""

    a: str
    b: str
    title: str  # the archives column's header
    pairs: list[tuple[str, str | None]]
    only: tuple[str, str] | None = None  # (key, value): the cells kept, when a pair's archives hold others too

    @property
    def key(self) -> str:
        """The key the sides differ in (``training``, ``matching_score``, ``loss``)."""
        return self.a.split("=")[0]

    @property
    def other(self) -> str:
        """The key besides dataset, loss and model that tells a table's rows apart, sorted on after the loss."""
        return "matching_score" if self.key == "training" else "training"


TABLES = {
    # (end-to-end archive, step-by-step archive or None), in the order they were measured.
    "training": PairedTable("training=end-to-end", "training=step-by-step", "archives, end to end − step by step", [
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
        ("runs_thirtysixth.csv", "runs_twentyeighth.csv"),
        ("runs_thirtyeighth.csv", "runs_thirtyseventh.csv"),
        ("runs_fortieth.csv", "runs_fortyfirst.csv"),
        ("runs_fortysecond.csv", "runs_thirtyninth.csv"),
        ("runs_fiftieth.csv", None),
        ("runs_fiftieth.csv", "runs_fortyninth.csv"),
        ("runs_fiftieth.csv", "runs_fiftyfirst.csv"),
        ("runs_sixteenth.csv", "runs_fiftyfirst.csv"),
        ("runs_fiftysecond.csv", "runs_fiftieth.csv"),
        ("runs_fiftysecond.csv", "runs_eleventh.csv"),
        ("runs_seventeenth.csv", "runs_fiftythird.csv"),
        ("runs_fiftieth.csv", "runs_fiftythird.csv"),
        ("runs_fiftyeighth.csv", "runs_eleventh.csv"),
    ]),
    # (Top-MSE-matching archive, MSE-matching archive or None).
    "matching": PairedTable("matching_score=top-mse", "matching_score=mse", "archives, Top-MSE − MSE matching", [
        ("runs_twentyfifth_worldcup.csv", None),
        ("runs_twentyeighth.csv", None),
        ("runs_twentyninth.csv", "runs_thirtysixth.csv"),
        ("runs_thirtyfourth.csv", "runs_thirtyseventh.csv"),
        ("runs_thirtyfifth.csv", "runs_thirtyseventh.csv"),
        ("runs_twentyninth.csv", "runs_thirtyeighth.csv"),
        ("runs_twentyseventh.csv", "runs_thirtyninth.csv"),
        ("runs_twentyninth.csv", "runs_fortieth.csv"),
        ("runs_eleventh.csv", "runs_fortyfirst.csv"),
        ("runs_twelfth.csv", "runs_fortyfirst.csv"),
        ("runs_twentyninth.csv", "runs_fortysecond.csv"),
        ("runs_tenth.csv", "runs_fortyninth.csv"),
        ("runs_twentyfirst.csv", "runs_fiftieth.csv"),
        ("runs_eleventh.csv", "runs_fiftieth.csv"),
        ("runs_tenth.csv", "runs_fiftieth.csv"),
        ("runs_eighteenth.csv", "runs_fiftieth.csv"),
        ("runs_seventeenth.csv", "runs_fiftieth.csv"),
        ("runs_sixteenth.csv", "runs_fiftieth.csv"),
        ("runs_fiftyfirst.csv", None),
        ("runs_fiftysecond.csv", None),
        ("runs_fiftythird.csv", None),
    ]),
    # (Top-MSE archive, MSE archive or None): the proposed model under MSE matching; the Top-MSE-matching cells are
    # the report's hand-kept tables above them.
    "top-mse-loss": PairedTable("loss=top-mse", "loss=mse", "archives, Top-MSE − MSE", [
        ("runs_twentyfifth_worldcup.csv", None),
        ("runs_thirtyseventh.csv", "runs_fortyfirst.csv"),
        ("runs_thirtyeighth.csv", "runs_fortieth.csv"),
        ("runs_fiftieth.csv", None),
        ("runs_fiftythird.csv", "runs_fiftyfirst.csv"),
    ], only=("matching_score", "mse")),
    # (Top-Dice archive, Dice archive or None), as above.
    "top-dice-loss": PairedTable("loss=top-dice", "loss=dice", "archives, Top-Dice − Dice", [
        ("runs_twentyfifth_worldcup.csv", None),
        ("runs_thirtyninth.csv", "runs_twentyeighth.csv"),
        ("runs_fortysecond.csv", "runs_thirtysixth.csv"),
        ("runs_fiftieth.csv", None),
        ("runs_fiftieth.csv", "runs_fortyninth.csv"),
        ("runs_fiftysecond.csv", None),
    ], only=("matching_score", "mse")),
}


def verdict(text: str) -> str:
    """A verdict, the undecided one in the report's short form."""
    return text.replace("consistent with the paper (and with no difference)", "consistent (and with no difference)")


@cache
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


def pair_cells(table: PairedTable, archive: str, against: str | None) -> pd.DataFrame:
    """Every cell of one pair, both readings side by side (suffixes ``_iou``, ``_iou_weighted``)."""
    keys = [key for key in CELL_KEYS if key != table.key]
    readings = [
        synthcal.paired_differences(RESULTS / archive, table.a, table.b, metric=metric,
                                    against=None if against is None else RESULTS / against)
        .set_index(keys).add_suffix(f"_{metric}")
        for metric in ("iou", "iou_weighted")
    ]
    cells = readings[0].join(readings[1], how="inner").reset_index()
    if table.only is not None:
        key, value = table.only
        cells = cells[cells[key] == value]
    return cells.assign(archives=provenance(archive, against))


def label(cell: pd.Series, table: PairedTable, several_matchings: bool) -> str:
    """``intersection-3, Dice, proposed`` / ```worldcup2014`, Dice (matching MSE), proposed`` /
    ``intersection-3, Dice, end to end, proposed`` / ``intersection-3, end to end, proposed``: what a row compares,
    the paired key left out (and the loss tables' one matching score)."""
    dataset = cell["dataset"] if cell["dataset"].startswith("intersection-") else f"`{cell['dataset']}`"
    if table.key == "loss":
        return f"{dataset}, {TRAININGS[cell['training']]}, {cell['model']}"
    loss = LOSSES[cell["loss"]]
    if table.key == "training":
        matching = f" (matching {LOSSES[cell['matching_score']]})" if several_matchings else ""
        return f"{dataset}, {loss}{matching}, {cell['model']}"
    return f"{dataset}, {loss}, {TRAININGS[cell['training']]}, {cell['model']}"


def lines(name: str) -> list[str]:
    """A report table as Markdown lines (its header first): rows sorted by dataset, the other keys, model."""
    table = TABLES[name]
    cells = pd.concat([pair_cells(table, archive, against) for archive, against in table.pairs], ignore_index=True)
    # a cell two pairs give is the later pair's: a rerun on one clone supersedes a pair across devices
    cells = cells.drop_duplicates([key for key in CELL_KEYS if key != table.key], keep="last", ignore_index=True)
    other = table.other
    orders = {"dataset": DATASETS, "loss": list(LOSSES), "matching_score": list(LOSSES), "training": list(TRAININGS),
              "model": MODELS}
    sort_keys = [key for key in ("dataset", "loss", other, "model") if key != table.key]
    ranks = pd.DataFrame({key: cells[key].map(orders[key].index) for key in sort_keys})
    cells = cells.loc[ranks.sort_values(sort_keys, kind="stable").index]
    several = cells.groupby(["dataset", "model"])[other].transform("nunique") > 1
    rows = [f"| cell | {table.title} | paper | `iou` [95 % CI] | verdict | `iou_weighted` [95 % CI] | verdict |",
            "|:---|:---|---:|---:|:---|---:|:---|"]
    for index, cell in cells.iterrows():
        readings = [
            f"{interval(cell[f'mean_{m}'], cell[f't_low_{m}'], cell[f't_high_{m}'])} | {verdict(cell[f'verdict_{m}'])}"
            for m in ("iou", "iou_weighted")
        ]
        rows.append(f"| {label(cell, table, bool(several[index]))} | {cell['archives']} | {signed(cell['paper_iou'])} "
                    f"| {readings[0]} | {readings[1]} |")
    return rows


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] not in TABLES:
        raise SystemExit(f"usage: python {Path(__file__).name} {'|'.join(TABLES)}")
    print("\n".join(lines(sys.argv[1])))
