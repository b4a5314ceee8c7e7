"""The UNet's own segmentation quality, and the readings beside those on true maps (issue 27).

Under ``segmentation: unet`` the paper's models read a UNet's maps, not the true
ones; how good those maps are is a result of its own. This module scores them
(NumPy in, NumPy or pandas out) and reads the results folder; loading the
checkpoints (torch) is :func:`synthcal.api.segmentation_quality`'s.

* :func:`confusion_matrix` — true vs predicted class ids → (C, C) counts;
* :func:`class_scores` — per-class IoU and Dice of a confusion matrix;
* :func:`quality_row` — one split's scores as a flat row (per class, mean over
  the foreground classes, pixel accuracy);
* :func:`seed_summary` — mean ± std of those rows over seeds;
* :func:`unet_records` — the runs of a results folder whose UNet is cached;
* :func:`readings_side_by_side` — each model's reading on the UNet's maps beside
  the same model's on true maps.

Scores are over all pixels of all images of the split pooled (not a mean of
per-image scores): a class absent from one image neither counts as 0 nor as 1
there. A class absent from truth and prediction alike has no score (NaN).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from synthcal.eval.harness import read_record

__all__ = ["FOREGROUND", "SEED_KEYS", "confusion_matrix", "class_scores", "quality_row", "seed_summary",
           "unet_records", "chosen_learning_rate", "readings_side_by_side", "format_quality"]

# Classes 1–3 (the scene's marked classes): class 0, background, covers most of a view and
# would lift a mean over all four classes towards it.
FOREGROUND = (1, 2, 3)
# What identifies one UNet's scores: the dataset it was trained on and the seed of its split.
SEED_KEYS = ("dataset", "seed")


def confusion_matrix(truth: np.ndarray, predicted: np.ndarray, num_classes: int = 4) -> np.ndarray:
    """Pixel counts of (true class, predicted class).

    Args:
        truth: (..., H, W) integer class ids in ``0..num_classes-1``.
        predicted: the same shape.
        num_classes: C.

    Returns:
        (C, C) int64: entry ``[t, p]`` counts pixels of true class ``t`` predicted ``p``
        (rows: truth, as :func:`sklearn.metrics.confusion_matrix`).

    Raises:
        ValueError: different shapes, or a class id outside ``0..C-1`` (names it).
    """
    truth, predicted = np.asarray(truth), np.asarray(predicted)
    if truth.shape != predicted.shape:
        raise ValueError(f"truth {truth.shape} and prediction {predicted.shape} differ in shape")
    for name, ids in (("truth", truth), ("prediction", predicted)):
        if ids.size and (ids.min() < 0 or ids.max() >= num_classes):
            raise ValueError(f"{name}: class ids must lie in 0..{num_classes - 1}; got {ids.min()}..{ids.max()}")
    pairs = truth.astype(np.int64).ravel() * num_classes + predicted.astype(np.int64).ravel()
    return np.bincount(pairs, minlength=num_classes * num_classes).reshape(num_classes, num_classes)


def class_scores(confusion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-class IoU ``TP / (TP + FP + FN)`` and Dice ``2 TP / (2 TP + FP + FN)``.

    Args:
        confusion: (C, C) counts, rows truth, columns prediction (:func:`confusion_matrix`).

    Returns:
        ``(iou, dice)``, each (C,) float64 in [0, 1]; NaN for a class that neither the
        truth nor the prediction holds.
    """
    confusion = np.asarray(confusion, np.float64)
    tp = np.diag(confusion)
    wrong = confusion.sum(axis=0) + confusion.sum(axis=1) - 2 * tp  # FP + FN
    with np.errstate(invalid="ignore", divide="ignore"):
        return tp / (tp + wrong), 2 * tp / (2 * tp + wrong)


def quality_row(confusion: np.ndarray, names: Sequence[str]) -> dict[str, float]:
    """A split's scores as one flat row.

    Args:
        confusion: (C, C) counts (:func:`confusion_matrix`).
        names: the C class names (the store's scene ``classes``).

    Returns:
        ``iou <name>`` and ``dice <name>`` per class, ``mean iou`` and ``mean dice`` over
        :data:`FOREGROUND` (classes without a score left out), ``pixel accuracy``, in that order.
    """
    iou, dice = class_scores(confusion)
    if len(names) != len(iou):
        raise ValueError(f"{len(names)} class names for a {len(iou)}-class confusion matrix")
    row = {f"iou {name}": float(v) for name, v in zip(names, iou, strict=True)}
    row.update({f"dice {name}": float(v) for name, v in zip(names, dice, strict=True)})
    foreground = list(FOREGROUND)
    with np.errstate(invalid="ignore"):
        row["mean iou"] = float(np.nanmean(iou[foreground])) if np.isfinite(iou[foreground]).any() else np.nan
        row["mean dice"] = float(np.nanmean(dice[foreground])) if np.isfinite(dice[foreground]).any() else np.nan
    total = np.asarray(confusion).sum()
    row["pixel accuracy"] = float(np.trace(confusion) / total) if total else np.nan
    return row


def seed_summary(frame: pd.DataFrame, decimals: int = 2) -> pd.DataFrame:
    """Mean ± std over seeds of every score column, in percent, per dataset and set of UNets.

    Models whose learning rate was chosen on validation may read different UNets on
    one seed; each summary row is then the UNets some models read, labelled by them.

    Args:
        frame: one row per UNet: ``dataset``, ``seed``, optionally ``unet`` (an id)
            and ``models`` (the comma-separated labels that read it; without them, one
            group per dataset), and the :func:`quality_row` columns (fractions).
        decimals: of the printed numbers.

    Returns:
        one row per group: ``dataset``, ``models``, ``seeds`` (how many UNets), then
        each score as ``"mean ± std"`` (std with ``ddof=1``; one value alone; ``–`` none).
    """
    scores = [c for c in frame.columns if c.startswith(("iou ", "dice ", "mean ")) or c == "pixel accuracy"]
    rows = []
    for (dataset, models), group in _unet_groups(frame):
        row: dict[str, Any] = {"dataset": dataset, "models": models, "seeds": len(group)}
        for column in scores:
            row[column] = _mean_std(100 * group[column].dropna().to_numpy(np.float64), decimals)
        rows.append(row)
    return pd.DataFrame(rows, columns=["dataset", "models", "seeds", *scores])


def _unet_groups(frame: pd.DataFrame) -> list[tuple[tuple[str, str], pd.DataFrame]]:
    """``((dataset, models), rows)``: the models of a dataset that read the same UNets, grouped."""
    if not {"unet", "models"} <= set(frame.columns):
        return [((str(dataset), ""), group) for dataset, group in frame.groupby("dataset", sort=False)]
    out = []
    for dataset, group in frame.groupby("dataset", sort=False):
        read: dict[str, set[str]] = {}
        for unet, models in zip(group["unet"], group["models"], strict=True):
            for model in str(models).split(", "):
                read.setdefault(model, set()).add(unet)
        shared: dict[frozenset[str], list[str]] = {}
        for model, unets in sorted(read.items()):
            shared.setdefault(frozenset(unets), []).append(model)
        out += [((str(dataset), ", ".join(models)), group[group["unet"].isin(unets)]) for unets, models in shared.items()]
    return out


def _percent(value: float, decimals: int) -> str:
    """A fraction in percent, ``–`` for no score (NaN)."""
    return "–" if np.isnan(value) else f"{100 * value:.{decimals}f}"


def _mean_std(values: np.ndarray, decimals: int) -> str:
    if not len(values):
        return "–"
    if len(values) == 1:
        return f"{values[0]:.{decimals}f}"
    return f"{values.mean():.{decimals}f} ± {values.std(ddof=1):.{decimals}f}"


def unet_records(results: str | Path) -> list[dict[str, Any]]:
    """The finished runs of a results folder that read a cached UNet, in folder order.

    Those are the bundled paper models (code ``synthcal:…``) trained ``step-by-step``
    under ``segmentation: unet``: end-to-end training caches no UNet, and a plug-in's
    stages are its own. Damaged records are skipped with a warning (:func:`read_record`).

    Returns:
        their ``run.json`` records.
    """
    folder = Path(results) / "runs"
    records = []
    for path in sorted(folder.glob("*/run.json")) if folder.is_dir() else []:
        record = read_record(path)
        if record is None or record["status"] != "ok":
            continue
        run = record["run"]
        if (run.get("segmentation") == "unet" and run.get("training") == "step-by-step"
                and str(run.get("code", "")).startswith("synthcal:") and run.get("settings") is not None):
            records.append(record)
    return records


def chosen_learning_rate(record: dict[str, Any]) -> float | None:
    """The learning rate validation chose for a run (its UNet trained at it), or None when nothing was chosen."""
    chosen = (record.get("selection") or {}).get("chosen") or {}
    rate = chosen.get("learning_rate")
    return None if rate is None else float(rate)


def readings_side_by_side(frame: pd.DataFrame, metric: str, decimals: int = 2) -> pd.DataFrame:
    """Each configuration's reading on the UNet's maps beside the same on true maps.

    Args:
        frame: the results (:func:`synthcal.eval.harness.collect_results`).
        metric: the reading (a column of ``frame``, in [0, 1]).
        decimals: of the printed numbers.

    Returns:
        one row per (dataset, model, training, loss, matching_score) that has runs with
        both segmentations: ``unet`` and ``ground-truth`` (mean ± std over seeds, percent),
        and ``unet − ground-truth``: the mean ± std of the per-seed differences over the
        seeds both have (``seeds`` counts those). Empty when no configuration has both.
    """
    keys = ["dataset", "model", "training", "loss", "matching_score"]
    ok = frame[(frame["status"] == "ok") & frame["segmentation"].isin(["unet", "ground-truth"])]
    rows = []
    for values, group in ok.groupby(keys, sort=False, dropna=False):
        by = {s: part.groupby("seed")[metric].mean() * 100 for s, part in group.groupby("segmentation")}
        if len(by) < 2:
            continue
        both = by["unet"].index.intersection(by["ground-truth"].index)
        difference = (by["unet"][both] - by["ground-truth"][both]).to_numpy(np.float64)
        rows.append({**dict(zip(keys, values, strict=True)), "unet": _mean_std(by["unet"].to_numpy(np.float64), decimals),
                     "ground-truth": _mean_std(by["ground-truth"].to_numpy(np.float64), decimals),
                     "unet − ground-truth": _mean_std(difference, decimals), "seeds": len(both)})
    return pd.DataFrame(rows, columns=[*keys, "unet", "ground-truth", "unet − ground-truth", "seeds"])


def _markdown(frame: pd.DataFrame, numeric: int) -> str:
    """``frame`` as a Markdown grid, its first ``numeric`` columns left-aligned, the rest right-aligned."""
    lines = ["| " + " | ".join(map(str, frame.columns)) + " |",
             "|" + "|".join([":---"] * numeric + ["---:"] * (len(frame.columns) - numeric)) + "|"]
    lines += ["| " + " | ".join(map(str, row)) + " |" for row in frame.itertuples(index=False)]
    return "\n".join(lines) + "\n"


def format_quality(quality: pd.DataFrame, results: pd.DataFrame | None, fmt: str = "md", metric: str = "iou",
                   decimals: int = 2) -> str:
    """``synthcal segmentation``'s text.

    Args:
        quality: one row per UNet (:func:`synthcal.api.segmentation_quality`), scores as fractions.
        results: the results folder's runs (:func:`synthcal.eval.harness.collect_results`)
            for the readings side by side; None: left out.
        fmt: ``md`` (three tables: per seed, over seeds, the readings side by side) or
            ``csv`` (the per-seed rows, scores as fractions at full precision).
        metric: the reading shown side by side.
        decimals: of the Markdown numbers.

    Raises:
        ValueError: an unknown ``fmt``.
    """
    if fmt == "csv":
        return quality.to_csv(index=False)
    if fmt != "md":
        raise ValueError(f"format must be md or csv; got {fmt!r}")
    scores = [c for c in quality.columns if c.startswith(("iou ", "dice ", "mean ")) or c == "pixel accuracy"]
    per_seed = quality.assign(**{c: [_percent(v, decimals) for v in quality[c]] for c in scores})
    blocks = ["### The UNet on the test split, per seed (%)\n",
              _markdown(per_seed.drop(columns=["unet"]), 3),
              "### Over seeds: mean ± std (%)\n", _markdown(seed_summary(quality, decimals), 2),
              f"Scores pool every test pixel at the working resolution; mean: over classes "
              f"{', '.join(map(str, FOREGROUND))} (not the background).\n"]
    if results is not None:
        side = readings_side_by_side(results, metric, decimals)
        blocks.append(f"### {metric} on the UNet's maps beside the true maps (%)\n")
        blocks.append(_markdown(side, 5) if len(side) else
                      "(no configuration has runs with both segmentation unet and ground-truth in this folder; "
                      "for true-map runs kept in another one: synthcal table TRUE-MAP-RESULTS --against "
                      "THIS-FOLDER --paired segmentation=ground-truth segmentation=unet)\n")
    return "\n".join(blocks)
