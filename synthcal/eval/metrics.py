"""Per-image accuracy of estimated homographies (SPEC §8): the checks, and the paper's IoU.

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

The sports-field literature's metrics, ``iou_part`` (the ground seen, in the
bird's-eye plane) and ``iou_whole`` (the image against its round trip, in the image
plane), are computed exactly from polygons in :mod:`synthcal.eval.polygon`; all five
of a batch of images by :func:`synthcal.eval.scoring.evaluate`. Their names and
descriptions are :data:`synthcal.config.METRICS` and :data:`synthcal.config.DESCRIPTIONS`.

Failures and the truth
----------------------
A foreign estimate is first checked by :func:`check_homography`: ``None``, a
wrong shape, NaN/inf entries or a singular matrix (smallest singular value below
``1e-12`` of the largest; grid cameras are above ``1e-8``) score 0 on every metric
and are flagged; otherwise it is divided by its largest absolute entry (so
``1e150 · H`` and ``1e-150 · H`` score as ``H``: nothing downstream overflows)
and its overall sign is fixed with
:func:`synthcal.generate.camera.orient_homography`.

The truth is data, not an estimate: :func:`check_truth` checks a true ``H``: its
bottom-centre pixel must see the ground in front of the camera (SPEC §2's rule),
else :class:`TruthError` names the sample.

Example
-------
>>> import numpy as np
>>> scene = np.repeat(np.repeat(np.array([[1, 2, 3]], np.uint8), 40, 1), 60, 0)
>>> H = np.array([[1.0, 0, -10], [0, 1, -10], [0, 0, 1]])
>>> iou(scene, H, H, (64, 36))
1.0
>>> readings(scene, H, H, (64, 36))
{'iou': 1.0, 'iou_bg': 1.0, 'iou_weighted': 1.0}
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from synthcal.config import READINGS
from synthcal.generate.camera import orient_homography
from synthcal.generate.render import render_semantic
from synthcal.store.errors import StoreError

__all__ = [
    "SINGULAR_RCOND",
    "CLASSES",
    "NUM_CLASSES",
    "TruthError",
    "check_homography",
    "check_truth",
    "semantic_iou",
    "semantic_readings",
    "iou",
    "readings",
]

SINGULAR_RCOND = 1e-12
CLASSES = (1, 2, 3)
NUM_CLASSES = 4


class TruthError(StoreError):
    """A true homography that breaks SPEC §2's rule: an error in the data, not a score.

    A :class:`~synthcal.store.StoreError` (a ValueError), so that the command line reports
    it as one line naming the store and sample, as it does any other damaged data.
    """


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
    predicted, target = estimate_and_true_views(scene_semantic, H, H_true, image_size)
    return semantic_iou(predicted, target, classes)


def estimate_and_true_views(scene_semantic: np.ndarray, H: np.ndarray, H_true: np.ndarray,
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
    return semantic_readings(*estimate_and_true_views(scene_semantic, H, H_true, image_size))
