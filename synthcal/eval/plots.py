"""Figures of a results folder: IoU per dataset and estimator, and overlays.

Both show one metric (``value``: a column of :data:`synthcal.config.METRICS`,
e.g. ``iou_weighted``), named in the axis label and titles: a fraction in percent, a
pixel error (:data:`synthcal.config.PIXEL_METRICS`) in pixels.

* :func:`plot_iou` — one group of bars per dataset, one bar per configuration
  (model and the keys that vary), height the mean over seeds of the per-run mean
  of the metric, error bar the standard deviation over seeds (ddof = 1, as the tables).
* :func:`plot_overlays` — for a few test images of one seed: the image with its
  true semantic map, then with the map each configuration's estimate renders
  (the estimate stored in the run's ``metrics.csv``, oriented and drawn with the
  generator's renderer), the image's metric in the title ("–" where a run recorded
  before the metric existed has none), under a legend of the classes the overlays
  tint (the scene's classes 1–3 in its palette colours; background is left
  untinted). Nothing is re-run. :func:`overlay_figure` is the same figure, unsaved.

Figures are drawn on :class:`matplotlib.figure.Figure` objects and written with
their own ``savefig`` (Agg for PNG): no pyplot, so no global figure state and no
backend choice at import — callers that use pyplot keep theirs, and no display is
needed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from synthcal.config import PIXEL_METRICS
from synthcal.data import read_scene
from synthcal.eval.metrics import check_homography
from synthcal.generate.render import render_semantic
from synthcal.store import open_store, read_samples
from synthcal.viz import overlay

__all__ = ["configuration_labels", "plot_iou", "overlay_figure", "plot_overlays"]

_KEYS = ("model", "training", "loss", "matching_score", "segmentation")
_H_COLUMNS = [f"h{r}{c}" for r in range(3) for c in range(3)]


def configuration_labels(runs: pd.DataFrame) -> pd.Series:
    """A short label per run: the model, then the keys whose values vary among the runs.

    A key an estimator has no value for (identity's loss) does not count as varying.
    """
    varying = [k for k in _KEYS[1:] if runs[k].nunique() > 1]
    def label(row: pd.Series) -> str:
        extra = [str(row[k]) for k in varying if pd.notna(row[k])]
        return row["model"] + (f" ({', '.join(extra)})" if extra else "")
    return runs.apply(label, axis=1)


def plot_iou(runs: pd.DataFrame, path: str | Path, value: str = "iou") -> Path:
    """Bar chart of ``value`` (percent) per dataset and configuration, ± std over seeds.

    Args:
        runs: :func:`synthcal.eval.harness.collect_results`.
        path: the PNG to write.
        value: the metric column.

    Returns:
        ``path``.
    """
    frame = runs.assign(config=configuration_labels(runs))
    scale = 1 if value in PIXEL_METRICS else 100
    stats = frame.groupby(["dataset", "config"], sort=False)[value].agg(["mean", "std", "count"]) * [scale, scale, 1]
    datasets = list(dict.fromkeys(frame["dataset"]))
    configs = list(dict.fromkeys(frame["config"]))
    width = 0.8 / len(configs)
    fig = Figure(figsize=(max(6.0, 1.2 * len(datasets) * max(1, len(configs)) * 0.5), 4.0))
    ax = fig.subplots()
    for k, config in enumerate(configs):
        rows = [stats.loc[(d, config)] if (d, config) in stats.index else None for d in datasets]
        means = [np.nan if r is None else r["mean"] for r in rows]
        errors = [0.0 if r is None or not np.isfinite(r["std"]) else r["std"] for r in rows]
        ax.bar(np.arange(len(datasets)) + (k - (len(configs) - 1) / 2) * width, means, width, yerr=errors,
               capsize=3, label=config)
    ax.set_xticks(np.arange(len(datasets)), datasets)
    if value in PIXEL_METRICS:  # unbounded above (an inf bar is not drawn)
        ax.set_ylabel(f"{value} (px)")
        ax.set_ylim(bottom=0)
    else:
        ax.set_ylabel(f"{value} (%)")
        ax.set_ylim(0, 100)
    n = sorted(frame.groupby(["dataset", "config"])["seed"].nunique().unique())
    ax.set_title(f"{value}: mean ± std over {'/'.join(map(str, n))} seeds")
    ax.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path


def _estimated_map(scene_semantic: np.ndarray, estimate: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """The class map an estimate renders (all background for a failure)."""
    H, _ = check_homography(estimate.reshape(3, 3), image_size)
    if H is None:
        return np.zeros(image_size[::-1], np.uint8)
    return render_semantic(scene_semantic, H, image_size)


def _percent(frame: pd.DataFrame, row: int, value: str) -> str:
    """``87.5 %`` (``3.2 px``): one test image's metric from a run's ``metrics.csv``; "–" where it has none."""
    score = frame.loc[row, value] if value in frame.columns else np.nan
    if pd.isna(score):
        return "–"
    return f"{score:.1f} px" if value in PIXEL_METRICS else f"{100 * score:.1f} %"


def plot_overlays(results: str | Path, runs: pd.DataFrame, dataset: str, path: str | Path, count: int = 3,
                  max_configs: int = 4, value: str = "iou") -> Path:
    """Test images of ``dataset`` with the true map and each configuration's estimate, written as a PNG.

    Args:
        path: the PNG to write.
        others: as :func:`overlay_figure`.

    Returns:
        ``path``.
    """
    fig = overlay_figure(results, runs, dataset, count, max_configs, value)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path


def overlay_figure(results: str | Path, runs: pd.DataFrame, dataset: str, count: int = 3, max_configs: int = 4,
                   value: str = "iou") -> Figure:
    """The figure of :func:`plot_overlays`: test images of ``dataset``, the true map, each estimate's, a legend.

    Uses the lowest seed; the test images are spread evenly over the test split.

    Args:
        results: the results folder (for the runs' ``metrics.csv`` and ``run.json``).
        runs: :func:`synthcal.eval.harness.collect_results`.
        dataset: which dataset.
        count: test images (rows).
        max_configs: at most this many configurations (columns after the truth).
        value: the metric column of ``metrics.csv`` in each estimate's title.

    Returns:
        The figure; its one figure legend names the tinted classes (module docstring).
    """
    chosen = runs[runs["dataset"] == dataset]
    chosen = chosen[chosen["seed"] == chosen["seed"].min()].assign(config=configuration_labels(chosen))
    chosen = chosen.drop_duplicates("config")
    # One configuration of each model first, then the others, up to max_configs.
    chosen = chosen.assign(first=~chosen["model"].duplicated()).sort_values("first", ascending=False, kind="stable")
    chosen = chosen.head(max_configs)
    folder = Path(results) / "runs"
    metrics = {r.config: pd.read_csv(folder / r.run_id / "metrics.csv") for r in chosen.itertuples()}
    store = json.loads((folder / chosen["run_id"].iloc[0] / "run.json").read_text())["run"]["store"]
    scene = read_scene(store)
    first = next(iter(metrics.values()))
    rows = np.linspace(0, len(first) - 1, min(count, len(first))).round().astype(int)
    samples = read_samples(open_store(store), first["pool_index"].to_numpy()[rows])
    height, width = samples["semantic"].shape[1:]
    fig = Figure(figsize=(2.6 * (1 + len(metrics)), 1.7 * len(rows)))
    axes = fig.subplots(len(rows), 1 + len(metrics), squeeze=False)
    for i, row in enumerate(rows):
        image = samples["image"][i]
        axes[i, 0].imshow(overlay(image, samples["semantic"][i], scene.palette))
        axes[i, 0].set_title("truth", fontsize=8)
        for j, (config, frame) in enumerate(metrics.items(), start=1):
            estimate = frame.loc[row, _H_COLUMNS].to_numpy(np.float64)
            axes[i, j].imshow(overlay(image, _estimated_map(scene.semantic, estimate, (width, height)),
                                      scene.palette))
            axes[i, j].set_title(f"{config}\n{value} {_percent(frame, row, value)}", fontsize=7)
    for ax in axes.flat:
        ax.axis("off")
    fig.suptitle(f"{dataset}: estimated vs true semantic map ({value} per image)", fontsize=9)
    # Class 0 is never tinted (synthcal.viz.overlay): only the classes a reader sees coloured.
    handles = [Patch(facecolor=(r / 255, g / 255, b / 255), edgecolor="grey", label=scene.classes[k])
               for k, (r, g, b) in enumerate(scene.palette.tolist()) if k > 0]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, 0.0), title="tinted classes", title_fontsize=8)
    return fig
