"""The per-seed table of each "The UNet in the loop" section of docs/reproduction.md.

One cell is a dataset and an STN loss, step by step, Top-MSE matching, the quick profile, the seeds its UNet archive
holds (0–4 once complete), with the UNet in the loop (``--segmentation unet``, docs/sweeps/unet30w.yaml) in one archive and the same cell on true maps in another.
Per seed: each model's ``iou`` on the UNet's maps beside its ``iou`` on true maps, proposed − ``sha2020`` on the
UNet's maps, and both models' ``iou_weighted`` on the UNet's maps; the last row gives mean ± std over the seeds and
the difference's 95 % t interval. The report's tables are this script's output (tests/eval/test_committed_archives.py
checks each against its section, and the section's difference of the two models' UNet costs against `synthcal table
--between`), so a new cell goes in ``CELLS``, then the script's output goes in its section.

Run it from anywhere: ``python docs/sweeps/unet_table.py DATASET LOSS`` (it finds ``docs/results`` beside itself).
"""

from __future__ import annotations

import sys
from functools import cache
from pathlib import Path
from typing import NamedTuple

import pandas as pd
from report_figures import interval, signed

from synthcal.eval.archive import read_archive
from synthcal.eval.statistics import t_interval

RESULTS = Path(__file__).resolve().parents[1] / "results"
MODELS = ("sha2020", "proposed")


class Cell(NamedTuple):
    """A UNet cell: its report section's heading and the archives of its true-map and UNet-map runs."""

    section: str
    true_maps: str
    unet_maps: str


# (dataset, loss) → the cell, in the order the report measured them. Intersection-1 has no runs archive of its UNet
# runs (they predate the archives; its section quotes the results folders' tables).
CELLS = {
    ("intersection-2", "top-mse"): Cell("## The UNet in the loop (intersection-2, Top-MSE)", "runs_thirteenth.csv",
                                        "runs_unet30w_intersection2.csv"),
    ("intersection-3", "top-mse"): Cell("## The UNet in the loop (intersection-3, Top-MSE)", "runs_thirtyfourth.csv",
                                        "runs_unet30w_intersection3.csv"),
    ("intersection-4", "top-mse"): Cell("## The UNet in the loop (intersection-4, Top-MSE)", "runs_thirtyfifth.csv",
                                        "runs_unet30w_intersection4.csv"),
    ("intersection-5", "top-mse"): Cell("## The UNet in the loop (intersection-5, Top-MSE)", "runs_thirtyfifth.csv",
                                        "runs_unet30w_intersection5.csv"),
    **{(f"intersection-{k}", "top-dice"): Cell(f"## The UNet in the loop with Top-Dice (intersection-{k})",
                                               "runs_twentyseventh.csv", f"runs_unet30w_topdice_intersection{k}.csv")
       for k in (3, 4, 5)},
    ("intersection-3", "dice"): Cell("## The UNet in the loop with Dice (intersection-3)",
                                     "runs_twentyeighth.csv", "runs_unet30w_dice_intersection3.csv"),
}
CELL_KEYS = {"training": "step-by-step", "matching_score": "top-mse", "profile": "quick"}


@cache
def runs(archive: str) -> pd.DataFrame:
    """An archive's finished runs."""
    return read_archive(RESULTS / archive)


def readings(archive: str, dataset: str, loss: str, segmentation: str, metric: str,
             seeds: list[int] | None = None) -> pd.DataFrame:
    """(seeds, models) ``metric`` in percent of one cell of an archive, on ``seeds`` (None: those it holds).

    Raises:
        ValueError: a seed of the cell lacks a model's run, or has two (naming the archive and cell).
    """
    frame = runs(archive)
    keys = {**CELL_KEYS, "dataset": dataset, "loss": loss, "segmentation": segmentation}
    cell = frame[(frame[list(keys)] == pd.Series(keys)).all(axis=1) & frame["model"].isin(MODELS)]
    seeds = sorted(set(cell["seed"])) if seeds is None else seeds
    counts = cell.groupby(["seed", "model"]).size().unstack("model").reindex(index=seeds, columns=list(MODELS))
    if not seeds or (counts != 1).any().any():
        raise ValueError(f"{archive}: {dataset} {loss} on {segmentation} maps: not one run of each of {MODELS} on "
                         f"every seed {seeds}")
    return cell.pivot(index="seed", columns="model", values=metric).loc[seeds, list(MODELS)] * 100


def _spread(values: pd.Series) -> str:
    return f"{values.mean():.2f} ± {values.std(ddof=1):.2f}"


def lines(dataset: str, loss: str) -> list[str]:
    """The section's table as Markdown lines, its header first."""
    cell = CELLS[(dataset, loss)]
    unet = readings(cell.unet_maps, dataset, loss, "unet", "iou")
    seeds = list(unet.index)
    true = readings(cell.true_maps, dataset, loss, "ground-truth", "iou", seeds)
    weighted = readings(cell.unet_maps, dataset, loss, "unet", "iou_weighted", seeds)
    gap = unet["proposed"] - unet["sha2020"]
    rows = ["| seed | `sha2020`, UNet maps | true maps | `proposed`, UNet maps | true maps | proposed − sha2020, UNet "
            "maps | `iou_weighted` (sha2020 / proposed) |",
            "|:---|---:|---:|---:|---:|---:|:---|"]
    for seed in seeds:
        rows.append(f"| {seed} | {unet.at[seed, 'sha2020']:.2f} | {true.at[seed, 'sha2020']:.2f} | "
                    f"{unet.at[seed, 'proposed']:.2f} | {true.at[seed, 'proposed']:.2f} | {signed(gap[seed])} | "
                    f"{weighted.at[seed, 'sha2020']:.2f} / {weighted.at[seed, 'proposed']:.2f} |")
    low, high, _ = t_interval(gap.to_numpy())
    label = "mean ± std" if len(seeds) == 5 else f"mean ± std ({len(seeds)} seeds)"  # an archive under way
    rows.append(f"| {label} | {_spread(unet['sha2020'])} | {_spread(true['sha2020'])} | "
                f"{_spread(unet['proposed'])} | {_spread(true['proposed'])} | {interval(float(gap.mean()), low, high)} | "
                f"{_spread(weighted['sha2020'])} / {_spread(weighted['proposed'])} |")
    return rows


if __name__ == "__main__":
    if len(sys.argv) != 3 or tuple(sys.argv[1:]) not in CELLS:
        sys.exit(f"usage: unet_table.py DATASET LOSS, one of: {', '.join(' '.join(key) for key in CELLS)}")
    print("\n".join(lines(*sys.argv[1:])))
