"""The sports-field literature's metrics, ``iou_part`` and ``iou_whole`` (SPEC §8), exactly.

Conventions as in :mod:`synthcal.eval.metrics`: ``H`` maps a bird's-eye pixel to an
image pixel, third coordinate the depth; an image of size ``(W, H)`` covers
``[-0.5, W - 0.5] × [-0.5, H - 0.5]``, and so does the bird's-eye scene.

``iou_part``
    In the bird's-eye plane: the ground seen by the image under the truth against
    the ground seen under the estimate, each clipped to the scene's *field*
    polygon (SPEC §4: the pitch for soccer, as the sports-field literature's code
    clips to its pitch template; the whole scene by default).
``iou_whole``
    In the image plane: the part of the image rectangle that sees the ground under
    the truth, against that region sent to the ground by the truth and back into
    the image by the estimate, on a canvas ``canvas_scale`` times the image in
    each direction (4, as in the literature's code, see below).

``iou_part`` and ``iou_whole`` are computed *exactly*, not by rasterisation. An
image pixel ``x`` sees ground point ``g`` when ``x ~ H g`` with positive depth;
for homogeneous ``p = H g`` the four conditions "inside the image rectangle"
(``p₁ + 0.5 p₃ ≥ 0``, ``(W - 0.5) p₃ - p₁ ≥ 0`` and the same for rows) are linear
in ``g`` and their sum is ``W p₃ ≥ 0``, so they also enforce cheirality. Each
region is therefore a convex polygon: a rectangle clipped by a few half-planes
(Sutherland–Hodgman), whose area is exact. This is the limit of the literature's
rasterised IoU as the raster gets finer, needs no resolution setting, and costs
microseconds (results are rounded to 12 decimals so that an exact match
scores exactly 1 despite float round-off). An empty *true* region is never
agreement: the estimate scores 0 (:func:`synthcal.eval.scoring.evaluate` skips
such images instead). The field polygon may be any simple polygon: clipping a simple
polygon by half-planes keeps its area exact (Sutherland–Hodgman may leave zero-width
seams, which have no area).

What the literature's code does for ``iou_whole`` (our reading)
---------------------------------------------------------------
Jiang et al. (WACV 2020, ``vcg-uvic/sportsfield_release``, ``utils/metrics.py``,
``get_model_whole_iou_rasterization``) keep homographies *frame → template* in
normalised coordinates (``[-0.5, 0.5]²`` for both). They fill a canvas 4× larger
(``ZOOM_OUT_SCALE = 4``) with ``mask(y) = [T⁻¹ O S y ∈ unit square]``, ``T`` the
truth, ``O`` the estimate, ``S`` the zoom, against ``mask(y) = [S y ∈ unit
square]``, both bilinearly sampled and thresholded at 0.5. With ``O, T`` mapping
frame → template the composite ``T⁻¹ O`` takes a *frame* point to the template by
the estimate and back by the truth, so the compared regions are the frame
rectangle and ``O⁻¹ T`` (frame rectangle): the rectangle sent to the template by
the truth and back by the estimate — exactly SPEC §8's wording. Written for our
bird's-eye → image ``H``: ``B = H_est · H_true⁻¹ (R)``. A later kornia-based
re-implementation for SoccerNet homographies (``iou_whole(h_pred, h_true)``, same
zoom-out of 4) composes the same product. Neither masks points behind the camera (``grid_sample`` of points
divided by a negative depth); we do, as SPEC §2 requires of every warp, which is
why region ``A`` is the part of the rectangle below the true horizon — with it an
oracle scores exactly 1. Like the literature, the part of ``B`` beyond the canvas
is ignored (it can only be reached by estimates far off).

Example
-------
>>> import numpy as np
>>> H = np.array([[1.0, 0, -10], [0, 1, -10], [0, 0, 1]])
>>> iou_part((60, 120), H, H, (64, 36)), iou_whole(H, H, (64, 36))
(1.0, 1.0)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from synthcal.eval.metrics import check_homography, check_truth

__all__ = ["field_polygon", "iou_part", "iou_whole"]


def field_polygon(scene_shape: tuple[int, ...], field: Any = None) -> np.ndarray:
    """The polygon ``iou_part`` is clipped to (SPEC §4).

    Args:
        scene_shape: ``(Hs, Ws, ...)`` shape of the bird's-eye scene.
        field: (n, 2) vertices ``(u, v)`` in bird's-eye pixels (a simple polygon,
            n ≥ 3), or None for the whole scene.

    Returns:
        (n, 2) float64 vertices; the scene rectangle ``[-0.5, Ws - 0.5] × [-0.5,
        Hs - 0.5]`` when ``field`` is None.
    """
    if field is None:
        return _rectangle(-0.5, -0.5, scene_shape[1] - 0.5, scene_shape[0] - 0.5)
    polygon = np.asarray(field, dtype=np.float64)
    if polygon.ndim != 2 or polygon.shape[1] != 2 or len(polygon) < 3 or not np.isfinite(polygon).all():
        raise ValueError(f"a field polygon must be (n >= 3, 2) finite (u, v) vertices, got {polygon.tolist()}")
    return polygon


# --- convex polygons -------------------------------------------------------------------


def _rectangle(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """(4, 2) counter-clockwise-in-image corners of an axis-aligned rectangle."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=np.float64)


def _clip(polygon: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Clip a convex polygon by half-planes ``a x + b y + c ≥ 0`` (Sutherland–Hodgman).

    Args:
        polygon: (n, 2) vertices in order.
        lines: (m, 3) half-plane coefficients ``(a, b, c)``.

    Returns:
        (k, 2) vertices of the clipped polygon (k = 0 when empty).
    """
    for line in lines:
        if len(polygon) == 0:
            break
        # Scale-free test: lines come from homographies of arbitrary scale.
        line = line / max(np.abs(line).max(), np.finfo(float).tiny)
        side = polygon @ line[:2] + line[2]
        nxt_polygon, nxt_side = np.roll(polygon, -1, axis=0), np.roll(side, -1)
        clipped = []
        for p, q, sp, sq in zip(polygon, nxt_polygon, side, nxt_side, strict=True):
            if sp >= 0:
                clipped.append(p)
            if (sp >= 0) != (sq >= 0):
                clipped.append(p + (sp / (sp - sq)) * (q - p))
        polygon = np.array(clipped, dtype=np.float64).reshape(-1, 2)
    return polygon


def polygon_area(polygon: np.ndarray) -> float:
    """Area of a simple polygon (shoelace)."""
    if len(polygon) < 3:
        return 0.0
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _image_cone(image_size: tuple[int, int]) -> np.ndarray:
    """(4, 3) rows ``e`` with ``e · p ≥ 0`` ⇔ homogeneous image point ``p`` inside the rectangle."""
    width, height = image_size
    return np.array([[1.0, 0, 0.5], [-1.0, 0, width - 0.5], [0, 1.0, 0.5], [0, -1.0, height - 0.5]])


def _polygon_iou(region_a: np.ndarray, region_b: np.ndarray, lines_b: np.ndarray) -> float:
    """IoU of the true region ``a`` and the estimated ``b``, ``b`` a polygon clipped by ``lines_b``.

    An empty true region is never agreement: 0, whatever ``b`` is.
    """
    area_a, area_b = polygon_area(region_a), polygon_area(region_b)
    if area_a <= 0:
        return 0.0
    intersection = polygon_area(_clip(region_a, lines_b))
    union = area_a + area_b - intersection
    # Clipping a polygon by its own edges moves vertices by ~1e-16; rounding to 12
    # digits lets an exact match score exactly 1 and changes nothing measurable.
    return round(float(np.clip(intersection / union, 0.0, 1.0)), 12)


def iou_part(
    scene_shape: tuple[int, ...], H_est: Any, H_true: np.ndarray, image_size: tuple[int, int], field: Any = None
) -> float:
    """IoU, in the bird's-eye plane, of the ground seen by the image under truth and estimate.

    Each region is the set of ground points that project inside the image
    rectangle with positive depth, clipped to the scene's field polygon (the
    whole scene ``[-0.5, Ws - 0.5] × [-0.5, Hs - 0.5]`` by default); areas are
    exact (module docstring).

    Args:
        scene_shape: ``(Hs, Ws, ...)`` shape of the bird's-eye scene (e.g.
            ``scene_semantic.shape``).
        H_est: (3, 3) estimate, bird's-eye → image, any scale and sign (checked).
        H_true: (3, 3) true homography, bird's-eye → image, depth sign kept.
        image_size: ``(width, height)`` of the image.
        field: (n, 2) field polygon in bird's-eye pixels, or None for the scene.

    Returns:
        IoU in [0, 1]; 0 for a failed estimate, and 0 when the truth sees no field.

    Raises:
        TruthError: ``H_true`` is not valid truth (:func:`~synthcal.eval.metrics.check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    return 0.0 if H is None else iou_part_checked(field_polygon(scene_shape, field), H, H_true, image_size)


def field_seen(field: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """The part of the field the true view sees (a polygon, empty when it sees none)."""
    # Ground g is seen iff e · (H g) ≥ 0 for every row e: half-planes (e H) · g ≥ 0.
    return _clip(field, _image_cone(image_size) @ np.asarray(H_true, np.float64))


def iou_part_checked(field: np.ndarray, H: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int]) -> float:
    """:func:`iou_part` of an estimate already checked and oriented by :func:`check_homography`."""
    lines_est = _image_cone(image_size) @ H
    return _polygon_iou(field_seen(field, H_true, image_size), _clip(field, lines_est), lines_est)


def iou_whole(
    H_est: Any, H_true: np.ndarray, image_size: tuple[int, int], canvas_scale: float = 4.0
) -> float:
    """IoU, in the image plane, of the image against its round trip truth → ground → estimate.

    ``A`` is the part of the image rectangle that sees the ground under the truth;
    ``B`` is ``A`` sent to the ground by ``H_true⁻¹`` and back by ``H_est``, keeping
    only points in front of the estimated camera, and cropped to a canvas
    ``canvas_scale`` times the image about its centre (module docstring).

    Args:
        H_est: (3, 3) estimate, bird's-eye → image, any scale and sign (checked).
        H_true: (3, 3) true homography, bird's-eye → image, depth sign kept.
        image_size: ``(width, height)`` of the image.
        canvas_scale: canvas size in image sizes (4 as in Jiang et al.'s code).

    Returns:
        IoU in [0, 1]; 0 for a failed estimate.

    Raises:
        TruthError: ``H_true`` is not valid truth (:func:`~synthcal.eval.metrics.check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    return 0.0 if H is None else iou_whole_checked(H, H_true, image_size, canvas_scale)


def iou_whole_checked(H: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int], canvas_scale: float) -> float:
    """:func:`iou_whole` of an estimate already checked and oriented by :func:`check_homography`."""
    width, height = image_size
    H_true = np.asarray(H_true, np.float64)
    cone = _image_cone(image_size)
    # A: image pixels y with (H_true⁻¹ y)₃ > 0 (the renderer's cheirality test).
    region_a = _clip(_rectangle(-0.5, -0.5, width - 0.5, height - 0.5), np.linalg.inv(H_true)[2:])
    # B: y whose ground point g = H_est⁻¹ y is in front of the estimate (g₃ > 0) and
    # is seen by the true camera inside the image: e · (H_true g) ≥ 0, which also
    # implies a positive true depth. inv() keeps the sign, so both tests are linear.
    H_est_inv = np.linalg.inv(H)
    lines_b = np.vstack([H_est_inv[2:], cone @ H_true @ H_est_inv])
    cx, cy, half = (width - 1) / 2.0, (height - 1) / 2.0, canvas_scale / 2.0
    canvas = _rectangle(cx - half * width, cy - half * height, cx + half * width, cy + half * height)
    return _polygon_iou(region_a, _clip(canvas, lines_b), lines_b)
