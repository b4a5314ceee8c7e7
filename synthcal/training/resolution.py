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

from collections.abc import Iterable
from functools import lru_cache
from itertools import product

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from synthcal.models import one_hot_maps

__all__ = ["NUM_CLASSES", "resolution_matrix", "reduce_class_maps", "reduce_class_map_batches", "reduce_images"]

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
    fast = _block_modes(semantics, work_size)
    if fast is not None:
        return torch.from_numpy(fast)
    out = []
    for start in range(0, len(semantics), _CHUNK):
        maps = one_hot_maps(torch.from_numpy(semantics[start:start + _CHUNK]), NUM_CLASSES)
        out.append(F.interpolate(maps, size=work_size[::-1], mode="area").argmax(1).to(torch.uint8))
    return torch.cat(out) if out else torch.empty(0, *work_size[::-1], dtype=torch.uint8)


def reduce_class_map_batches(batches: Iterable[tuple[int, np.ndarray]], count: int,
                             work_size: tuple[int, int]) -> Tensor:
    """:func:`reduce_class_maps` of ``count`` maps given as ``(start, (k, H, W) maps)`` batches, e.g. a
    pool dictionary read shard by shard: (count, h, w) uint8, filled in place, so the peak memory is
    the result plus one batch at full size (a list of reduced batches and their concatenation would
    hold the result twice)."""
    out = torch.empty((count, work_size[1], work_size[0]), dtype=torch.uint8)
    filled = 0
    for start, maps in batches:
        out[start:start + len(maps)] = reduce_class_maps(maps, work_size)
        filled += len(maps)
    if filled != count:
        raise ValueError(f"reduce_class_map_batches: {filled} maps given, {count} expected")
    return out


# Integer reduction factors of at most 8 pixels per output pixel: the footprint's class
# ids (2 bits each) packed side by side make one ≤ 16-bit code, whose most frequent
# class (the lowest id among equals, as argmax) a table of 4^pixels entries gives.
_ID_BITS = (NUM_CLASSES - 1).bit_length()
_MAX_BLOCK = 16 // _ID_BITS


@lru_cache(maxsize=_MAX_BLOCK)
def _mode_table(pixels: int) -> np.ndarray:
    """(NUM_CLASSES ** pixels,) uint8: a footprint's packed ids → its first class of largest count."""
    codes = np.arange(NUM_CLASSES**pixels, dtype=np.uint32)
    ids = (codes[:, None] >> (_ID_BITS * np.arange(pixels, dtype=np.uint32))) & (NUM_CLASSES - 1)
    counts = (ids[:, :, None] == np.arange(NUM_CLASSES)).sum(axis=1)
    return counts.argmax(axis=1).astype(np.uint8)


def _block_modes(semantics: np.ndarray, work_size: tuple[int, int]) -> np.ndarray | None:
    """:func:`reduce_class_maps` by table, for integer factors of ≤ 8 pixels and uint8 ids < 4; else None.

    The area interpolation of one-hot maps averages each class over the output pixel's
    footprint, so for a footprint of whole input pixels its argmax is the most frequent
    class, the lowest id among equal counts: what the table gives, at a few byte operations
    per pixel instead of a float one-hot map per class (≈ 20× faster; the tests compare both).
    """
    if semantics.ndim != 3 or semantics.dtype != np.uint8:
        return None
    (height, width), (w, h) = semantics.shape[1:], work_size
    if height % h or width % w or (height // h) * (width // w) > _MAX_BLOCK \
            or (semantics.size and semantics.max() >= NUM_CLASSES):
        return None
    fy, fx = height // h, width // w
    dtype = np.uint8 if fy * fx * _ID_BITS <= 8 else np.uint16
    code = np.zeros((len(semantics), h, w), dtype)
    for p, (dy, dx) in enumerate(product(range(fy), range(fx))):
        code |= np.left_shift(semantics[:, dy::fy, dx::fx], _ID_BITS * p, dtype=dtype)
    return _mode_table(fy * fx)[code]


def reduce_images(images: np.ndarray, work_size: tuple[int, int]) -> Tensor:
    """(K, H, W, 3) uint8 RGB → (K, 3, h, w) uint8 (area average)."""
    out = []
    for start in range(0, len(images), _CHUNK):
        chunk = torch.from_numpy(np.asarray(images[start:start + _CHUNK])).permute(0, 3, 1, 2)
        if chunk.shape[-1:-3:-1] != tuple(work_size):
            chunk = F.interpolate(chunk.float(), size=work_size[::-1], mode="area").round().to(torch.uint8)
        out.append(chunk.contiguous())
    return torch.cat(out) if out else torch.empty(0, 3, *work_size[::-1], dtype=torch.uint8)
