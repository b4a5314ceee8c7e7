"""The classic bundled estimators: no learning beyond a colour table and a template search.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).

Bundled here (the learned models live in :mod:`synthcal.models`)
------------------------------------------------------------------
``identity``
    Ignores the image: always the train set's *medoid* camera — the train sample
    whose semantic view has the smallest mean squared one-hot distance to all
    train views. It is what the template pipeline returns when the image carries
    no information (identity refinement ``H̄ = I`` of a fixed template), the
    lower bound any estimator must beat. ``np.eye(3)`` itself would not be a
    camera of the scene and would score 0, telling nothing.
``template``
    The matched template alone: segment the image (a replaceable
    :class:`Segmenter`; default a colour look-up table fitted on the train set),
    pick the dictionary template of lowest MSE between one-hot maps, return its
    homography.
``ecc``
    ``template``, then refined by OpenCV's ECC (``MOTION_HOMOGRAPHY``) between the
    template's and the image's semantic maps: ``H = W · H_k`` with ``W`` the found
    template-pixel → image-pixel warp.
``proposed``, ``baseline`` (alias ``sha2020``), ``sha2020-ccbv``
    The paper's models, UNet → Siamese → STN (:mod:`synthcal.estimators.paper`).
``retrieved``, ``oracle-template``
    Diagnostics: the Siamese's template alone, and the best template by the true
    matching score (:mod:`synthcal.estimators.diagnostic`).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from synthcal.estimators.protocol import SceneLike, Segmenter, SplitLike

__all__ = [
    "ColourSegmenter",
    "IdentityEstimator",
    "TemplateEstimator",
    "ECCEstimator",
    "one_hot",
    "match_templates",
    "match_strided",
    "medoid_index",
    "ecc_warp",
]

NUM_CLASSES = 4
# Dictionary maps read per block in fit (a lazy pool dictionary is streamed).
_TEMPLATE_BATCH = 1024


# --- segmentation -----------------------------------------------------------------------


def _subsample(array: Any, max_items: int) -> np.ndarray:
    """Up to ``max_items`` evenly spaced items along axis 0, by basic slicing (lazy-array safe)."""
    step = max(1, -(-len(array) // max_items))
    return np.asarray(array[::step])


class ColourSegmenter:
    """Per-pixel classifier by a colour look-up table fitted on labelled images.

    RGB is quantised to ``2**bits`` levels per channel; each colour bin takes the
    class most often seen with it in the training pixels. A class may have
    several colours (background is sky, roofs and pavement), which a single
    mean colour per class would miss. Bins never seen take the class whose mean
    colour is nearest. CPU-cheap: one ``bincount`` to fit, one table look-up to
    apply. Stand-in for the UNet (SPEC §7) behind the same :class:`Segmenter`
    interface.

    Args:
        bits: quantisation bits per channel (5 → 32,768 bins).
        max_images: at most this many evenly spaced train images are used to fit.
    """

    def __init__(self, bits: int = 5, max_images: int = 256) -> None:
        self.bits = int(bits)
        self.max_images = int(max_images)
        self.table: np.ndarray | None = None

    def _bins(self, images: np.ndarray) -> np.ndarray:
        q = (np.asarray(images, np.uint8) >> (8 - self.bits)).astype(np.int64)
        return (q[..., 0] << (2 * self.bits)) | (q[..., 1] << self.bits) | q[..., 2]

    def fit(self, images: np.ndarray, semantics: np.ndarray) -> None:
        images, semantics = _subsample(images, self.max_images), _subsample(semantics, self.max_images)
        n_bins = 1 << (3 * self.bits)
        labels = semantics.reshape(-1).astype(np.int64)
        counts = np.bincount(self._bins(images).reshape(-1) * NUM_CLASSES + labels,
                             minlength=n_bins * NUM_CLASSES).reshape(n_bins, NUM_CLASSES)
        pixels = images.reshape(-1, 3).astype(np.float64)
        totals = np.bincount(labels, minlength=NUM_CLASSES)
        means = np.stack([np.bincount(labels, pixels[:, k], NUM_CLASSES) for k in range(3)], 1)
        means = np.where(totals[:, None] > 0, means / np.maximum(totals, 1)[:, None], np.inf)
        levels = (np.arange(1 << self.bits) + 0.5) * (1 << (8 - self.bits))
        centres = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), -1).reshape(-1, 3)
        nearest = np.argmin(((centres[:, None, :] - means[None]) ** 2).sum(-1), axis=1)
        self.table = np.where(counts.sum(1) > 0, counts.argmax(1), nearest).astype(np.uint8)

    def __call__(self, images: np.ndarray) -> np.ndarray:
        if self.table is None:
            raise RuntimeError("ColourSegmenter: call fit() first")
        return self.table[self._bins(images)]


# --- matching ---------------------------------------------------------------------------


def one_hot(semantics: np.ndarray, stride: int = 1) -> np.ndarray:
    """Flattened one-hot class maps, for matching by matrix products.

    Args:
        semantics: (K, H, W) integer class ids in ``0..3``.
        stride: keep every ``stride``-th pixel in each direction.

    Returns:
        (K, 4 · ⌈H/stride⌉ · ⌈W/stride⌉) float32.
    """
    s = np.asarray(semantics)[:, ::stride, ::stride]
    return (s[..., None] == np.arange(NUM_CLASSES)).reshape(len(s), -1).astype(np.float32)


def match_templates(queries: np.ndarray, templates: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Index of the template of lowest MSE for each query (one-hot maps).

    For one-hot maps ``‖q − t‖² = 2 · #pixels whose labels differ = 2 (P − q·t)``,
    so the lowest MSE is the largest dot product: one GEMM per chunk of queries.

    Args:
        queries: (B, D) one-hot maps from :func:`one_hot`.
        templates: (K, D) one-hot maps, same stride.
        chunk: queries per matrix product (bounds memory to ``chunk × K``).

    Returns:
        (B,) int64 template indices (ties: the lowest index).
    """
    out = np.empty(len(queries), np.int64)
    for start in range(0, len(queries), chunk):
        out[start:start + chunk] = np.argmax(queries[start:start + chunk] @ templates.T, axis=1)
    return out


def match_strided(queries: np.ndarray, templates: np.ndarray, template_chunk: int = 2048) -> np.ndarray:
    """:func:`match_templates` against class-id templates, expanded to one-hot a block at a time.

    Memory: one block of ``template_chunk`` one-hot templates and its score matrix,
    whatever the dictionary's size; the answer is :func:`match_templates`'s
    (ties: the lowest index, kept across blocks by a strict comparison).

    Args:
        queries: (B, D) one-hot maps from :func:`one_hot`.
        templates: (T, h, w) uint8 class ids at the queries' stride.
        template_chunk: templates per block.

    Returns:
        (B,) int64 template indices.
    """
    best = np.full(len(queries), -np.inf, np.float32)
    out = np.zeros(len(queries), np.int64)
    for start in range(0, len(templates), template_chunk):
        scores = queries @ one_hot(templates[start:start + template_chunk]).T  # (B, block)
        position = np.argmax(scores, axis=1)
        value = scores[np.arange(len(queries)), position]
        better = value > best
        best = np.where(better, value, best)
        out = np.where(better, position + start, out)
    return out


def medoid_index(semantics: Any, chunk: int = 256) -> int:
    """The class map with the smallest mean squared one-hot distance to all others.

    ``mean_j ‖x_i − x_j‖² = ‖x_i − x̄‖² + const`` and, for one-hot ``x_i``,
    ``‖x_i − x̄‖² = const − 2 Σ_p x̄[p, label_i(p)]``: the medoid is the map whose
    labels agree best with the per-pixel class frequencies ``x̄`` — O(K·P), no
    K × K distance matrix.

    Args:
        semantics: (K, H, W) uint8 class ids (array or slicable lazy array).
        chunk: maps processed at a time.

    Returns:
        Index of the medoid in ``0..K-1``.
    """
    n = len(semantics)
    counts: np.ndarray | None = None
    for start in range(0, n, chunk):
        block = np.asarray(semantics[start:start + chunk]).astype(np.int64)
        c = (block[..., None] == np.arange(NUM_CLASSES)).sum(0)
        counts = c if counts is None else counts + c
    if counts is None:
        raise ValueError("medoid_index: no class maps (K = 0)")
    frequency = counts / n
    scores = []
    for start in range(0, n, chunk):
        block = np.asarray(semantics[start:start + chunk]).astype(np.int64)
        agree = np.take_along_axis(frequency[None], block[..., None], axis=-1)[..., 0]
        scores.append(agree.reshape(len(block), -1).sum(1))
    return int(np.argmax(np.concatenate(scores)))


# --- ECC refinement -----------------------------------------------------------------------

_GREY_LEVELS = np.array([0.0, 1.0, 2.0, 3.0], np.float32) / 3.0


def ecc_warp(
    template: np.ndarray,
    target: np.ndarray,
    iterations: int = 100,
    eps: float = 1e-6,
    blur: int = 5,
) -> np.ndarray | None:
    """Image homography between two class maps by ECC (OpenCV ``findTransformECC``).

    OpenCV's convention: the returned ``W`` satisfies ``target(W x) ≈ template(x)``,
    i.e. ``W`` maps *template* pixel coordinates to *target* pixel coordinates
    (pixel centres at integers). So if ``template`` was rendered by ``H_k``, the
    target is seen by ``W · H_k``. Class maps become grey images (class id / 3),
    smoothed by a ``blur`` × ``blur`` Gaussian inside ECC for a wider basin.

    Args:
        template: (H, W) class map (the matched template's view).
        target: (H, W) class map (the segmented input image).
        iterations: maximum ECC iterations.
        eps: ECC convergence threshold on the correlation increment.
        blur: Gaussian kernel size (odd, ≥ 1).

    Returns:
        (3, 3) float64 warp normalised to ``W[2, 2] = 1``, or None if ECC failed
        (no convergence, featureless input).
    """
    warp = np.eye(3, dtype=np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, int(iterations), float(eps))
    try:
        # OpenCV takes None for "no mask"; its stubs allow None only in the overload without gaussFiltSize.
        _, warp = cv2.findTransformECC(  # type: ignore[call-overload]
            _GREY_LEVELS[np.asarray(template)], _GREY_LEVELS[np.asarray(target)], warp,
            cv2.MOTION_HOMOGRAPHY, criteria, None, int(blur),
        )
    except cv2.error:
        return None
    warp = warp.astype(np.float64)
    if not np.isfinite(warp).all() or abs(warp[2, 2]) < 1e-12:
        return None
    return warp / warp[2, 2]


# --- bundled estimators -------------------------------------------------------------------


class IdentityEstimator:
    """Ignores the image and predicts the train set's medoid camera (module docstring)."""

    def __init__(self) -> None:
        self.homography: np.ndarray | None = None

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        self.homography = np.asarray(train.homographies[medoid_index(train.semantics)], np.float64)

    def predict(self, images: np.ndarray) -> np.ndarray:
        if self.homography is None:
            raise RuntimeError("IdentityEstimator: call fit() first")
        return np.repeat(self.homography[None], len(images), axis=0)


class TemplateEstimator:
    """Segment, then return the homography of the nearest dictionary template (MSE).

    Args:
        segmenter: any :class:`Segmenter`; default :class:`ColourSegmenter`. It is
            fitted on the train split in :meth:`fit` (pass ``fit_segmenter=False``
            for a segmenter that is already trained, e.g. the UNet).
        stride: pixel stride of the one-hot maps used for matching (2 keeps a
            1,000-template dictionary of 256 × 144 maps at 150 MB).
        fit_segmenter: whether :meth:`fit` trains the segmenter.
    """

    def __init__(self, segmenter: Segmenter | None = None, stride: int = 2, fit_segmenter: bool = True) -> None:
        self.segmenter = segmenter if segmenter is not None else ColourSegmenter()
        self.stride = int(stride)
        self.fit_segmenter = fit_segmenter
        self.templates: np.ndarray | None = None  # (T, h', w') uint8 strided class ids
        self.template_semantics: Any = None
        self.template_homographies: np.ndarray | None = None

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        """Fit the segmenter; keep the dictionary's strided class ids and homographies.

        The dictionary's maps are read ``_TEMPLATE_BATCH`` at a time and kept as
        (T, ⌈H/stride⌉, ⌈W/stride⌉) uint8 class ids (a lazy pool dictionary is never
        read whole at full size); ``template_semantics`` stays the dictionary's own
        array (lazy or not), read per matched template by ECC.
        """
        if self.fit_segmenter:
            self.segmenter.fit(train.images, train.semantics)
        self.template_semantics = dictionary.semantics
        self.template_homographies = np.asarray(dictionary.homographies, np.float64)
        s = self.stride
        blocks = [np.asarray(dictionary.semantics[a:a + _TEMPLATE_BATCH])[:, ::s, ::s]
                  for a in range(0, len(dictionary.semantics), _TEMPLATE_BATCH)]
        self.templates = np.concatenate(blocks) if blocks else np.empty((0, 1, 1), np.uint8)

    def match(self, images: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment ``images`` and match them.

        Returns:
            ``(indices, semantics)``: (B,) template indices and the (B, H, W)
            segmentations.
        """
        semantics = self.segmenter(np.asarray(images))
        return self.match_semantic(semantics), semantics

    def _dictionary(self) -> tuple[np.ndarray, Any, np.ndarray]:
        """``(templates, template_semantics, template_homographies)`` of the fitted dictionary."""
        if self.templates is None or self.template_semantics is None or self.template_homographies is None:
            raise RuntimeError(f"{type(self).__name__}: call fit() first")
        return self.templates, self.template_semantics, self.template_homographies

    def match_semantic(self, semantics: np.ndarray) -> np.ndarray:
        """(B,) indices of the templates nearest (MSE) to (B, H, W) class maps."""
        templates, _, _ = self._dictionary()
        return match_strided(one_hot(semantics, self.stride), templates)

    def predict(self, images: np.ndarray) -> np.ndarray:
        return self.predict_semantic(self.segmenter(np.asarray(images)))

    def predict_semantic(self, semantics: np.ndarray) -> np.ndarray:
        """The matched templates' homographies for (B, H, W) class maps."""
        _, _, homographies = self._dictionary()
        return homographies[self.match_semantic(semantics)].copy()


class ECCEstimator(TemplateEstimator):
    """:class:`TemplateEstimator`, then ECC refinement of the matched template.

    When ECC fails on an image, the matched template's homography is kept.

    Args:
        segmenter, stride, fit_segmenter: as :class:`TemplateEstimator`.
        iterations, eps, blur: as :func:`ecc_warp`.
    """

    def __init__(
        self,
        segmenter: Segmenter | None = None,
        stride: int = 2,
        fit_segmenter: bool = True,
        iterations: int = 100,
        eps: float = 1e-6,
        blur: int = 5,
    ) -> None:
        super().__init__(segmenter, stride, fit_segmenter)
        self.iterations, self.eps, self.blur = iterations, eps, blur

    def predict_semantic(self, semantics: np.ndarray) -> np.ndarray:
        _, template_semantics, homographies = self._dictionary()
        semantics = np.asarray(semantics)
        indices = self.match_semantic(semantics)
        out = homographies[indices].copy()
        for k, (index, semantic) in enumerate(zip(indices, semantics, strict=True)):
            warp = ecc_warp(template_semantics[index], semantic, self.iterations, self.eps, self.blur)
            if warp is not None:
                out[k] = warp @ out[k]
        return out
