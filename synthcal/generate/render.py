"""Rendering a camera's view of a bird's-eye scene.

Convention
----------
``homography`` maps a bird's-eye pixel to an image pixel (``x_img ~ H (u, v, 1)ᵀ``,
third coordinate = depth > 0 in front of the camera; SPEC §2). An image pixel
``x`` sees the ground point ``H⁻¹ x`` only where that point's third coordinate is
positive (*cheirality*); pixels above the horizon, and pixels whose ground point
falls outside the bird's-eye image, are class 0 and black.

The semantic map is sampled with nearest neighbour from sampling positions computed
here in float64 (``u = row0 / depth`` with ``row_i = (m_i1 y + m_i2) + m_i0 x``,
``M = H⁻¹``), rounded half to even; positions outside the scene give class 0. The
arithmetic is spelled out, rather than left to ``cv2.warpPerspective`` (whose
kernels changed from double to float32 arithmetic in OpenCV 4.11), so that stores
do not depend on the OpenCV version and the models' torch warp reproduces the map
bit for bit. The RGB view is rendered at ``supersample`` times
the output resolution with bilinear interpolation and averaged down (area
filter), which removes the aliasing of far-away road markings. Both renderers
compute only the rows that see some ground (:func:`ground_rows`): the sky of a
camera that sees the horizon costs nothing.

Example
-------
>>> import numpy as np
>>> from synthcal.generate.camera import homography
>>> H = homography(np.array([0.0]), np.array([-5.0]), np.array([150.0]),
...                np.array([[50.0, 50.0, 20.0]]), (64, 36))[0]
>>> semantic = np.ones((100, 200), np.uint8)
>>> view = render_semantic(semantic, H, (64, 36))
>>> view.shape, int(view[0].max()), int(view[-1].min())
((36, 64), 0, 1)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from statistics import NormalDist
from typing import NamedTuple

import cv2
import numpy as np

__all__ = [
    "inverse_homography",
    "visible_mask",
    "ground_rows",
    "mask_invisible",
    "render_semantic",
    "render_semantic_and_mask",
    "scene_mask",
    "render_image",
    "Appearance",
    "apply_appearance",
    "apply_appearance_on_ground",
    "foreground_fraction",
    "supersampled",
]


def inverse_homography(homography: np.ndarray) -> np.ndarray:
    """Inverse of a (3, 3) matrix by adjugate / determinant.

    Spelled out in the same operation order as :func:`synthcal.models.warp.inverse_3x3`
    so that the torch warp reproduces this module's sampling positions bit for bit
    (two LAPACK inverses may differ in the last bit, which flips pixels whose
    position falls exactly halfway between two bird's-eye pixels).
    """
    # Python floats are IEEE doubles like float64, and several times faster to index.
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(homography, dtype=np.float64).tolist()
    adjugate = np.array([
        m11 * m22 - m12 * m21, m02 * m21 - m01 * m22, m01 * m12 - m02 * m11,
        m12 * m20 - m10 * m22, m00 * m22 - m02 * m20, m02 * m10 - m00 * m12,
        m10 * m21 - m11 * m20, m01 * m20 - m00 * m21, m00 * m11 - m01 * m10,
    ])
    det = m00 * adjugate[0] - m01 * (m10 * m22 - m12 * m20) + m02 * adjugate[6]
    return (adjugate * (1.0 / det)).reshape(3, 3)


def visible_mask(homography: np.ndarray, image_size: tuple[int, int], supersample: int = 1) -> np.ndarray:
    """Pixels that see the ground in front of the camera (cheirality).

    Args:
        homography: (3, 3) bird's-eye → image homography with the depth sign.
        image_size: ``(width, height)`` of the output image.
        supersample: the mask is computed on a grid ``supersample`` times finer,
            whose pixel centres sit at ``(i + 0.5) / s - 0.5`` output pixels.

    Returns:
        (height · s, width · s) bool array, True where the pixel sees the ground.
    """
    width, height = image_size
    a, b, c = inverse_homography(homography)[2]
    s = supersample
    xs = (np.arange(width * s) + 0.5) / s - 0.5
    ys = (np.arange(height * s) + 0.5) / s - 0.5
    return np.add.outer(b * ys + c, a * xs) > 0


@lru_cache(maxsize=16)
def _pixel_centres(count: int, supersample: int) -> np.ndarray:
    """(count,) centres of the pixels of an axis ``supersample`` times finer, in output
    pixels: ``(i + 0.5) / s − 0.5`` (read-only; cached, as every sample asks again)."""
    centres = (np.arange(count) + 0.5) / supersample - 0.5
    centres.flags.writeable = False
    return centres


class _RowDepths(NamedTuple):
    """Depth of ``H⁻¹ x`` over an (h, w) image ``supersample`` times finer than the
    output: ``depth[r, i] = row[r] + a · xs[i]`` (the sums of :func:`visible_mask`).
    Depth is linear along a row, so a row's extremes sit at its end pixels."""

    row: np.ndarray  # (h,)
    xs: np.ndarray  # (w,)
    a: float
    highest: np.ndarray  # (h,) each row's largest depth
    lowest: np.ndarray  # (h,) each row's smallest depth

    @classmethod
    def of(cls, inverse: np.ndarray, shape: tuple[int, int], supersample: int) -> _RowDepths:
        """From ``inverse`` = :func:`inverse_homography` of the output-resolution homography."""
        h, w = shape
        a, b, c = inverse[2].tolist()
        xs = _pixel_centres(w, supersample)
        row = b * _pixel_centres(h, supersample) + c
        first, last = row + a * xs[0], row + a * xs[-1]
        return cls(row, xs, a, np.maximum(first, last), np.minimum(first, last))

    def ground_rows(self) -> slice:
        seen = np.flatnonzero(self.highest > 0)
        return slice(seen[0], seen[-1] + 1) if len(seen) else slice(0, 0)

    def mask(self, image: np.ndarray) -> np.ndarray:
        image[self.highest <= 0] = 0
        for r in np.flatnonzero((self.lowest <= 0) & (self.highest > 0)):
            image[r][~(self.row[r] + self.a * self.xs > 0)] = 0
        return image


def ground_rows(homography: np.ndarray, shape: tuple[int, int], supersample: int = 1) -> slice:
    """The rows of an (h, w) image that see some ground (empty when none do).

    They are one contiguous run, because depth is linear down a column: the
    renderers compute only these rows, which skips the sky of cameras that see the
    horizon.

    Args:
        homography: (3, 3) bird's-eye → image homography (output resolution).
        shape: ``(h, w)`` of the image, ``supersample`` × the output size.
        supersample: the factor between ``shape`` and the output size.
    """
    return _RowDepths.of(inverse_homography(homography), shape, supersample).ground_rows()


def mask_invisible(image: np.ndarray, homography: np.ndarray, supersample: int = 1) -> np.ndarray:
    """Zero, in place, the pixels that :func:`visible_mask` marks invisible.

    Equal to ``image[~visible_mask(H, size, s)] = 0`` but fast: the visible set is a
    half-plane, so whole rows are decided from their end pixels (the same float
    sums as ``visible_mask``, which is monotone along a row) and only the few rows
    the horizon crosses are tested pixel by pixel.

    Args:
        image: (h, w) or (h, w, C) array at ``supersample`` × the output size.
        homography: (3, 3) bird's-eye → image homography (output resolution).
        supersample: the factor between ``image`` and the output size.

    Returns:
        ``image``.
    """
    return _RowDepths.of(inverse_homography(homography), image.shape[:2], supersample).mask(image)


def supersampled(homography: np.ndarray, supersample: int) -> np.ndarray:
    """The (3, 3) homography into an image ``supersample`` times finer (same pixel-centre rule).

    A pixel centre ``(u, v)`` of the output becomes ``(s·u + (s − 1)/2, s·v + (s − 1)/2)``
    in the finer image, ``s = supersample``.
    """
    s = float(supersample)
    A = np.array([[s, 0.0, (s - 1) / 2], [0.0, s, (s - 1) / 2], [0.0, 0.0, 1.0]])
    return A @ homography


def _rounded_quotient(m: np.ndarray, xs: np.ndarray, ys: np.ndarray, reciprocal: np.ndarray,
                      out: np.ndarray) -> None:
    """``rint(((m[1] y + m[2]) + m[0] x) · reciprocal)`` over the (h, w) grid, into ``out``."""
    np.add(m[1] * ys + m[2], m[0] * xs, out=out)
    np.multiply(out, reciprocal, out=out)
    np.rint(out, out=out)


def _scene_lookup(
    M: np.ndarray, rows: slice, width: int, scene_shape: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest bird's-eye pixel of each output pixel of ``rows``, and whether it is on the scene.

    Args:
        M: :func:`inverse_homography` of the output-resolution homography.
        rows: a non-empty run of output rows (:func:`ground_rows`).
        width: output width.
        scene_shape: ``(Hs, Ws)`` of the bird's-eye image.

    Returns:
        flat scene indices (0 where not on the scene) and the (len(rows), width)
        bool mask of pixels that see the scene in front of the camera.
    """
    xs = np.arange(width, dtype=np.float64)
    ys = np.arange(rows.start, rows.stop, dtype=np.float64)[:, None]
    depth = (M[2, 1] * ys + M[2, 2]) + M[2, 0] * xs
    scene_height, scene_width = scene_shape
    # The same float64 expressions as ``row = rint(((m11 y + m12) + m10 x) * (1 / depth))``,
    # evaluated into two reused (h, w) buffers (≈ 10 % of the lookup went on temporaries).
    # Where depth ≤ 0 the quotients are meaningless (even inf or NaN): ``inside``
    # rejects those pixels, and whatever their casts give is zeroed below.
    inside = depth > 0
    row, col = np.empty_like(depth), np.empty_like(depth)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        reciprocal = np.divide(1.0, depth, out=depth)
        _rounded_quotient(M[1], xs, ys, reciprocal, out=row)
        inside &= row >= 0
        inside &= row < scene_height
        _rounded_quotient(M[0], xs, ys, reciprocal, out=col)
        inside &= col >= 0
        inside &= col < scene_width
        index_type = np.int32 if scene_height * scene_width < 2**31 else np.int64
        flat = row.astype(index_type)
        flat *= scene_width
        flat += col.astype(index_type)
    flat *= inside
    return flat, inside


def render_semantic(scene_semantic: np.ndarray, homography: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour semantic view of the scene through ``homography``.

    Args:
        scene_semantic: (Hs, Ws) uint8 bird's-eye class map.
        homography: (3, 3) bird's-eye → image homography with the depth sign.
        image_size: ``(width, height)`` of the output.

    Returns:
        (height, width) uint8 class map; 0 above the horizon and off the scene.
    """
    return render_semantic_and_mask(scene_semantic, homography, image_size)[0]


def render_semantic_and_mask(
    scene_semantic: np.ndarray, homography: np.ndarray, image_size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`render_semantic` and :func:`scene_mask` in one pass.

    Returns:
        (height, width) uint8 class map and (height, width) bool, True where the
        pixel sees the scene.
    """
    width, height = image_size
    view = np.zeros((height, width), np.uint8)
    mask = np.zeros((height, width), bool)
    M = inverse_homography(homography)
    rows = _RowDepths.of(M, (height, width), 1).ground_rows()
    if rows.start == rows.stop:
        return view, mask
    flat, inside = _scene_lookup(M, rows, width, scene_semantic.shape[:2])
    labels = scene_semantic.reshape(-1).take(flat)
    labels *= inside
    view[rows] = labels
    mask[rows] = inside
    return view, mask


def scene_mask(homography: np.ndarray, image_size: tuple[int, int], scene_shape: tuple[int, int]) -> np.ndarray:
    """Pixels that see the scene: in front of the camera, their ground point on the bird's-eye image.

    Exactly the pixels :func:`render_semantic` samples the scene for (the same
    nearest-pixel positions); the others are class 0 in the semantic map and
    black in the image.

    Args:
        homography: (3, 3) bird's-eye → image homography with the depth sign.
        image_size: ``(width, height)`` of the output.
        scene_shape: ``(Hs, Ws)`` of the bird's-eye image.

    Returns:
        (height, width) bool.
    """
    width, height = image_size
    mask = np.zeros((height, width), bool)
    M = inverse_homography(homography)
    rows = _RowDepths.of(M, (height, width), 1).ground_rows()
    if rows.start < rows.stop:
        mask[rows] = _scene_lookup(M, rows, width, scene_shape)[1]
    return mask


def foreground_fraction(semantic: np.ndarray) -> np.ndarray:
    """Share of non-background pixels (class ≠ 0) of each semantic map.

    Args:
        semantic: (..., H, W) class maps.

    Returns:
        (...) float64 in [0, 1]; 0 for an empty (all-background) map.
    """
    semantic = np.asarray(semantic)
    pixels = semantic.shape[-2] * semantic.shape[-1]
    counts = np.count_nonzero(semantic.reshape(*semantic.shape[:-2], pixels), axis=-1)
    return np.asarray(counts / pixels, np.float64)


def render_image(
    scene_image: np.ndarray, homography: np.ndarray, image_size: tuple[int, int], supersample: int = 2
) -> np.ndarray:
    """Anti-aliased RGB view of the scene through ``homography``.

    Args:
        scene_image: (Hs, Ws, 3) uint8 bird's-eye RGB.
        homography: (3, 3) bird's-eye → image homography with the depth sign.
        image_size: ``(width, height)`` of the output.
        supersample: rendering resolution factor (1 disables anti-aliasing).

    Returns:
        (height, width, 3) uint8 RGB; black above the horizon and off the scene.
    """
    width, height = image_size
    s = int(supersample)
    fine = np.empty((height * s, width * s, 3), np.uint8)
    depths = _RowDepths.of(inverse_homography(homography), fine.shape[:2], s)
    rows = depths.ground_rows()
    fine[: rows.start] = 0
    fine[rows.stop :] = 0
    if rows.start < rows.stop:
        # Warp only the rows that see ground, straight into their place in ``fine``.
        shift = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, -rows.start], [0.0, 0.0, 1.0]])
        cv2.warpPerspective(
            scene_image, shift @ supersampled(np.asarray(homography, np.float64), s),
            (width * s, rows.stop - rows.start), dst=fine[rows], flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT, borderValue=0,
        )
    depths.mask(fine)
    if s == 1:
        return fine
    return cv2.resize(fine, image_size, interpolation=cv2.INTER_AREA)


# Gaussian noise table: N(0, 1) at the centres of 256 equal-probability bins, in
# units of 1/_NOISE_STEPS standard deviations around 128 (so it fits in a byte).
_NOISE_STEPS = 32
_NOISE_TABLE = np.array(
    [[128 + round(_NOISE_STEPS * NormalDist().inv_cdf((k + 0.5) / 256)) for k in range(256)]], dtype=np.uint8
)


@dataclass(frozen=True)
class Appearance:
    """Ranges of the per-sample photometric changes (all drawn uniformly).

    Attributes:
        brightness: maximum absolute offset, in grey levels.
        contrast: maximum relative change of contrast (0.2 → factor in [0.8, 1.2]).
        blur_sigma: maximum Gaussian blur sigma in pixels.
        noise_sigma: maximum standard deviation of additive Gaussian noise.
    """

    brightness: float = 0.0
    contrast: float = 0.0
    blur_sigma: float = 0.0
    noise_sigma: float = 0.0


def apply_appearance(image: np.ndarray, appearance: Appearance, rng: np.random.Generator) -> np.ndarray:
    """Random brightness, contrast, blur and noise, drawn from ``rng``.

    The same draws are made whatever the ranges, so a sample's random stream does
    not depend on which changes are enabled. The noise is Gaussian quantised to
    1/32 of its standard deviation (one random byte per value through a table of
    the normal quantile function): exact normal draws cost as much as the whole
    warp at this image size. Contrast, brightness and noise are one weighted sum,
    rounded and clipped to bytes.

    Args:
        image: (H, W, 3) uint8 RGB.
        appearance: ranges of the changes.
        rng: the sample's own generator.

    Returns:
        (H, W, 3) uint8 RGB.
    """
    offset, gain, sigma, noise_level = rng.uniform(size=4)
    # Raw 64-bit outputs viewed as bytes: half the cost of ``rng.bytes``.
    levels = rng.bit_generator.random_raw(-(-image.size // 8)).view(np.uint8)[: image.size].reshape(image.shape)
    if appearance.blur_sigma > 0 and sigma * appearance.blur_sigma > 0.05:
        image = cv2.GaussianBlur(image, (0, 0), float(sigma * appearance.blur_sigma))
    channels = image.shape[2] if image.ndim == 3 else 1
    mean = sum(cv2.mean(image)[:channels]) / channels
    factor = 1.0 + appearance.contrast * (2 * gain - 1)
    shift = (1.0 - factor) * mean + appearance.brightness * (2 * offset - 1)
    noise_gain = noise_level * appearance.noise_sigma / _NOISE_STEPS
    noise = cv2.LUT(levels, _NOISE_TABLE)  # 128 + 32 · N(0, 1)
    return cv2.addWeighted(image, factor, noise, noise_gain, shift - 128 * noise_gain)


def apply_appearance_on_ground(
    image: np.ndarray,
    homography: np.ndarray,
    appearance: Appearance,
    rng: np.random.Generator,
    on_scene: np.ndarray | None = None,
) -> np.ndarray:
    """:func:`apply_appearance` on the rows that see ground, in place; the sky stays black.

    Restricting it to those rows saves the time spent on the sky and keeps the
    contrast pivoting on the ground's mean rather than on black pixels. With
    ``on_scene`` (:func:`scene_mask`), the pixels whose ground point lies off the
    scene are black afterwards too, as in the semantic map: the brightness offset
    and noise would otherwise paint them grey. The pixels that see the scene are
    the same either way.

    Args:
        image: (H, W, 3) uint8 RGB at the output resolution of ``homography``.
        homography: (3, 3) bird's-eye → image homography.
        appearance: ranges of the changes.
        rng: the sample's own generator.
        on_scene: (H, W) bool, True where the pixel sees the scene (None: leave
            off-scene pixels as drawn).

    Returns:
        ``image``.
    """
    depths = _RowDepths.of(inverse_homography(homography), image.shape[:2], 1)
    rows = depths.ground_rows()
    if rows.start < rows.stop:
        image[rows] = apply_appearance(image[rows], appearance, rng)
        # Blur and brightness reach past the horizon within a row. ``on_scene`` lies inside the
        # visible half-plane (its depths are the same float sums), so it blacks out both.
        if on_scene is None:
            depths.mask(image)
        else:  # cv2.copyTo: ~10× faster than image[~on_scene] = 0
            image[...] = cv2.copyTo(image, np.ascontiguousarray(on_scene, np.uint8), np.zeros_like(image))
    return image
