"""Pixel errors of estimated homographies, as the homography literature reports them (SPEC §8).

Convention
----------
Every homography maps a bird's-eye pixel to an image pixel, ``x_img ~ H (u, v, 1)ᵀ``;
its third output coordinate is the depth, positive in front of the camera (SPEC §2).
An image of size ``(W, H)`` covers ``[-0.5, W - 0.5] × [-0.5, H - 0.5]`` (pixel centres at
integer coordinates). Estimates are first checked and oriented by
:func:`synthcal.eval.metrics.check_homography` (scale and sign do not matter).

Readings (per test image; lower is better, in pixels)
-----------------------------------------------------
``reproj_px``
    The scene's ground points on a 10-px bird's-eye grid (``u, v = 0, 10, 20, …`` over the
    whole scene image) that the true view sees — positive depth under the truth and
    projecting inside the image — are projected by the estimate and by the truth; the
    reading is the mean image-pixel distance between the two projections, at the store's
    image size. A point behind the camera under the estimate (depth ≤ 0) has no image: the
    image's reading is ``inf`` (a failure), and so is a failed estimate's. NaN when the true
    view sees no grid point (nothing to measure).
``acc@5``, ``acc@10``, ``acc@20``
    1.0 when the image's ``reproj_px`` is at most 5 / 10 / 20 px, else 0.0 (failures 0);
    their mean over the test images is the share the SoccerNet camera-calibration challenge
    reports (higher is better).
``corner_error``
    The four corners of the image rectangle sent to the ground by the inverse of the
    estimate and of the truth; the reading is the mean bird's-eye distance between the
    two ground points (DeTone et al.'s mean corner error, in the ground plane). Only for
    images whose four corners see the ground under the truth (third coordinate of
    ``H⁻¹ x`` positive); NaN otherwise (not applicable, left out of every summary). A corner
    that does not see the ground under the estimate makes the reading ``inf`` (a failure).

An estimate equal to the truth scores 0 / 1 / 0 exactly: both sides go through the same
arithmetic. Summaries over a run (:func:`synthcal.eval.scoring.summarize`) report the
*median* of ``reproj_px`` and ``corner_error`` (a mean is ``inf`` as soon as one image
fails) and the share of failures beside it (``reproj_px_failed``, ``corner_error_failed``).

Example
-------
>>> import numpy as np
>>> H = np.array([[1.0, 0, -10], [0, 1, -10], [0, 0, 1]])
>>> shift = np.array([[1.0, 0, 3], [0, 1, 4], [0, 0, 1]])  # 3 px right, 4 px down in the image
>>> points = ground_grid((60, 120))
>>> float(reproj_px_checked(points, shift @ H, H, (64, 36)))
5.0
>>> float(corner_error_checked(H, H, (64, 36)))
0.0
"""

from __future__ import annotations

from typing import Any

import numpy as np

from synthcal.eval.metrics import check_homography

__all__ = ["GRID_STEP", "ACCURACY_THRESHOLDS", "ground_grid", "reproj_px_checked", "corner_error_checked",
           "reprojection_readings", "reproj_px", "corner_error"]

GRID_STEP = 10
# acc@k: the thresholds in image pixels (SPEC §8).
ACCURACY_THRESHOLDS = (5, 10, 20)


def ground_grid(scene_shape: tuple[int, ...], step: int = GRID_STEP) -> np.ndarray:
    """The scene's ground points on a ``step``-px bird's-eye grid.

    Args:
        scene_shape: ``(Hs, Ws, ...)`` of the bird's-eye image.
        step: grid spacing in bird's-eye pixels.

    Returns:
        (3, N) float64 homogeneous points ``(u, v, 1)``, ``u = 0, step, … < Ws``,
        ``v = 0, step, … < Hs``.
    """
    v, u = np.mgrid[0:scene_shape[0]:step, 0:scene_shape[1]:step]
    return np.stack([u.ravel(), v.ravel(), np.ones(u.size)]).astype(np.float64)


def _inside(p: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Which homogeneous image points ``p`` (3, N) lie in front of the camera and inside the image."""
    width, height = image_size
    depth = p[2]
    with np.errstate(all="ignore"):
        x, y = p[0] / depth, p[1] / depth
    return (depth > 0) & (x >= -0.5) & (x <= width - 0.5) & (y >= -0.5) & (y <= height - 0.5)


def reproj_px_checked(points: np.ndarray, H: np.ndarray | None, H_true: np.ndarray,
                      image_size: tuple[int, int]) -> float:
    """``reproj_px`` of an estimate already checked and oriented (module docstring).

    Args:
        points: (3, N) homogeneous ground points (:func:`ground_grid`).
        H: (3, 3) checked estimate, bird's-eye → image, depth sign right; None for a
            failed one.
        H_true: (3, 3) true homography, depth sign kept.
        image_size: ``(width, height)`` of the image.

    Returns:
        Mean image distance in pixels; ``inf`` for a failed estimate or when a seen
        point is behind the estimated camera; NaN when the true view sees no point.
    """
    truth = np.asarray(H_true, np.float64) @ points
    seen = _inside(truth, image_size)
    if not seen.any():
        return float("nan")
    if H is None:
        return float("inf")
    estimate = H @ points[:, seen]
    truth = truth[:, seen]
    if not (estimate[2] > 0).all():
        return float("inf")
    difference = estimate[:2] / estimate[2] - truth[:2] / truth[2]
    return float(np.mean(np.hypot(difference[0], difference[1])))


def corner_error_checked(H: np.ndarray | None, H_true: np.ndarray, image_size: tuple[int, int]) -> float:
    """``corner_error`` of an estimate already checked and oriented (module docstring).

    Args:
        H: (3, 3) checked estimate, bird's-eye → image, depth sign right; None for a
            failed one.
        H_true: (3, 3) true homography, depth sign kept.
        image_size: ``(width, height)`` of the image.

    Returns:
        Mean ground distance of the four image corners in bird's-eye pixels; NaN when a
        corner does not see the ground under the truth; else ``inf`` for a failed
        estimate or a corner that does not see the ground under it.
    """
    width, height = image_size
    corners = np.array([[-0.5, width - 0.5, width - 0.5, -0.5],
                        [-0.5, -0.5, height - 0.5, height - 0.5],
                        [1.0, 1.0, 1.0, 1.0]])
    truth = np.linalg.solve(np.asarray(H_true, np.float64), corners)
    if not (truth[2] > 0).all():
        return float("nan")
    if H is None:
        return float("inf")
    estimate = np.linalg.solve(H, corners)
    if not (estimate[2] > 0).all():
        return float("inf")
    difference = estimate[:2] / estimate[2] - truth[:2] / truth[2]
    return float(np.mean(np.hypot(difference[0], difference[1])))


def reprojection_readings(points: np.ndarray, H: np.ndarray | None, H_true: np.ndarray,
                          image_size: tuple[int, int]) -> dict[str, float]:
    """``reproj_px``, ``acc@5/10/20`` and ``corner_error`` of one image.

    Args:
        points: (3, N) homogeneous ground points (:func:`ground_grid`).
        H: (3, 3) checked, oriented estimate, or None for a failed one.
        H_true: (3, 3) true homography, depth sign kept.
        image_size: ``(width, height)`` of the image.

    Returns:
        dict of the five readings (module docstring); a failed estimate scores ``inf``,
        0 and ``inf`` (NaN where the truth leaves a reading undefined).
    """
    error = reproj_px_checked(points, H, H_true, image_size)
    accuracy = {f"acc@{k}": float("nan") if np.isnan(error) else float(error <= k) for k in ACCURACY_THRESHOLDS}
    return {"reproj_px": error, **accuracy, "corner_error": corner_error_checked(H, H_true, image_size)}


def reproj_px(H_est: Any, H_true: np.ndarray, image_size: tuple[int, int], scene_shape: tuple[int, ...],
              step: int = GRID_STEP) -> float:
    """``reproj_px`` of one foreign estimate (module docstring).

    Args:
        H_est: (3, 3) estimate, bird's-eye → image, any scale and sign (checked).
        H_true: (3, 3) true homography, depth sign kept.
        image_size: ``(width, height)`` of the image.
        scene_shape: ``(Hs, Ws, ...)`` of the bird's-eye scene.
        step: grid spacing in bird's-eye pixels.

    Returns:
        Mean image distance in pixels; NaN when the true view sees no grid point; else
        ``inf`` for a failed estimate or a seen point behind the estimated camera.
    """
    H, _ = check_homography(H_est, image_size)
    return reproj_px_checked(ground_grid(scene_shape, step), H, H_true, image_size)


def corner_error(H_est: Any, H_true: np.ndarray, image_size: tuple[int, int]) -> float:
    """``corner_error`` of one foreign estimate (module docstring).

    Args:
        H_est: (3, 3) estimate, bird's-eye → image, any scale and sign (checked).
        H_true: (3, 3) true homography, depth sign kept.
        image_size: ``(width, height)`` of the image.

    Returns:
        Mean ground distance in bird's-eye pixels; NaN when a corner does not see the
        ground under the truth; else ``inf`` for a failed estimate or a corner that does
        not see the ground under it.
    """
    H, _ = check_homography(H_est, image_size)
    return corner_error_checked(H, H_true, image_size)
