"""Warp losses and matching scores on semantic maps (SPEC §7).

Convention
----------
* Maps are ``(B, C, H, W)`` one-hot or soft class maps (``C = 4``: background and
  three classes). ``pred`` is the warped estimate ``Ŷ``, ``target`` the truth ``Y``.
* **MSE** reduces ``(Ŷ − Y)²`` over the class channels as ``class_reduction`` says,
  then averages over pixels. ``"sum"`` (the default): the squared distance between
  the per-pixel class vectors, so for one-hot maps ``2 · (fraction of pixels whose
  class differs)`` — a wholly wrong patch scores 2. ``"mean"``: that divided by ``C``
  (``torch.nn.functional.mse_loss``'s reading), 0.5 for a wholly wrong patch of
  4 classes, which leaves the β = 0.3 hinge of the topological loss silent below
  60 % wrong pixels. docs/decisions.md gives the measurements behind the default.
* **Dice loss** is ``1 − mean_c Dice_c`` with the soft Dice coefficient
  ``Dice_c = (2 Σ Ŷ_c Y_c + ε) / (Σ Ŷ_c + Σ Y_c + ε)`` over the pixels of the map (or
  patch), averaged over the classes 1 … C−1: the background (sky, off-scene ground,
  buildings) is left out by default because it covers most of a view and would
  make a poor alignment of the classes that matter look good. ``ε = 1`` (one
  pixel) keeps the gradient finite and makes a class absent from both maps score
  1, so a patch with nothing but background in both maps has loss 0.
* **Topological losses** ``L_Top-MSE`` and ``L_Top-Dice``: both maps are split into a
  ``rows × cols`` grid of patches (default 4 × 4, N = 16); with ``ℓ_ij`` the patch
  loss, ``L_patch(i, j) = ℓ_ij + α Σ_{k,l ∈ {−1,0,1}} max(0, ℓ_{i+k, j+l} − β)`` over
  the neighbours inside the grid, the patch itself included, and
  ``L_Top = (1/N) Σ_ij L_patch(i, j)``; α = β = 0.3.
* **Patch split**: exactly ``torch.tensor_split(x, rows, dim=-2)`` then
  ``torch.tensor_split(·, cols, dim=-1)``: when ``H`` is not divisible by ``rows``
  the first ``H mod rows`` patch rows are one pixel taller (same for columns).
  Patch losses are means over each patch's own pixels.
* Every loss takes ``reduction="mean"`` (training: mean over the batch,
  differentiable) or ``"none"`` (the per-pair score, shape ``(B,)``).

Example
-------
>>> import torch
>>> y = torch.nn.functional.one_hot(torch.randint(0, 4, (2, 8, 8)), 4).permute(0, 3, 1, 2).float()
>>> float(top_mse_loss(y, y)), float(dice_loss(y, y))
(0.0, 0.0)
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import torch
import torch.nn.functional as F
from torch import Tensor

__all__ = [
    "one_hot_maps",
    "ALPHA",
    "BETA",
    "GRID",
    "DICE_EPS",
    "CLASS_REDUCTIONS",
    "CLASS_REDUCTION",
    "class_divisor",
    "patch_bounds",
    "patch_sums",
    "patch_pixel_counts",
    "patch_mse",
    "patch_dice_loss",
    "topological_combination",
    "mse_loss",
    "dice_loss",
    "top_mse_loss",
    "top_dice_loss",
    "WARP_LOSSES",
    "warp_loss",
]

ALPHA = 0.3
BETA = 0.3
GRID = (4, 4)
DICE_EPS = 1.0
# How MSE reduces over the class channels (module docstring); the default of every MSE-based loss and score.
CLASS_REDUCTIONS = ("sum", "mean")
CLASS_REDUCTION = "sum"

LossFn = Callable[..., Tensor]


def one_hot_maps(class_ids: Tensor, num_classes: int = 4, dtype: torch.dtype = torch.float32) -> Tensor:
    """One-hot maps of class-id maps.

    Args:
        class_ids: (..., H, W) integer class ids.
        num_classes: number of classes C.
        dtype: result dtype.

    Returns:
        (..., C, H, W).
    """
    return F.one_hot(class_ids.long(), num_classes).movedim(-1, -3).to(dtype)


def patch_bounds(length: int, parts: int) -> list[int]:
    """Boundaries of ``torch.tensor_split(range(length), parts)``.

    Args:
        length: number of pixels along the axis.
        parts: number of patches along the axis.

    Returns:
        ``parts + 1`` increasing offsets from 0 to ``length``; the first
        ``length mod parts`` patches are one pixel longer.
    """
    size, extra = divmod(length, parts)
    bounds = [0]
    for i in range(parts):
        bounds.append(bounds[-1] + size + (1 if i < extra else 0))
    return bounds


def _membership(length: int, parts: int, like: Tensor) -> Tensor:
    """(parts, length) 0/1 matrix: entry (p, i) is 1 where pixel i lies in patch p."""
    bounds = torch.tensor(patch_bounds(length, parts), device=like.device)
    index = torch.arange(length, device=like.device)
    member = (index >= bounds[:-1, None]) & (index < bounds[1:, None])
    return member.to(like.dtype)


def patch_sums(x: Tensor, grid: tuple[int, int] = GRID) -> Tensor:
    """Sum of ``x`` over each patch of a ``rows × cols`` grid.

    Two small matrix products with 0/1 membership matrices, so the sums are
    differentiable and cost one pass over ``x``.

    Args:
        x: (..., H, W) values.
        grid: ``(rows, cols)``.

    Returns:
        (..., rows, cols) patch sums.
    """
    rows = _membership(x.shape[-2], grid[0], x)
    cols = _membership(x.shape[-1], grid[1], x)
    return torch.einsum("ph,...hw,qw->...pq", rows, x, cols)


def patch_pixel_counts(size: tuple[int, int], grid: tuple[int, int] = GRID) -> Tensor:
    """Number of pixels of each patch.

    Args:
        size: ``(H, W)`` of the map.
        grid: ``(rows, cols)``.

    Returns:
        (rows, cols) float64 counts.
    """
    rows = torch.diff(torch.tensor(patch_bounds(size[0], grid[0]), dtype=torch.float64))
    cols = torch.diff(torch.tensor(patch_bounds(size[1], grid[1]), dtype=torch.float64))
    return rows[:, None] * cols[None, :]


def class_divisor(num_classes: int, class_reduction: str) -> int:
    """What the summed squared class differences are divided by: 1 (``"sum"``) or ``C`` (``"mean"``).

    >>> class_divisor(4, "sum"), class_divisor(4, "mean")
    (1, 4)
    """
    if class_reduction == "sum":
        return 1
    if class_reduction == "mean":
        return num_classes
    raise ValueError(f"class_reduction must be one of {', '.join(CLASS_REDUCTIONS)}; got {class_reduction!r}")


def patch_mse(pred: Tensor, target: Tensor, grid: tuple[int, int] = GRID,
              class_reduction: str = CLASS_REDUCTION) -> Tensor:
    """Mean squared error of each patch.

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        grid: ``(rows, cols)``.
        class_reduction: ``"sum"`` or ``"mean"`` over the C channels (module docstring).

    Returns:
        (B, rows, cols) per-patch MSE (reduced over channels, mean over the patch's pixels).
    """
    divisor = class_divisor(pred.shape[1], class_reduction)
    squared = (pred - target).square().sum(dim=1)
    counts = patch_pixel_counts((pred.shape[-2], pred.shape[-1]), grid).to(pred.device, pred.dtype)
    return patch_sums(squared, grid) / (counts * divisor)


def patch_dice_loss(
    pred: Tensor,
    target: Tensor,
    grid: tuple[int, int] = GRID,
    eps: float = DICE_EPS,
    include_background: bool = False,
) -> Tensor:
    """Soft Dice loss (``1 − mean_c Dice_c``) of each patch.

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        grid: ``(rows, cols)``; ``(1, 1)`` gives the whole-map Dice loss.
        eps: smoothing added to numerator and denominator, in pixels.
        include_background: average over all C classes instead of 1 … C−1.

    Returns:
        (B, rows, cols) per-patch Dice loss in [0, 1].
    """
    if not include_background:
        pred, target = pred[:, 1:], target[:, 1:]
    intersection = patch_sums(pred * target, grid)
    total = patch_sums(pred + target, grid)
    dice = (2 * intersection + eps) / (total + eps)
    return 1 - dice.mean(dim=1)


def topological_combination(patch_losses: Tensor, alpha: float = ALPHA, beta: float = BETA) -> Tensor:
    """``L_Top`` from per-patch losses (SPEC §7).

    Args:
        patch_losses: (..., rows, cols) per-patch losses ``ℓ_ij``.
        alpha: weight of the neighbours' hinge terms.
        beta: hinge threshold.

    Returns:
        (...) ``(1/N) Σ_ij [ℓ_ij + α Σ_{3×3 neighbourhood in the grid} max(0, ℓ − β)]``.
    """
    # Summed over all patches, each patch's hinge term is counted once for every
    # patch whose 3×3 neighbourhood (inside the grid) holds it: 4 in a corner, 6 on
    # an edge, 9 inside a 4 × 4 grid. Weighting by that count gives the same sum
    # without forming the neighbourhoods (which dominated the cost of matching).
    rows, cols = patch_losses.shape[-2:]
    weight = _neighbourhood_count(rows, patch_losses)[:, None] * _neighbourhood_count(cols, patch_losses)
    hinge = torch.relu(patch_losses - beta)
    return (patch_losses + alpha * weight * hinge).mean(dim=(-2, -1))


def _neighbourhood_count(n: int, like: Tensor) -> Tensor:
    """(n,) how many of the positions 0 … n−1 lie within 1 of each position."""
    index = torch.arange(n, device=like.device)
    return ((index[:, None] - index[None, :]).abs() <= 1).sum(0).to(like.dtype)


def _reduce(per_sample: Tensor, reduction: str) -> Tensor:
    if reduction == "mean":
        return per_sample.mean()
    if reduction == "none":
        return per_sample
    raise ValueError(f"reduction must be 'mean' or 'none', got {reduction!r}")


def mse_loss(pred: Tensor, target: Tensor, reduction: str = "mean", class_reduction: str = CLASS_REDUCTION) -> Tensor:
    """Mean squared error of whole maps.

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        reduction: ``"mean"`` → scalar; ``"none"`` → (B,).
        class_reduction: ``"sum"`` or ``"mean"`` over the C channels (module docstring).
    """
    divisor = class_divisor(pred.shape[1], class_reduction)
    return _reduce((pred - target).square().sum(dim=1).mean(dim=(1, 2)) / divisor, reduction)


def dice_loss(
    pred: Tensor, target: Tensor, reduction: str = "mean", eps: float = DICE_EPS, include_background: bool = False
) -> Tensor:
    """Soft Dice loss of whole maps (see the module's convention).

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        reduction: ``"mean"`` → scalar; ``"none"`` → (B,).
        eps: smoothing in pixels.
        include_background: include class 0 in the class average.
    """
    per_sample = patch_dice_loss(pred, target, (1, 1), eps, include_background)[:, 0, 0]
    return _reduce(per_sample, reduction)


def top_mse_loss(
    pred: Tensor,
    target: Tensor,
    reduction: str = "mean",
    grid: tuple[int, int] = GRID,
    alpha: float = ALPHA,
    beta: float = BETA,
    class_reduction: str = CLASS_REDUCTION,
) -> Tensor:
    """``L_Top-MSE``: the topological combination of per-patch MSE.

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        reduction: ``"mean"`` → scalar; ``"none"`` → (B,).
        grid: ``(rows, cols)`` of patches.
        alpha: neighbour weight.
        beta: hinge threshold.
        class_reduction: ``"sum"`` or ``"mean"`` over the C channels (module docstring).
    """
    patches = patch_mse(pred, target, grid, class_reduction)
    return _reduce(topological_combination(patches, alpha, beta), reduction)


def top_dice_loss(
    pred: Tensor,
    target: Tensor,
    reduction: str = "mean",
    grid: tuple[int, int] = GRID,
    alpha: float = ALPHA,
    beta: float = BETA,
    eps: float = DICE_EPS,
    include_background: bool = False,
) -> Tensor:
    """``L_Top-Dice``: the topological combination of per-patch Dice losses.

    Args:
        pred: (B, C, H, W) estimated maps.
        target: (B, C, H, W) true maps.
        reduction: ``"mean"`` → scalar; ``"none"`` → (B,).
        grid: ``(rows, cols)`` of patches.
        alpha: neighbour weight.
        beta: hinge threshold.
        eps: Dice smoothing in pixels.
        include_background: include class 0 in the class average.
    """
    patches = patch_dice_loss(pred, target, grid, eps, include_background)
    return _reduce(topological_combination(patches, alpha, beta), reduction)


_MSE_BASED = ("mse", "top_mse")
WARP_LOSSES: dict[str, LossFn] = {
    "mse": mse_loss,
    "dice": dice_loss,
    "top_mse": top_mse_loss,
    "top_dice": top_dice_loss,
}


def warp_loss(name: str, class_reduction: str = CLASS_REDUCTION) -> LossFn:
    """The warp loss called ``name``: ``"mse"``, ``"dice"``, ``"top_mse"`` or ``"top_dice"``.

    The MSE-based ones come with ``class_reduction`` bound (``"sum"`` or ``"mean"``);
    the Dice-based ones have no such choice. (The benchmark's option spellings,
    ``"top-mse"`` …, are mapped to these names explicitly by
    :data:`synthcal.training.WARP_LOSS_NAMES`.)
    """
    if name not in WARP_LOSSES:
        raise ValueError(f"unknown warp loss {name!r}; choose from {sorted(WARP_LOSSES)}")
    class_divisor(1, class_reduction)  # checks the value
    if name in _MSE_BASED:
        return functools.partial(WARP_LOSSES[name], class_reduction=class_reduction)
    return WARP_LOSSES[name]
