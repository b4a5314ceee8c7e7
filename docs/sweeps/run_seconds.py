"""Seconds per trained run in every committed archive (reproduction.md, "Budget: runs × minutes, measured").

Reads ``docs/results/runs_*.csv`` (the runs layout of ``synthcal table``, whose ``seconds`` column is each run's wall
time, the three-rate selection included) and prints one Markdown row per device, maps, training, model and kind of
dataset: how many runs, the median and the range of their seconds. The CPU runs ran two side by side with one torch
thread each on the 2-core machine; the GPU runs all side by side on one H200.

Run it from anywhere: ``python docs/sweeps/run_seconds.py`` (it finds ``docs/results`` beside itself).
"""

from pathlib import Path

import pandas as pd

from synthcal.eval.archive import read_archive

RESULTS = Path(__file__).resolve().parents[1] / "results"


def dataset_kind(dataset: str) -> str:
    """Group a dataset name with those of its size: the single intersections, the mixes, the real data."""
    if dataset.startswith("intersection-"):
        return "intersections 1–5"
    if dataset == "worldcup2014":
        return "World Cup 2014"
    return "mixes"


runs = pd.concat([read_archive(path) for path in sorted(RESULTS.glob("runs_*.csv"))], ignore_index=True)
runs = runs[runs["seconds"].notna() & (runs["status"] == "ok")].assign(kind=runs["dataset"].map(dataset_kind))
keys = ["device", "segmentation", "training", "model", "kind"]
print("| device | maps | training | model | datasets | runs | median s | range s |")
print("|:---|:---|:---|:---|:---|---:|---:|---:|")
for key, seconds in runs.groupby(keys)["seconds"]:
    device, maps, training, model, kind = key
    maps = "UNet" if maps == "unet" else "true"
    print(
        f"| {device} | {maps} | {training} | `{model}` | {kind} | {len(seconds)} | {seconds.median():,.0f} "
        f"| {seconds.min():,.0f}–{seconds.max():,.0f} |"
    )
