"""Ground-truth template matching by batched matrix products (SPEC §7).

The correct match of a training map is the dictionary template of lowest matching
score, MSE or ``L_Top-MSE`` (:mod:`synthcal.models.losses`), with the same
``class_reduction`` keyword (``"sum"``: squared distance between per-pixel class
vectors; ``"mean"``: that divided by C). For MSE the two readings pick the same
templates (a constant factor); for ``L_Top-MSE`` they may not (the β hinge). All pairs are scored
with the expansion ``‖a − b‖² = ‖a‖² + ‖b‖² − 2 a·b``: one GEMM for MSE, one GEMM
per patch for the topological score, then the same per-patch combination as the
loss. Queries are processed in chunks, and templates too when asked
(``template_chunk``, or :func:`merge_matches` over batches streamed from a store),
so memory stays bounded for a dictionary of any size.

Class-id maps
-------------
Maps given as integer class ids ``(N, H, W)`` are not expanded to one-hot. Each
class is coded as a vertex of a regular simplex, the rows of a Sylvester-Hadamard
matrix without its all-ones column: ``C − 1`` entries ±1 per pixel instead of ``C``
(a quarter fewer FLOPs for 4 classes), with every pair of distinct classes
``2C`` apart in squared distance, i.e. ``C`` times the one-hot distance. The
entries and all partial sums are small integers, so the products are exact even
when the float32 GEMM runs in reduced precision (bfloat16 / TF32 inputs, float32
accumulation), which is enabled for them. The (per-patch) squared errors are
therefore exactly those of the one-hot maps, and identical errors give identical
scores, whose tie goes to the lowest template index. Class counts that are not a
power of two use the one-hot code in full precision.

Example
-------
>>> import torch
>>> q = torch.randint(0, 4, (5, 16, 32)); t = torch.cat([q[:2], torch.randint(0, 4, (7, 16, 32))])
>>> match_ground_truth(q[:2], t, "top_mse").index.tolist()
[0, 1]
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import pairwise

import torch
from torch import Tensor

from .losses import (
    ALPHA,
    BETA,
    CLASS_REDUCTION,
    GRID,
    class_divisor,
    patch_bounds,
    patch_pixel_counts,
    topological_combination,
)

__all__ = ["MatchResult", "class_code", "pairwise_scores", "match_ground_truth", "merge_matches", "Encoded",
           "encoded_scores"]

SCORES = ("mse", "top_mse")


@dataclass(frozen=True)
class MatchResult:
    """Best template of each query.

    Attributes:
        index: (Q,) int64 index of the template of lowest score (first on ties).
        score: (Q,) that score.
    """

    index: Tensor
    score: Tensor


def class_code(num_classes: int) -> tuple[Tensor, float]:
    """Code vectors of the classes and the factor back to one-hot squared distances.

    Args:
        num_classes: number of classes ``C``.

    Returns:
        ``(code, factor)``: (C, D) float32 code (D = C − 1 for a power of two,
        else the C × C identity) and the factor such that
        ``‖code[a] − code[b]‖² · factor = ‖onehot(a) − onehot(b)‖²``.
    """
    if num_classes < 2 or num_classes & (num_classes - 1):
        return torch.eye(num_classes), 1.0
    hadamard = torch.ones(1, 1)
    while hadamard.shape[0] < num_classes:
        hadamard = torch.cat([torch.cat([hadamard, hadamard], 1), torch.cat([hadamard, -hadamard], 1)], 0)
    return hadamard[:, 1:].contiguous(), 1.0 / num_classes


@contextmanager
def _exact_fast_matmul(enabled: bool) -> Iterator[None]:
    """Let float32 GEMMs use bfloat16/TF32 inputs (exact for small-integer data)."""
    if not enabled:
        yield
        return
    previous = torch.get_float32_matmul_precision()
    torch.set_float32_matmul_precision("medium")
    try:
        yield
    finally:
        torch.set_float32_matmul_precision(previous)


def _patch_order(size: tuple[int, int], grid: tuple[int, int], device: torch.device) -> tuple[Tensor | None, list[int]]:
    """Pixel indices (H·W,) in patch-major order (None: a single patch, no reordering)
    and the P + 1 pixel offsets of the patches."""
    if grid == (1, 1):
        return None, [0, size[0] * size[1]]
    index = torch.arange(size[0] * size[1], device=device).reshape(size)
    rows, cols = patch_bounds(size[0], grid[0]), patch_bounds(size[1], grid[1])
    pieces = [index[r0:r1, c0:c1].flatten() for r0, r1 in pairwise(rows) for c0, c1 in pairwise(cols)]
    offsets = [0]
    for piece in pieces:
        offsets.append(offsets[-1] + len(piece))
    return torch.cat(pieces), offsets


def _reorder(pixels: Tensor, order: Tensor | None) -> Tensor:
    """(..., H·W) values in patch-major order."""
    return pixels if order is None else pixels.index_select(-1, order)


class Encoded:
    """Maps as rows of a matrix: pixels in patch-major order, channels innermost.

    ``vectors`` (N, H·W·D); ``norms`` (N, P) per-patch squared norms;
    ``offsets`` the P + 1 column offsets of the patches; ``factor`` converts code
    distances to one-hot distances; ``exact`` whether reduced-precision GEMM is
    exact for these vectors. ``out`` is an optional (≥ N, H·W·D) buffer to fill,
    which spares page-faulting a fresh large allocation per chunk.
    """

    def __init__(self, maps: Tensor, grid: tuple[int, int], num_classes: int, out: Tensor | None = None):
        n = maps.shape[0]
        order, pixel_offsets = _patch_order((maps.shape[-2], maps.shape[-1]), grid, maps.device)
        pixels_per_map = pixel_offsets[-1]
        if maps.dtype.is_floating_point:
            if maps.ndim != 4:
                raise ValueError(f"float maps must be (N, C, H, W), got {tuple(maps.shape)}")
            pixels = _reorder(maps.flatten(2), order).transpose(1, 2)  # (N, HW, C)
            self.vectors = pixels.reshape(n, -1)
            pixel_norms = pixels.square().sum(2)
            self.factor, self.exact, self.channels = 1.0, False, maps.shape[1]
        else:
            if maps.ndim != 3:
                raise ValueError(f"class-id maps must be (N, H, W), got {tuple(maps.shape)}")
            code, self.factor = class_code(num_classes)
            # Scores stay exact in float32 while ‖q‖² + ‖t‖² < 2^24.
            if 2 * code.square().sum(1).max() * maps.shape[-1] * maps.shape[-2] >= 2**24:
                code = code.double()
            code = code.to(maps.device)
            ids = _reorder(maps.flatten(1), order).reshape(-1).int()
            if out is not None:
                out = out[:n].view(-1, code.shape[1])
            self.vectors = torch.index_select(code, 0, ids, out=out).view(n, -1)
            # Every code vector has the same norm: a patch's norm is that times its pixel count.
            pixel_norms = code[0].square().sum().expand(n, pixels_per_map)
            self.exact, self.channels = code.dtype == torch.float32, num_classes
        depth = self.vectors.shape[1] // pixels_per_map
        self.offsets = [depth * o for o in pixel_offsets]
        self.norms = torch.stack(
            [pixel_norms[:, a:b].sum(1) for a, b in pairwise(pixel_offsets)], 1
        )


def encoded_scores(q: Encoded, t: Encoded, score: str, grid: tuple[int, int], size: tuple[int, int],
            alpha: float, beta: float, class_reduction: str) -> Tensor:
    """(Q, T) scores of encoded queries against encoded templates (as :func:`pairwise_scores`).

    Args:
        q, t: the queries and templates, encoded with the same ``grid`` and class count.
        score: one of :data:`SCORES` (``mse``, ``top-mse``).
        grid: (rows, columns) of the Top-MSE patches.
        size: (H, W) of the maps.
        alpha, beta: weights of the topological combination of the patch scores.
        class_reduction: ``sum`` or ``mean`` over the class channels.
    """
    divisor = class_divisor(q.channels, class_reduction)
    if score == "mse":
        blocks, q_norms, t_norms = [(0, q.offsets[-1])], q.norms.sum(1, keepdim=True), t.norms.sum(1, keepdim=True)
    else:
        blocks, q_norms, t_norms = list(pairwise(q.offsets)), q.norms, t.norms
    # ‖q − t‖² = ‖t‖² − 2 q·t + ‖q‖²: one fused GEMM (addmm) per block of columns.
    squared = q.vectors.new_empty(len(blocks), q.vectors.shape[0], t.vectors.shape[0])
    with _exact_fast_matmul(q.exact and t.exact):
        for k, (a, b) in enumerate(blocks):
            torch.addmm(t_norms[:, k], q.vectors[:, a:b], t.vectors[:, a:b].T, alpha=-2, out=squared[k])
    squared += q_norms.T[:, :, None]
    squared.clamp_min_(0)  # rounding of soft maps' float products
    # Same divisions as the losses, so class-id scores equal theirs bit for bit.
    if score == "mse":
        return squared[0] * q.factor / (divisor * size[0] * size[1])
    counts = patch_pixel_counts(size, grid).flatten().to(squared.device, squared.dtype)
    per_patch = squared * q.factor / (counts * divisor)[:, None, None]  # (P, Q, T)
    return topological_combination(per_patch.permute(1, 2, 0).unflatten(-1, grid), alpha, beta)


def _check(queries: Tensor, templates: Tensor, score: str, class_reduction: str) -> None:
    class_divisor(1, class_reduction)  # raises on an unknown value
    if score not in SCORES:
        raise ValueError(f"score must be one of {SCORES}, got {score!r}")
    if queries.shape[1:] != templates.shape[1:] or queries.dtype.is_floating_point != templates.dtype.is_floating_point:
        raise ValueError(f"queries {tuple(queries.shape)} and templates {tuple(templates.shape)} differ in kind")


def pairwise_scores(
    queries: Tensor,
    templates: Tensor,
    score: str = "mse",
    grid: tuple[int, int] = GRID,
    alpha: float = ALPHA,
    beta: float = BETA,
    num_classes: int = 4,
    class_reduction: str = CLASS_REDUCTION,
) -> Tensor:
    """Matching score of every query against every template (no chunking).

    Args:
        queries: (Q, H, W) integer class ids or (Q, C, H, W) float maps.
        templates: (T, H, W) or (T, C, H, W), of the same kind.
        score: ``"mse"`` or ``"top_mse"``.
        grid: patch grid of the topological score.
        alpha: neighbour weight of the topological score.
        beta: hinge threshold of the topological score.
        num_classes: number of classes of class-id maps.
        class_reduction: ``"sum"`` or ``"mean"`` over the class channels.

    Returns:
        (Q, T) scores, equal to ``mse_loss`` / ``top_mse_loss`` with
        ``reduction="none"`` and the same ``class_reduction`` on each one-hot pair.
    """
    _check(queries, templates, score, class_reduction)
    size = (queries.shape[-2], queries.shape[-1])
    patches = grid if score == "top_mse" else (1, 1)
    q = Encoded(queries, patches, num_classes)
    t = Encoded(templates, patches, num_classes)
    return encoded_scores(q, t, score, grid, size, alpha, beta, class_reduction)


def match_ground_truth(
    queries: Tensor,
    templates: Tensor,
    score: str = "mse",
    *,
    query_chunk: int = 256,
    template_chunk: int | None = None,
    grid: tuple[int, int] = GRID,
    alpha: float = ALPHA,
    beta: float = BETA,
    num_classes: int = 4,
    class_reduction: str = CLASS_REDUCTION,
) -> MatchResult:
    """The template of lowest matching score for each query.

    Memory: the encoded templates, ``T · D · H · W`` floats (``D = 3`` for class
    ids of 4 classes), plus a chunk of queries and a ``(query_chunk, T, N)``
    block of patch scores; with ``template_chunk``, ``T`` is at most that (the
    result is the same: :func:`merge_matches`).

    Args:
        queries: (Q, H, W) integer class ids or (Q, C, H, W) float maps.
        templates: (T, H, W) or (T, C, H, W), of the same kind.
        score: ``"mse"`` or ``"top_mse"``.
        query_chunk: queries scored per block.
        template_chunk: templates encoded and scored per block (None: all at once).
        grid: patch grid of the topological score.
        alpha: neighbour weight of the topological score.
        beta: hinge threshold of the topological score.
        num_classes: number of classes of class-id maps.
        class_reduction: ``"sum"`` or ``"mean"`` over the class channels.

    Returns:
        :class:`MatchResult` with (Q,) indices into ``templates`` and scores.
    """
    _check(queries, templates, score, class_reduction)
    if template_chunk is not None and templates.shape[0] > template_chunk:
        merged: MatchResult | None = None
        for start in range(0, templates.shape[0], template_chunk):
            part = match_ground_truth(queries, templates[start:start + template_chunk], score, query_chunk=query_chunk,
                                      grid=grid, alpha=alpha, beta=beta, num_classes=num_classes,
                                      class_reduction=class_reduction)
            merged = merge_matches(merged, part, start)
        assert merged is not None  # at least one block: templates.shape[0] > template_chunk
        return merged
    size = (queries.shape[-2], queries.shape[-1])
    patches = grid if score == "top_mse" else (1, 1)
    t = Encoded(templates, patches, num_classes)
    buffer = None if queries.dtype.is_floating_point else t.vectors.new_empty(
        min(query_chunk, queries.shape[0]), t.vectors.shape[1])
    index, best = [], []
    for start in range(0, queries.shape[0], query_chunk):
        q = Encoded(queries[start:start + query_chunk], patches, num_classes, out=buffer)
        value, position = encoded_scores(q, t, score, grid, size, alpha, beta, class_reduction).min(dim=1)
        index.append(position)
        best.append(value)
    if not index:
        return MatchResult(torch.empty(0, dtype=torch.long), torch.empty(0))
    return MatchResult(torch.cat(index), torch.cat(best))


def merge_matches(best: MatchResult | None, part: MatchResult, offset: int) -> MatchResult:
    """The better of two matches per query: ``best`` over earlier templates, ``part`` over the
    templates from ``offset`` on (its indices relative to ``offset``).

    Ties keep ``best`` (the lower template index), so merging consecutive template
    blocks in order gives :func:`match_ground_truth`'s answer over them all.

    Args:
        best: (Q,) the match so far, or None for the first block.
        part: (Q,) the match within one block.
        offset: the block's first template index.

    Returns:
        (Q,) :class:`MatchResult` with indices over all templates seen.
    """
    index = part.index + offset
    if best is None:
        return MatchResult(index, part.score)
    better = part.score < best.score
    return MatchResult(torch.where(better, index, best.index), torch.where(better, part.score, best.score))
