"""Cheirality-masked warping of a bird's-eye semantic map into camera views.

Convention
----------
``homography`` maps a bird's-eye pixel to an image pixel, ``x_img ~ H (u, v, 1)ᵀ``,
with the depth sign kept (SPEC §2). Each image pixel ``x`` (pixel centres at
integers) samples the scene at ``H⁻¹ x``; it sees the ground only where the third
coordinate of ``H⁻¹ x`` is positive, and everything else (above the horizon, off
the scene) is class 0 / zero.

Modes
-----
* ``"nearest"`` reproduces :func:`synthcal.generate.render.render_semantic` pixel
  for pixel when ``homography`` is float64: both compute the sampling positions in
  double precision and round half to even. Not differentiable.
* ``"bilinear"`` samples with ``torch.nn.functional.grid_sample``
  (``align_corners=True``, zero padding) and multiplies by the cheirality mask, so
  gradients reach ``homography`` through the sampling positions. Positions are
  computed in ``homography``'s dtype (float64 recommended: the bird's-eye map is
  large), then cast to the scene's dtype for sampling.

  This is the warp of ``kornia.geometry.transform.warp_perspective(scene, H, (h, w),
  align_corners=True)`` times the cheirality mask; the two agree to 1e-12 in float64,
  gradients included (``tests/models/test_warp.py``). kornia is not used: it
  computes positions in the scene's dtype, so on a float32 map it is several times
  less accurate, and as accurate only by sampling a float64 copy, 1.1–3.4× slower
  (``benchmarks/warp.py``, ``docs/decisions.md``).

Example
-------
>>> import torch
>>> scene = torch.nn.functional.one_hot(torch.randint(0, 4, (50, 80)), 4).permute(2, 0, 1).float()
>>> H = torch.tensor([[1.0, 0, -10], [0, 1, -5], [0, 0, 1]], dtype=torch.float64)
>>> warp_semantic(scene, H[None], (32, 18)).shape
torch.Size([1, 4, 18, 32])
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

__all__ = ["inverse_3x3", "ground_coordinates", "cheirality_mask", "warp_semantic"]

# Normalised sampling positions beyond this only ever read the zero padding.
_GRID_LIMIT = 2.0


def inverse_3x3(matrix: Tensor) -> Tensor:
    """Inverse of 3 × 3 matrices in closed form (adjugate / determinant).

    Batched, differentiable, and the same on every device (no LAPACK call);
    singular matrices give inf/nan.

    Args:
        matrix: (..., 3, 3).

    Returns:
        (..., 3, 3) inverses.
    """
    m = matrix

    def minor(r0: int, r1: int, c0: int, c1: int) -> Tensor:
        return m[..., r0, c0] * m[..., r1, c1] - m[..., r0, c1] * m[..., r1, c0]

    det = (m[..., 0, 0] * minor(1, 2, 1, 2) - m[..., 0, 1] * minor(1, 2, 0, 2)
           + m[..., 0, 2] * minor(1, 2, 0, 1))
    d = 1.0 / det
    adjugate = torch.stack([
        minor(1, 2, 1, 2), m[..., 0, 2] * m[..., 2, 1] - m[..., 0, 1] * m[..., 2, 2], minor(0, 1, 1, 2),
        m[..., 1, 2] * m[..., 2, 0] - m[..., 1, 0] * m[..., 2, 2], minor(0, 2, 0, 2),
        m[..., 0, 2] * m[..., 1, 0] - m[..., 0, 0] * m[..., 1, 2],
        minor(1, 2, 0, 1), m[..., 0, 1] * m[..., 2, 0] - m[..., 0, 0] * m[..., 2, 1], minor(0, 1, 0, 1),
    ], dim=-1)
    return (adjugate * d[..., None]).reshape(matrix.shape)


def ground_coordinates(homography: Tensor, image_size: tuple[int, int]) -> tuple[Tensor, Tensor, Tensor]:
    """Bird's-eye position seen by every image pixel, and whether it is in front.

    Computed in ``homography``'s dtype and differentiable with respect to it.

    Args:
        homography: (B, 3, 3) bird's-eye → image homographies.
        image_size: ``(width, height)`` of the image.

    Returns:
        ``(u, v, visible)``: (B, height, width) bird's-eye column and row (0 where
        not visible, so they stay finite for autograd) and the bool cheirality mask
        (third coordinate of ``H⁻¹ x`` > 0).
    """
    width, height = image_size
    M = inverse_3x3(homography)
    xs = torch.arange(width, dtype=M.dtype, device=M.device)
    ys = torch.arange(height, dtype=M.dtype, device=M.device)[:, None]

    def row(i: int) -> Tensor:
        m = M[:, i, :, None, None]
        return (m[:, 1] * ys + m[:, 2]) + m[:, 0] * xs

    depth = row(2)
    visible = depth > 0
    # Sanitise the denominator *before* dividing: a nan/inf in a discarded branch
    # would still poison the gradient.
    reciprocal = torch.where(visible, 1.0 / torch.where(visible, depth, torch.ones_like(depth)), 0.0)
    return row(0) * reciprocal, row(1) * reciprocal, visible


def cheirality_mask(homography: Tensor, image_size: tuple[int, int]) -> Tensor:
    """Pixels that see the ground in front of the camera.

    Args:
        homography: (B, 3, 3) bird's-eye → image homographies.
        image_size: ``(width, height)``.

    Returns:
        (B, height, width) bool.
    """
    return ground_coordinates(homography, image_size)[2]


def _nearest(scene: Tensor, u: Tensor, v: Tensor, visible: Tensor) -> Tensor:
    """Nearest-neighbour sampling; scene (Hs, Ws), (C, Hs, Ws) or (B, C, Hs, Ws)."""
    hs, ws = scene.shape[-2:]
    col, row = torch.round(u), torch.round(v)  # half to even, like cvRound
    inside = visible & (col >= 0) & (col <= ws - 1) & (row >= 0) & (row <= hs - 1)
    # Index in int64: float32 is exact only up to 2^24 scene pixels.
    flat = torch.where(inside, row, 0).long() * ws + torch.where(inside, col, 0).long()  # (B, H, W)
    if scene.ndim == 2:
        out = scene.reshape(-1)[flat]
        return torch.where(inside, out, torch.zeros_like(out))
    if scene.ndim == 3:
        out = scene.reshape(scene.shape[0], -1)[:, flat].transpose(0, 1)  # (B, C, H, W)
    else:
        index = flat.reshape(flat.shape[0], 1, -1).expand(-1, scene.shape[1], -1)
        out = scene.reshape(*scene.shape[:2], -1).gather(2, index).reshape(*scene.shape[:2], *flat.shape[1:])
    return out * inside[:, None].to(out.dtype)


def _bilinear(scene: Tensor, u: Tensor, v: Tensor, visible: Tensor) -> Tensor:
    """Bilinear sampling (differentiable in u, v); scene (C, Hs, Ws) or (B, C, Hs, Ws)."""
    hs, ws = scene.shape[-2:]
    # align_corners=True: -1 and 1 are the centres of the first and last pixels.
    grid = torch.stack([u * (2.0 / (ws - 1)) - 1, v * (2.0 / (hs - 1)) - 1], dim=-1)
    grid = grid.clamp(-_GRID_LIMIT, _GRID_LIMIT).to(scene.dtype)
    batch, height, width = u.shape
    if scene.ndim == 3:
        # One scene for all views: stack the views' grids vertically instead of
        # copying the (large) scene B times.
        out = F.grid_sample(scene[None], grid.reshape(1, batch * height, width, 2),
                            mode="bilinear", padding_mode="zeros", align_corners=True)
        out = out.reshape(scene.shape[0], batch, height, width).transpose(0, 1)
    else:
        out = F.grid_sample(scene, grid, mode="bilinear", padding_mode="zeros", align_corners=True)
    return out * visible[:, None].to(out.dtype)


def warp_semantic(
    scene: Tensor,
    homography: Tensor,
    image_size: tuple[int, int],
    mode: str = "bilinear",
) -> Tensor:
    """Camera views of a bird's-eye map through homographies, cheirality-masked.

    Args:
        scene: (C, Hs, Ws) float map shared by all views (one-hot or soft), or
            (B, C, Hs, Ws) one map per view, or (Hs, Ws) integer class ids
            (``"nearest"`` only).
        homography: (B, 3, 3) bird's-eye → image homographies, or (3, 3) for a
            single view (the output then has no batch axis).
        image_size: ``(width, height)`` of the views.
        mode: ``"nearest"`` (the generator's renderer) or ``"bilinear"``
            (differentiable with respect to ``homography``).

    Returns:
        (B, C, height, width) views in the scene's dtype, or (B, height, width)
        class ids for a class-id scene.
    """
    single = homography.ndim == 2
    H = homography[None] if single else homography
    if scene.ndim == 4 and scene.shape[0] != H.shape[0]:
        raise ValueError(f"{scene.shape[0]} scenes for {H.shape[0]} homographies")
    u, v, visible = ground_coordinates(H, image_size)
    if mode == "nearest":
        out = _nearest(scene, u, v, visible)
    elif mode == "bilinear":
        if not scene.dtype.is_floating_point or scene.ndim == 2:
            raise ValueError("bilinear warping needs a float (C, Hs, Ws) or (B, C, Hs, Ws) map")
        out = _bilinear(scene, u, v, visible)
    else:
        raise ValueError(f"mode must be 'nearest' or 'bilinear', got {mode!r}")
    return out[0] if single else out
