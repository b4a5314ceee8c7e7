"""All metrics of a batch of test images (SPEC §8), and their summary over a run.

:func:`evaluate` scores every image by the readings of the paper's IoU
(:mod:`synthcal.eval.metrics`), the exact ``iou_part`` / ``iou_whole``
(:mod:`synthcal.eval.polygon`) and the pixel errors ``reproj_px``, ``acc@k``,
``corner_error`` (:mod:`synthcal.eval.reprojection`), checking each estimate once.

Failures, the truth and skipped images
---------------------------------------
A failed estimate (:func:`synthcal.eval.metrics.check_homography`: none, wrong shape,
non-finite, singular) scores 0 on every IoU and ``acc@k``, ``inf`` on the pixel errors
(:data:`synthcal.config.PIXEL_METRICS`), and is flagged. Every true ``H`` is
checked first (:func:`synthcal.eval.metrics.check_truth`). A test image whose true
view sees none of the field has no ``iou_part`` to speak of; it is *skipped* (all
its metrics NaN, column ``skipped``) and counted (``n_skipped`` in
:func:`summarize`), not scored.

Summaries
---------
:func:`summarize` averages the fractions (the IoUs, ``acc@k``: failures as 0) over the
scored images; the pixel errors, where one failed image is ``inf``, are summarised by
their *median* over the images that have the reading, beside the share of those that
failed (``reproj_px_failed``, ``corner_error_failed``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from synthcal.config import FAILURE_SHARES, METRICS, PIXEL_METRICS, READINGS
from synthcal.eval.metrics import (
    CLASSES,
    check_homography,
    check_truth,
    estimate_and_true_views,
    semantic_iou,
    semantic_readings,
)
from synthcal.eval.polygon import field_polygon, field_seen, iou_part_checked, iou_whole_checked, polygon_area
from synthcal.eval.reprojection import ground_grid, reprojection_readings

__all__ = ["evaluate", "completeness", "summarize"]


def _estimate_items(H_est_batch: Any, n: int) -> list[Any]:
    """Split whatever ``predict`` returned into ``n`` per-image estimates (or failure stand-ins)."""
    if H_est_batch is None:
        return [None] * n
    if hasattr(H_est_batch, "detach"):  # a torch tensor, possibly on a GPU
        H_est_batch = H_est_batch.detach().cpu().numpy()
    try:
        batch = np.asarray(H_est_batch, dtype=np.float64)
    except (TypeError, ValueError):  # ragged or mixed with None: judge item by item
        batch = None
    if batch is not None and batch.shape == (n, 3, 3):
        return list(batch)
    if isinstance(H_est_batch, (list, tuple)) and len(H_est_batch) == n:
        return list(H_est_batch)
    shape = getattr(batch, "shape", None)
    return [_BatchShapeError(f"wrong batch shape {shape}, expected ({n}, 3, 3)")] * n


class _BatchShapeError:
    """Marks every image of a batch whose overall shape is unusable."""

    def __init__(self, reason: str) -> None:
        self.reason = reason


def evaluate(
    scene_semantic: np.ndarray,
    H_est_batch: Any,
    H_true_batch: np.ndarray,
    image_size: tuple[int, int],
    classes: Sequence[int] = CLASSES,
    canvas_scale: float = 4.0,
    field: Any = None,
    indices: Sequence[int] | np.ndarray | None = None,
    source: str = "",
) -> pd.DataFrame:
    """All metrics for a batch of test images.

    Args:
        scene_semantic: (Hs, Ws) uint8 bird's-eye class map, classes 0–3.
        H_est_batch: (B, 3, 3) estimates from a plug-in (any scale and sign; NumPy
            or a torch tensor), or a length-B list whose entries may be None or
            malformed, or None for no estimate.
        H_true_batch: (B, 3, 3) true homographies, bird's-eye → image.
        image_size: ``(width, height)`` of the images.
        classes: the foreground class ids (``iou`` averages over them; ``iou_bg``
            and ``iou_weighted`` add class 0).
        canvas_scale: canvas of ``iou_whole``.
        field: (n, 2) field polygon of ``iou_part`` in bird's-eye pixels, or None
            for the whole scene (SPEC §4).
        indices: the B samples' indices, named by errors (default ``0 .. B − 1``).
        source: where the truths come from (a store's path), named by errors.

    Returns:
        DataFrame with one row per test image and columns :data:`METRICS` (float:
        fractions in [0, 1], the pixel errors in pixels, ``inf`` for a failure, NaN
        where the truth leaves them undefined; :mod:`synthcal.eval.reprojection`),
        ``failed`` (bool), ``failure`` (reason, ``""`` if none) and ``skipped`` (bool:
        the true view sees none of the field; its metrics are NaN). Failed estimates
        score 0 on every fraction and ``inf`` on every pixel error.

    Raises:
        TruthError: a true homography breaks SPEC §2's rule (names the sample);
            raised before anything is scored.
    """
    H_true_batch = np.asarray(H_true_batch, dtype=np.float64)
    if H_true_batch.ndim != 3 or H_true_batch.shape[1:] != (3, 3):
        raise ValueError(f"H_true_batch must be (B, 3, 3), got {H_true_batch.shape}")
    names = list(range(len(H_true_batch))) if indices is None else [int(i) for i in np.asarray(indices)]
    truths = [check_truth(H, image_size, name, source) for H, name in zip(H_true_batch, names, strict=True)]
    polygon = field_polygon(scene_semantic.shape, field)
    points = ground_grid(scene_semantic.shape)
    rows = []
    # Each estimate is checked (SVD, orientation) once, then scored by every metric.
    for estimate, H_true in zip(_estimate_items(H_est_batch, len(truths)), truths, strict=True):
        if polygon_area(field_seen(polygon, H_true, image_size)) <= 0:
            rows.append((*[np.nan] * len(METRICS), False, "", True))
            continue
        if isinstance(estimate, _BatchShapeError):
            H, reason = None, estimate.reason
        else:
            H, reason = check_homography(estimate, image_size)
        if H is None:
            pixels = reprojection_readings(points, None, H_true, image_size)
            rows.append((*[0.0] * (len(METRICS) - len(pixels)), *pixels.values(), True, reason, False))
            continue
        predicted, target = estimate_and_true_views(scene_semantic, H, H_true, image_size)
        scores = semantic_readings(predicted, target)
        if tuple(classes) != CLASSES:  # `iou` follows the classes asked for; the other readings keep 0–3
            scores["iou"] = semantic_iou(predicted, target, classes)
        rows.append((
            *(scores[name] for name in READINGS),
            iou_part_checked(polygon, H, H_true, image_size),
            iou_whole_checked(H, H_true, image_size, canvas_scale),
            *reprojection_readings(points, H, H_true, image_size).values(),
            False,
            "",
            False,
        ))
    frame = pd.DataFrame(rows, columns=[*METRICS, "failed", "failure", "skipped"])
    return frame.astype({name: float for name in METRICS} | {"failed": bool, "failure": str, "skipped": bool})


def _scored(per_image: pd.DataFrame) -> pd.DataFrame:
    """The rows that count: skipped images (the truth sees no field) left out."""
    return per_image[~per_image["skipped"].astype(bool)] if "skipped" in per_image else per_image


def completeness(per_image: pd.DataFrame) -> float:
    """Share of the scored test images with a usable estimate (1.0 when none is scored)."""
    scored = _scored(per_image)
    return 1.0 - float(scored["failed"].mean()) if len(scored) else 1.0


def summarize(per_image: pd.DataFrame) -> dict[str, float]:
    """Means (fractions; failures count as 0) or medians (pixel errors) over the scored test images,
    the pixel errors' failure shares, completeness and counts.

    Args:
        per_image: the frame returned by :func:`evaluate`.

    Returns:
        dict with every metric of :data:`METRICS` present in the frame (NaN when no
        image has it), for each of :data:`PIXEL_METRICS` present ``<name>_failed`` (the
        share of the images with the reading that score ``inf``), ``completeness``,
        ``n_images`` (scored images) and ``n_skipped`` (images whose true view sees no field).
    """
    scored = _scored(per_image)
    summary = {}
    for name in (name for name in METRICS if name in per_image):
        values = scored[name].dropna()  # NaN: the truth leaves the reading undefined
        if name in PIXEL_METRICS:
            summary[name] = float(values.median()) if len(values) else float("nan")
            summary[FAILURE_SHARES[name]] = float(np.isinf(values).mean()) if len(values) else float("nan")
        else:
            summary[name] = float(values.mean()) if len(values) else float("nan")
    summary["completeness"] = completeness(per_image)
    summary["n_images"] = float(len(scored))
    summary["n_skipped"] = float(len(per_image) - len(scored))
    return summary
