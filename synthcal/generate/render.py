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
filter), which removes the aliasing of far-away road markings.

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
from statistics import NormalDist

import cv2
import numpy as np

__all__ = [
    "inverse_homography",
    "visible_mask",
    "mask_invisible",
    "render_semantic",
    "render_image",
    "Appearance",
    "apply_appearance",
]


def inverse_homography(homography: np.ndarray) -> np.ndarray:
    """Inverse of a (3, 3) matrix by adjugate / determinant.

    Spelled out in the same operation order as :func:`synthcal.models.warp.inverse_3x3`
    so that the torch warp reproduces this module's sampling positions bit for bit
    (two LAPACK inverses may differ in the last bit, which flips pixels whose
    position falls exactly halfway between two bird's-eye pixels).
    """
    m = np.asarray(homography, dtype=np.float64)

    def minor(r0: int, r1: int, c0: int, c1: int) -> float:
        return m[r0, c0] * m[r1, c1] - m[r0, c1] * m[r1, c0]

    det = m[0, 0] * minor(1, 2, 1, 2) - m[0, 1] * minor(1, 2, 0, 2) + m[0, 2] * minor(1, 2, 0, 1)
    adjugate = np.array([
        minor(1, 2, 1, 2), m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2], minor(0, 1, 1, 2),
        m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2], minor(0, 2, 0, 2), m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2],
        minor(1, 2, 0, 1), m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1], minor(0, 1, 0, 1),
    ])
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
    h, w = image.shape[:2]
    s = supersample
    a, b, c = inverse_homography(homography)[2]
    xs = (np.arange(w) + 0.5) / s - 0.5
    ys = (np.arange(h) + 0.5) / s - 0.5
    row = b * ys + c
    ends = np.stack([row + a * xs[0], row + a * xs[-1]])
    image[ends.max(axis=0) <= 0] = 0
    for r in np.flatnonzero((ends.min(axis=0) <= 0) & (ends.max(axis=0) > 0)):
        image[r][~(row[r] + a * xs > 0)] = 0
    return image


def _supersampled(homography: np.ndarray, supersample: int) -> np.ndarray:
    """The homography into an image ``supersample`` times finer (same pixel-centre rule)."""
    s = float(supersample)
    A = np.array([[s, 0.0, (s - 1) / 2], [0.0, s, (s - 1) / 2], [0.0, 0.0, 1.0]])
    return A @ homography


def render_semantic(scene_semantic: np.ndarray, homography: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour semantic view of the scene through ``homography``.

    Args:
        scene_semantic: (Hs, Ws) uint8 bird's-eye class map.
        homography: (3, 3) bird's-eye → image homography with the depth sign.
        image_size: ``(width, height)`` of the output.

    Returns:
        (height, width) uint8 class map; 0 above the horizon and off the scene.
    """
    width, height = image_size
    M = inverse_homography(homography)
    xs = np.arange(width, dtype=np.float64)
    ys = np.arange(height, dtype=np.float64)[:, None]
    view = np.zeros((height, width), np.uint8)
    # The ground is a half-plane of the image: only rows that see some of it are computed.
    row_depth = M[2, 1] * ys[:, 0] + M[2, 2]
    seen = np.flatnonzero(np.maximum(row_depth + M[2, 0] * xs[0], row_depth + M[2, 0] * xs[-1]) > 0)
    if not len(seen):
        return view
    rows = slice(seen[0], seen[-1] + 1)
    ys = ys[rows]
    depth = (M[2, 1] * ys + M[2, 2]) + M[2, 0] * xs
    visible = depth > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        reciprocal = np.where(visible, 1.0 / depth, 0.0)
        col = np.rint(((M[0, 1] * ys + M[0, 2]) + M[0, 0] * xs) * reciprocal)
        row = np.rint(((M[1, 1] * ys + M[1, 2]) + M[1, 0] * xs) * reciprocal)
        scene_height, scene_width = scene_semantic.shape
        col_index, row_index = col.astype(np.intp), row.astype(np.intp)  # huge or negative: caught below
    # As unsigned, a negative index is huge: one comparison per axis checks both ends.
    inside = visible & (col_index.view(np.uintp) < scene_width) & (row_index.view(np.uintp) < scene_height)
    flat = np.where(inside, row_index * scene_width + col_index, 0)
    view[rows] = scene_semantic.reshape(-1).take(flat) * inside
    return view


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
    fine = cv2.warpPerspective(
        scene_image, _supersampled(np.asarray(homography, np.float64), s), (width * s, height * s),
        flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0,
    )
    mask_invisible(fine, homography, s)
    if s == 1:
        return fine
    return cv2.resize(fine, image_size, interpolation=cv2.INTER_AREA)


# Quantiles of N(0, 1) at the centres of 256 equal-probability bins.
_NORMAL_QUANTILES = np.array([NormalDist().inv_cdf((k + 0.5) / 256) for k in range(256)], dtype=np.float32)


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
    not depend on which changes are enabled. The noise is Gaussian quantised to 256
    levels (one random byte per value through the normal quantile function): exact
    normal draws cost as much as the whole warp at this image size.

    Args:
        image: (H, W, 3) uint8 RGB.
        appearance: ranges of the changes.
        rng: the sample's own generator.

    Returns:
        (H, W, 3) uint8 RGB.
    """
    offset, gain, sigma, noise_level = rng.uniform(size=4)
    levels = np.frombuffer(rng.bytes(image.size), dtype=np.uint8).reshape(image.shape)
    if appearance.blur_sigma > 0 and sigma * appearance.blur_sigma > 0.05:
        image = cv2.GaussianBlur(image, (0, 0), float(sigma * appearance.blur_sigma))
    out = image.astype(np.float32)
    factor = 1.0 + appearance.contrast * (2 * gain - 1)
    shift = (1.0 - factor) * float(out.mean()) + appearance.brightness * (2 * offset - 1)
    out = out * np.float32(factor) + np.float32(shift + 0.5)
    if appearance.noise_sigma > 0:
        out += _NORMAL_QUANTILES.take(levels) * np.float32(noise_level * appearance.noise_sigma)
    return np.clip(out, 0, 255).astype(np.uint8)
