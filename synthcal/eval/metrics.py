"""Per-image accuracy of estimated homographies (SPEC §8).

Convention
----------
Every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, and its third output coordinate is the depth (positive
in front of the camera; SPEC §2). Image pixels have their centres at integer
coordinates, so an image of size ``(W, H)`` covers the rectangle
``[-0.5, W - 0.5] × [-0.5, H - 0.5]``; the same holds for the bird's-eye scene.

Metrics
-------
The paper never defines its IoU beyond "the similarity between the images
produced by warping the bird's-eye view with the estimated homographies and the
ground truth", so three readings are computed, all from the same two renders:
the scene's semantic map rendered through the estimate (``Ŷ``) and through the
truth (``Y``) by :func:`synthcal.generate.render.render_semantic` (the
generator's own renderer, cheirality mask included), with the per-class Jaccard
``J_c = |Ŷc ∩ Yc| / |Ŷc ∪ Yc|``:

``iou``
    mean of ``J_c`` over the classes 1–3 present in either view (1 when neither
    view shows any of them: both agree that nothing is seen);
``iou_bg``
    the same mean over the classes 0–3 (background included);
``iou_weighted``
    ``Σ w_c J_c`` over the classes 0–3, ``w_c`` the share of class ``c`` in the
    true view: scikit-learn's ``jaccard_score(average="weighted")``, which the
    public re-implementation of Sha et al. computes.

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
agreement: the estimate scores 0 (:func:`evaluate` skips such images instead, see
below). The field polygon may be any simple polygon: clipping a simple polygon by
half-planes keeps its area exact (Sutherland–Hodgman may leave zero-width
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

Failures, the truth and skipped images
---------------------------------------
A foreign estimate is first checked by :func:`check_homography`: ``None``, a
wrong shape, NaN/inf entries or a singular matrix (smallest singular value below
``1e-12`` of the largest; grid cameras are above ``1e-8``) score 0 on every metric
and are flagged; otherwise it is divided by its largest absolute entry (so
``1e150 · H`` and ``1e-150 · H`` score as ``H``: nothing downstream overflows)
and its overall sign is fixed with
:func:`synthcal.generate.camera.orient_homography`.

The truth is data, not an estimate: :func:`evaluate` first checks every true
``H`` (:func:`check_truth`): its bottom-centre pixel must see the ground in front
of the camera (SPEC §2's rule), else :class:`TruthError` names the sample. A
test image whose true view sees none of the field has no ``iou_part`` to speak
of; it is *skipped* (all its metrics NaN, column ``skipped``) and counted
(``n_skipped`` in :func:`summarize`), not scored.

Example
-------
>>> import numpy as np
>>> scene = np.repeat(np.repeat(np.array([[1, 2, 3]], np.uint8), 40, 1), 60, 0)
>>> H = np.array([[1.0, 0, -10], [0, 1, -10], [0, 0, 1]])
>>> iou(scene, H, H, (64, 36)), iou_part(scene.shape, H, H, (64, 36))
(1.0, 1.0)
>>> readings(scene, H, H, (64, 36))
{'iou': 1.0, 'iou_bg': 1.0, 'iou_weighted': 1.0}
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from synthcal.generate.camera import orient_homography
from synthcal.generate.render import render_semantic

__all__ = [
    "SINGULAR_RCOND",
    "METRICS",
    "READINGS",
    "DESCRIPTIONS",
    "DEFAULT_READING",
    "TruthError",
    "check_homography",
    "check_truth",
    "field_polygon",
    "semantic_iou",
    "semantic_readings",
    "iou",
    "readings",
    "iou_part",
    "iou_whole",
    "evaluate",
    "completeness",
    "summarize",
]

SINGULAR_RCOND = 1e-12
CLASSES = (1, 2, 3)
NUM_CLASSES = 4
# The paper's IoU, three readings of it (module docstring), then the sports-field metrics.
READINGS = ("iou", "iou_bg", "iou_weighted")
METRICS = (*READINGS, "iou_part", "iou_whole")
# The reading tables and plots show unless told otherwise: on intersection-1 at the quick
# profile it puts the baseline at 87.6 (paper 85.9) where ``iou`` gives 65.6, and it is what the
# only public re-implementation of Sha et al. computes (docs/reproduction.md, docs/decisions.md).
DEFAULT_READING = "iou_weighted"
DESCRIPTIONS = {
    "iou": "the paper's IoU read as the mean over classes 1-3 present in either view",
    "iou_bg": "the paper's IoU read as the mean over classes 0-3 (background included) present in either view",
    "iou_weighted": "the paper's IoU read as the Jaccard of classes 0-3 weighted by their share of the true view "
                    "(sklearn jaccard_score average='weighted', as the public re-implementation of Sha et al.)",
    "iou_part": "IoU of the ground seen, on the scene's field (the pitch for soccer)",
    "iou_whole": "IoU of the image against its round trip truth -> ground -> estimate",
}


class TruthError(ValueError):
    """A true homography that breaks SPEC §2's rule: an error in the data, not a score."""


def check_homography(homography: Any, image_size: tuple[int, int]) -> tuple[np.ndarray | None, str]:
    """Validate a foreign estimate and fix its overall sign (SPEC §2, §8).

    Args:
        homography: anything a plug-in may return for one image: ideally a (3, 3)
            array-like, bird's-eye → image, of any (possibly negative) scale.
        image_size: ``(width, height)`` of the image.

    Returns:
        ``(H, "")`` with ``H`` a (3, 3) float64 homography whose depth sign is
        right, or ``(None, reason)`` for a failure: ``"no estimate"``, ``"not
        numeric"``, ``"wrong shape (…)"``, ``"non-finite entries"``, ``"singular"``.
    """
    if homography is None:
        return None, "no estimate"
    try:
        H = np.asarray(homography, dtype=np.float64)
    except (TypeError, ValueError):
        return None, "not numeric"
    if H.shape != (3, 3):
        return None, f"wrong shape {H.shape}"
    if not np.isfinite(H).all():
        return None, "non-finite entries"
    largest = float(np.abs(H).max())
    if not largest > 0:
        return None, "singular"
    # A positive factor changes nothing (SPEC §8); dividing by the largest entry keeps
    # every later product (SVD, inverses, the renderer's float32 maps) far from overflow.
    H = H / largest
    singular_values = np.linalg.svd(H, compute_uv=False)
    if not singular_values[2] > SINGULAR_RCOND * singular_values[0]:
        return None, "singular"
    return orient_homography(H[None], image_size)[0], ""


def check_truth(H_true: np.ndarray, image_size: tuple[int, int], index: Any = None, source: str = "") -> np.ndarray:
    """A true homography, checked against SPEC §2's rule and scaled to a largest entry of 1.

    Args:
        H_true: (3, 3) true homography, bird's-eye → image.
        image_size: ``(width, height)`` of the image.
        index: the sample's index, for the message.
        source: where the truth comes from (a store's path), for the message.

    Returns:
        (3, 3) float64, ``H_true`` divided by its largest absolute entry.

    Raises:
        TruthError: non-finite or singular, or its bottom-centre pixel does not see
            the ground in front of the camera (e.g. a negated truth).
    """
    where = f"{source + ': ' if source else ''}true homography" + ("" if index is None else f" of sample {index}")
    H = np.asarray(H_true, dtype=np.float64)
    if H.shape != (3, 3) or not np.isfinite(H).all() or not np.abs(H).max() > 0:
        raise TruthError(f"{where} is not a finite (3, 3) matrix: {H.tolist()}")
    H = H / np.abs(H).max()
    width, height = image_size
    with np.errstate(all="ignore"):
        try:
            ground = np.linalg.solve(H, np.array([(width - 1) / 2.0, height - 1.0, 1.0]))
        except np.linalg.LinAlgError:
            ground = np.full(3, np.nan)
    if not (np.isfinite(ground).all() and ground[2] > 0):
        raise TruthError(f"{where}: its bottom-centre pixel ({(width - 1) / 2:g}, {height - 1}) does not see the "
                         f"ground in front of the camera (SPEC §2); H = {np.asarray(H_true).tolist()}")
    return H


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


def semantic_iou(predicted: np.ndarray, target: np.ndarray, classes: Sequence[int] = CLASSES) -> float:
    """Mean per-class IoU over the classes present in either map.

    Args:
        predicted: (H, W) integer class map.
        target: (H, W) integer class map.
        classes: the class ids averaged over (background excluded by default).

    Returns:
        The mean IoU in [0, 1]; 1.0 when none of ``classes`` appears in either map.
    """
    n = int(max(predicted.max(initial=0), target.max(initial=0), max(classes))) + 1
    # One bincount gives the confusion matrix: rows predicted, columns target.
    confusion = np.bincount(
        predicted.ravel().astype(np.int64) * n + target.ravel(), minlength=n * n
    ).reshape(n, n)
    ids = np.asarray(classes)
    intersection = confusion[ids, ids]
    union = confusion[ids].sum(1) + confusion[:, ids].sum(0) - intersection
    present = union > 0
    if not present.any():
        return 1.0
    return float(np.mean(intersection[present] / union[present]))


def semantic_readings(predicted: np.ndarray, target: np.ndarray, num_classes: int = NUM_CLASSES) -> dict[str, float]:
    """The three readings of the paper's IoU from two class maps (module docstring).

    Args:
        predicted: (H, W) integer class map (the view through the estimate).
        target: (H, W) integer class map (the view through the truth), ids below
            ``num_classes``.
        num_classes: classes 0 .. num_classes − 1, 0 the background.

    Returns:
        dict ``iou`` (classes 1.. present in either map; 1 when none is),
        ``iou_bg`` (classes 0.. present in either map) and ``iou_weighted``
        (per-class Jaccard weighted by the class's pixel share in ``target``).

    Example:
        >>> import numpy as np
        >>> truth = np.array([[0, 1, 1, 2]]); estimate = np.array([[0, 1, 2, 2]])
        >>> semantic_readings(estimate, truth)  # J = 1, 1/2, 1/2 for classes 0, 1, 2
        {'iou': 0.5, 'iou_bg': 0.6666666666666666, 'iou_weighted': 0.625}
    """
    n = int(max(predicted.max(initial=0), target.max(initial=0), num_classes - 1)) + 1
    # One bincount gives the confusion matrix: rows predicted, columns target.
    confusion = np.bincount(
        predicted.ravel().astype(np.int64) * n + target.ravel().astype(np.int64), minlength=n * n
    ).reshape(n, n)[:num_classes, :num_classes]
    intersection = np.diag(confusion).astype(np.float64)
    support = confusion.sum(0)  # pixels of each class in the target
    union = confusion.sum(1) + support - intersection
    present = union > 0
    jaccard = np.divide(intersection, union, out=np.zeros(num_classes), where=present)
    foreground = present[1:]
    return {
        "iou": float(np.mean(jaccard[1:][foreground])) if foreground.any() else 1.0,
        "iou_bg": float(np.mean(jaccard[present])) if present.any() else 1.0,
        "iou_weighted": float(np.dot(jaccard, support) / support.sum()) if support.sum() else 1.0,
    }


def iou(
    scene_semantic: np.ndarray,
    H_est: Any,
    H_true: np.ndarray,
    image_size: tuple[int, int],
    classes: Sequence[int] = CLASSES,
) -> float:
    """The paper's IoU: both views of the scene's semantic map, compared per class.

    Args:
        scene_semantic: (Hs, Ws) uint8 bird's-eye class map.
        H_est: (3, 3) estimate, bird's-eye → image, any sign (checked, oriented).
        H_true: (3, 3) true homography, bird's-eye → image, depth sign kept.
        image_size: ``(width, height)`` of the image.
        classes: class ids averaged over.

    Returns:
        IoU in [0, 1]; 0 for a failed estimate.

    Raises:
        TruthError: ``H_true`` is not valid truth (:func:`check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    return 0.0 if H is None else _iou(scene_semantic, H, H_true, image_size, classes)


def _iou(scene_semantic: np.ndarray, H: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int],
         classes: Sequence[int]) -> float:
    """:func:`iou` of an estimate already checked and oriented by :func:`check_homography`."""
    predicted, target = _renders(scene_semantic, H, H_true, image_size)
    return semantic_iou(predicted, target, classes)


def _renders(scene_semantic: np.ndarray, H: np.ndarray, H_true: np.ndarray,
             image_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The two views every reading compares: through the (checked) estimate and through the truth."""
    return (render_semantic(scene_semantic, H, image_size),
            render_semantic(scene_semantic, np.asarray(H_true, np.float64), image_size))


def readings(scene_semantic: np.ndarray, H_est: Any, H_true: np.ndarray, image_size: tuple[int, int]) -> dict[str, float]:
    """The three readings of the paper's IoU (``iou``, ``iou_bg``, ``iou_weighted``) of one image.

    Args:
        scene_semantic: (Hs, Ws) uint8 bird's-eye class map, classes 0–3.
        H_est: (3, 3) estimate, bird's-eye → image, any scale and sign (checked).
        H_true: (3, 3) true homography, bird's-eye → image, depth sign kept.
        image_size: ``(width, height)`` of the image.

    Returns:
        dict of the three readings in [0, 1]; all 0 for a failed estimate.

    Raises:
        TruthError: ``H_true`` is not valid truth (:func:`check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    if H is None:
        return dict.fromkeys(READINGS, 0.0)
    return semantic_readings(*_renders(scene_semantic, H, H_true, image_size))


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


def _area(polygon: np.ndarray) -> float:
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
    area_a, area_b = _area(region_a), _area(region_b)
    if area_a <= 0:
        return 0.0
    intersection = _area(_clip(region_a, lines_b))
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
        TruthError: ``H_true`` is not valid truth (:func:`check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    return 0.0 if H is None else _iou_part(field_polygon(scene_shape, field), H, H_true, image_size)


def _true_field(field: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """The part of the field the true view sees (a polygon, empty when it sees none)."""
    # Ground g is seen iff e · (H g) ≥ 0 for every row e: half-planes (e H) · g ≥ 0.
    return _clip(field, _image_cone(image_size) @ np.asarray(H_true, np.float64))


def _iou_part(field: np.ndarray, H: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int]) -> float:
    """:func:`iou_part` of an estimate already checked and oriented by :func:`check_homography`."""
    lines_est = _image_cone(image_size) @ H
    return _polygon_iou(_true_field(field, H_true, image_size), _clip(field, lines_est), lines_est)


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
        TruthError: ``H_true`` is not valid truth (:func:`check_truth`).
    """
    H_true = check_truth(H_true, image_size)
    H, _ = check_homography(H_est, image_size)
    return 0.0 if H is None else _iou_whole(H, H_true, image_size, canvas_scale)


def _iou_whole(H: np.ndarray, H_true: np.ndarray, image_size: tuple[int, int], canvas_scale: float) -> float:
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


# --- batches -----------------------------------------------------------------------------


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
        DataFrame with one row per test image and columns :data:`METRICS` (float
        in [0, 1]), ``failed`` (bool), ``failure`` (reason, ``""`` if none) and
        ``skipped`` (bool: the true view sees none of the field; its metrics are
        NaN). Failed estimates score 0 on every metric.

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
    rows = []
    # Each estimate is checked (SVD, orientation) once, then scored by every metric.
    for estimate, H_true in zip(_estimate_items(H_est_batch, len(truths)), truths, strict=True):
        if _area(_true_field(polygon, H_true, image_size)) <= 0:
            rows.append((*[np.nan] * len(METRICS), False, "", True))
            continue
        if isinstance(estimate, _BatchShapeError):
            H, reason = None, estimate.reason
        else:
            H, reason = check_homography(estimate, image_size)
        if H is None:
            rows.append((*[0.0] * len(METRICS), True, reason, False))
            continue
        predicted, target = _renders(scene_semantic, H, H_true, image_size)
        scores = semantic_readings(predicted, target)
        if tuple(classes) != CLASSES:  # `iou` follows the classes asked for; the other readings keep 0–3
            scores["iou"] = semantic_iou(predicted, target, classes)
        rows.append((
            *(scores[name] for name in READINGS),
            _iou_part(polygon, H, H_true, image_size),
            _iou_whole(H, H_true, image_size, canvas_scale),
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
    """Means over the scored test images (failures count as 0), completeness and counts.

    Args:
        per_image: the frame returned by :func:`evaluate`.

    Returns:
        dict with every metric of :data:`METRICS` present in the frame (NaN when no
        image is scored), ``completeness``, ``n_images`` (scored images) and
        ``n_skipped`` (images whose true view sees no field).
    """
    scored = _scored(per_image)
    summary = {name: float(scored[name].mean()) if len(scored) else float("nan")
               for name in METRICS if name in per_image}
    summary["completeness"] = completeness(per_image)
    summary["n_images"] = float(len(scored))
    summary["n_skipped"] = float(len(per_image) - len(scored))
    return summary
