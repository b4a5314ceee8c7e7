"""The working resolution of the networks: maps and homographies of the full image reduced.

Networks see maps of ``work_size`` ``(w, h)``, which may be smaller than the
store's ``(W, H)``. Pixel centres correspond by
``x_w = (x + 0.5) · w / W − 0.5`` (same for rows), the affine matrix ``A`` of
:func:`resolution_matrix`; a homography ``H`` of the full image is ``A H`` at the
working resolution and back by ``A⁻¹``. Class maps are reduced by averaging their
one-hot maps over each output pixel's footprint (area interpolation, exact for
integer factors) and taking the most frequent class; RGB by area averaging.
Ground-truth matching always uses the full-resolution maps, its definition.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from synthcal.models import one_hot_maps

__all__ = ["NUM_CLASSES", "resolution_matrix", "reduce_class_maps", "reduce_images"]

NUM_CLASSES = 4
_CHUNK = 256


def resolution_matrix(full_size: tuple[int, int], work_size: tuple[int, int]) -> np.ndarray:
    """``A``: full-image pixels → working-resolution pixels (pixel centres kept).

    Args:
        full_size: ``(W, H)`` of the stored images.
        work_size: ``(w, h)`` the networks use.

    Returns:
        (3, 3) float64 affine matrix.
    """
    sx, sy = work_size[0] / full_size[0], work_size[1] / full_size[1]
    return np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])


def reduce_class_maps(semantics: np.ndarray, work_size: tuple[int, int]) -> Tensor:
    """(K, H, W) class ids → (K, h, w) uint8 class ids (most frequent in the footprint)."""
    semantics = np.asarray(semantics)
    if semantics.shape[-1:-3:-1] == tuple(work_size):
        return torch.from_numpy(semantics.astype(np.uint8))
    out = []
    for start in range(0, len(semantics), _CHUNK):
        maps = one_hot_maps(torch.from_numpy(semantics[start:start + _CHUNK]), NUM_CLASSES)
        out.append(F.interpolate(maps, size=work_size[::-1], mode="area").argmax(1).to(torch.uint8))
    return torch.cat(out) if out else torch.empty(0, *work_size[::-1], dtype=torch.uint8)


def reduce_images(images: np.ndarray, work_size: tuple[int, int]) -> Tensor:
    """(K, H, W, 3) uint8 RGB → (K, 3, h, w) uint8 (area average)."""
    out = []
    for start in range(0, len(images), _CHUNK):
        chunk = torch.from_numpy(np.asarray(images[start:start + _CHUNK])).permute(0, 3, 1, 2)
        if chunk.shape[-1:-3:-1] != tuple(work_size):
            chunk = F.interpolate(chunk.float(), size=work_size[::-1], mode="area").round().to(torch.uint8)
        out.append(chunk.contiguous())
    return torch.cat(out) if out else torch.empty(0, 3, *work_size[::-1], dtype=torch.uint8)
