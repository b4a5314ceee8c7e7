"""The report's summary of the selection score: proposed − sha2020 with the fits ranked by validation ``L_warp`` and
by validation ``iou``, and how far the score moves that gap (reproduction.md, "Does the selection score decide a
verdict?").

A cell's two readings come from two archives of the same cell (dataset, loss, step by step, Top-MSE matching, true
maps, the quick profile, seeds 0–4): one ranked by ``L_warp``, one by ``iou`` (``--selection-score iou``). Per seed
the gap is proposed − ``sha2020`` on the same split; the shift is the ``iou``-ranked gap − the ``L_warp``-ranked gap
of that seed (a difference of paired differences), with its 95 % t interval over the seeds. The report's table is
this script's output (tests/eval/test_committed_archives.py checks it), so a new cell goes in ``CELLS``, then the
script's output replaces the table.

Run it from anywhere: ``python docs/sweeps/selection_table.py`` (it finds ``docs/results`` beside itself).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
from report_figures import interval

from synthcal.eval.archive import read_archive
from synthcal.eval.statistics import t_interval

RESULTS = Path(__file__).resolve().parents[1] / "results"

# (dataset, loss, archive ranked by L_warp, archive ranked by iou), in the order the report measured them.
# Intersection-1 with Top-MSE is not here: its proposed runs ranked by L_warp were lost (report_iou.csv's summary).
CELLS = [
    ("intersection-2", "top-mse", "runs_thirteenth.csv", "runs_twentyfourth_iou.csv"),
    ("intersection-3", "top-mse", "runs_thirtyfourth.csv", "runs_fortyfifth_iou.csv"),
    ("intersection-4", "top-mse", "runs_thirtyfifth.csv", "runs_fortysixth_iou.csv"),
    ("intersection-5", "top-mse", "runs_thirtyfifth.csv", "runs_fortyseventh_iou.csv"),
    ("intersection-1", "dice", "runs_tenth.csv", "runs_fortyseventh_iou.csv"),
    ("intersection-2", "dice", "runs_eleventh.csv", "runs_fortyseventh_iou.csv"),
    ("intersection-3", "dice", "runs_twentyeighth.csv", "runs_fortyseventh_iou.csv"),
    ("intersection-4", "dice", "runs_twentyeighth.csv", "runs_fortyseventh_iou.csv"),
    ("intersection-5", "dice", "runs_twentyeighth.csv", "runs_fortyseventh_iou.csv"),
]
LOSSES = {"top-mse": "Top-MSE", "dice": "Dice"}
MODELS = ("proposed", "sha2020")
CELL = {"training": "step-by-step", "matching_score": "top-mse", "segmentation": "ground-truth", "profile": "quick"}


@cache
def runs(archive: str) -> pd.DataFrame:
    """An archive's finished runs."""
    return read_archive(RESULTS / archive)


def gaps(archive: str, dataset: str, loss: str, metric: str) -> pd.Series:
    """(seeds,) proposed − ``sha2020`` per split seed, in ``metric`` points, of one cell of an archive.

    Raises:
        ValueError: a seed of the cell lacks a model's run, or has two (naming the archive and cell).
    """
    frame = runs(archive)
    keys = {**CELL, "dataset": dataset, "loss": loss}
    cell = frame[(frame[list(keys)] == pd.Series(keys)).all(axis=1) & frame["estimator"].isin(MODELS)]
    table = cell.pivot_table(index="seed", columns="estimator", values=metric, aggfunc="count")
    if table.empty or set(table.columns) != set(MODELS) or table.isna().any().any() or (table != 1).any().any():
        raise ValueError(f"{archive}: {dataset} {loss}: not one run of each of {MODELS} on every seed")
    values = cell.pivot(index="seed", columns="estimator", values=metric) * 100
    return values["proposed"] - values["sha2020"]


def reading(differences: pd.Series) -> str:
    """``−0.35 [−1.47, +0.78]``: the mean of per-seed differences and its 95 % t interval."""
    low, high, _ = t_interval(differences.to_numpy())
    return interval(float(differences.mean()), low, high)


def row(dataset: str, loss: str, by_loss: str, by_iou: str, metric: str) -> tuple[str, str, str, np.ndarray]:
    """One cell's readings under ``metric``: ranked by ``L_warp``, by ``iou``, the shift, and the per-seed shifts."""
    before, after = gaps(by_loss, dataset, loss, metric), gaps(by_iou, dataset, loss, metric)
    if list(before.index) != list(after.index):
        raise ValueError(f"{dataset} {loss}: seeds {list(before.index)} in {by_loss}, {list(after.index)} in {by_iou}")
    shift = after - before
    return reading(before), reading(after), reading(shift), shift.to_numpy()


def lines() -> list[str]:
    """The report's table as Markdown lines (its header first), then one line over every cell's seeds."""
    rows = ["| cell | archives, `L_warp` / `iou` | `iou` by `L_warp` | by `iou` | shift [95 % CI] "
            "| `iou_weighted` by `L_warp` | by `iou` | shift [95 % CI] |",
            "|:---|:---|---:|---:|---:|---:|---:|---:|"]
    shifts: dict[str, list[np.ndarray]] = {"iou": [], "iou_weighted": []}
    for dataset, loss, by_loss, by_iou in CELLS:
        cells = []
        for metric in shifts:
            *printed, per_seed = row(dataset, loss, by_loss, by_iou, metric)
            shifts[metric].append(per_seed)
            cells.extend(printed)
        names = " / ".join(name.removeprefix("runs_").removesuffix(".csv") for name in (by_loss, by_iou))
        rows.append(f"| {dataset}, {LOSSES[loss]} | {names} | {' | '.join(cells)} |")
    datasets = pd.Series([dataset for dataset, *_ in CELLS])
    means = {metric: pd.Series([float(s.mean()) for s in per_cell]) for metric, per_cell in shifts.items()}
    # A dataset's cells share its stores and split seeds, so they are not independent: average them first too.
    by_dataset = {metric: cell_means.groupby(datasets).mean() for metric, cell_means in means.items()}
    rows.append("")
    rows.append(f"Over the {len(CELLS)} cells the mean shift is {reading(means['iou'])} `iou` and "
                f"{reading(means['iou_weighted'])} `iou_weighted` (a t interval over the cells' means); averaged "
                f"within each of the {datasets.nunique()} datasets first, {reading(by_dataset['iou'])} and "
                f"{reading(by_dataset['iou_weighted'])}.")
    return rows


if __name__ == "__main__":
    print("\n".join(lines()))
