"""Losses of synthcal.models.losses: hand-computed values and slow loop references."""

from __future__ import annotations

import zlib
from itertools import pairwise

import pytest
import torch

from synthcal.models.losses import (
    dice_loss,
    mse_loss,
    one_hot_maps,
    patch_bounds,
    top_dice_loss,
    top_mse_loss,
    warp_loss,
)

ALL_LOSSES = [mse_loss, dice_loss, top_mse_loss, top_dice_loss]


def _one_hot(ids: torch.Tensor) -> torch.Tensor:
    return one_hot_maps(ids, 4, torch.float64)


# --- slow, obvious references -------------------------------------------------------

def _slow_mse(p: torch.Tensor, t: torch.Tensor, class_reduction: str = "sum") -> float:
    """p, t: (C, h, w); summed over everything, divided by the pixels (and by C for "mean")."""
    pixels = p.shape[-1] * p.shape[-2]
    return float(((p - t) ** 2).sum() / (pixels * (p.shape[0] if class_reduction == "mean" else 1)))


def _slow_dice(p: torch.Tensor, t: torch.Tensor, eps: float = 1.0) -> float:
    """p, t: (C, h, w); classes 1..C-1, one class at a time."""
    scores = []
    for c in range(1, p.shape[0]):
        inter = float((p[c] * t[c]).sum())
        total = float(p[c].sum() + t[c].sum())
        scores.append((2 * inter + eps) / (total + eps))
    return 1 - sum(scores) / len(scores)


def _slow_top(p: torch.Tensor, t: torch.Tensor, ell, rows: int = 4, cols: int = 4,
              alpha: float = 0.3, beta: float = 0.3) -> float:
    """p, t: (C, H, W); patches by torch.tensor_split, neighbours by explicit loops."""
    patch = [[0.0] * cols for _ in range(rows)]
    for i, (pr, tr) in enumerate(zip(torch.tensor_split(p, rows, 1), torch.tensor_split(t, rows, 1), strict=True)):
        for j, (pp, tp) in enumerate(zip(torch.tensor_split(pr, cols, 2), torch.tensor_split(tr, cols, 2), strict=True)):
            patch[i][j] = ell(pp, tp)
    total = 0.0
    for i in range(rows):
        for j in range(cols):
            value = patch[i][j]
            for k in (-1, 0, 1):
                for m in (-1, 0, 1):
                    if 0 <= i + k < rows and 0 <= j + m < cols:
                        value += alpha * max(0.0, patch[i + k][j + m] - beta)
            total += value
    return total / (rows * cols)


SLOW = {
    mse_loss: _slow_mse,
    dice_loss: _slow_dice,
    top_mse_loss: lambda p, t, **kw: _slow_top(p, t, lambda a, b: _slow_mse(a, b, **kw)),
    top_dice_loss: lambda p, t: _slow_top(p, t, _slow_dice),
}
MSE_BASED = (mse_loss, top_mse_loss)


# --- hand-computed examples ----------------------------------------------------------

@pytest.fixture
def one_wrong_patch() -> tuple[torch.Tensor, torch.Tensor]:
    """8 × 8 maps, 4 × 4 grid of 2 × 2 patches; target all class 1, the top-left
    patch of the prediction class 2."""
    target = torch.ones(1, 8, 8, dtype=torch.long)
    pred = target.clone()
    pred[:, :2, :2] = 2
    return _one_hot(pred), _one_hot(target)


def test_mse_by_hand(one_wrong_patch):
    pred, target = one_wrong_patch
    # 4 pixels wrong, each contributes 2 squared units: over 64 pixels (sum over the
    # classes, the default), or over 4 channels × 64 pixels (mean).
    assert float(mse_loss(pred, target)) == pytest.approx(8 / 64)
    assert float(mse_loss(pred, target, class_reduction="mean")) == pytest.approx(8 / 256)


@pytest.mark.parametrize("reduction, mse, top", [("sum", 0.5, (2 + 4 * 0.3 * 1.7) / 4),
                                                 ("mean", 0.125, (0.5 + 4 * 0.3 * 0.2) / 4)])
def test_class_reduction_on_one_wrong_pixel(reduction, mse, top):
    """A 2 × 2 map of C = 4 classes with one wrong pixel.

    The wrong pixel's class vectors differ in two entries: squared distance 2. sum:
    2 / 4 pixels = 0.5; mean: also / 4 classes = 0.125. Top-MSE on a 2 × 2 grid (one
    pixel per patch): the wrong patch scores 2 (sum) or 0.5 (mean), its hinge
    2 − 0.3 = 1.7 or 0.5 − 0.3 = 0.2 is in every patch's neighbourhood (4 patches).
    """
    from synthcal.models.matching import pairwise_scores

    target_ids = torch.tensor([[[0, 1], [2, 3]]])
    pred_ids = torch.tensor([[[0, 1], [2, 1]]])
    pred, target = _one_hot(pred_ids), _one_hot(target_ids)
    assert float(mse_loss(pred, target, class_reduction=reduction)) == pytest.approx(mse)
    got = top_mse_loss(pred, target, grid=(2, 2), class_reduction=reduction)
    assert float(got) == pytest.approx(top)
    # The matching scores use the same reduction, from class ids and from float maps.
    for p, t in ((pred_ids, target_ids), (pred, target)):
        assert float(pairwise_scores(p, t, "mse", class_reduction=reduction)[0, 0]) == pytest.approx(mse)
        assert float(pairwise_scores(p, t, "top_mse", grid=(2, 2), class_reduction=reduction)[0, 0]) \
            == pytest.approx(top)
    with pytest.raises(ValueError, match="class_reduction"):
        mse_loss(pred, target, class_reduction="max")


def test_dice_by_hand(one_wrong_patch):
    pred, target = one_wrong_patch
    # class 1: (2·60 + 1) / (60 + 64 + 1); class 2: (0 + 1) / (4 + 1); class 3 absent: 1.
    expected = 1 - (121 / 125 + 1 / 5 + 1) / 3
    assert float(dice_loss(pred, target)) == pytest.approx(expected)


def test_top_mse_by_hand(one_wrong_patch):
    pred, target = one_wrong_patch
    # mean: wrong patch MSE 8 / 16 = 0.5, hinge 0.2; it and its 3 in-grid neighbours
    # each get 0.3 · 0.2: (0.5 + 4 · 0.06) / 16. sum: 8 / 4 = 2, hinge 1.7.
    assert float(top_mse_loss(pred, target, class_reduction="mean")) == pytest.approx((0.5 + 4 * 0.06) / 16)
    assert float(top_mse_loss(pred, target)) == pytest.approx((2 + 4 * 0.3 * 1.7) / 16)


def test_top_dice_by_hand(one_wrong_patch):
    pred, target = one_wrong_patch
    # wrong patch: class 1 (0 + 1)/(4 + 1), class 2 (0 + 1)/(4 + 1), class 3: 1.
    ell = 1 - (0.2 + 0.2 + 1) / 3
    hinge = ell - 0.3
    assert float(top_dice_loss(pred, target)) == pytest.approx((ell + 4 * 0.3 * hinge) / 16)


def test_dice_with_background_by_hand():
    target = torch.tensor([[[1, 1], [2, 0]]])
    pred = torch.tensor([[[1, 2], [2, 0]]])
    # classes 0..3: (2+1)/(2+1), (2+1)/(3+1), (2+1)/(3+1), 1
    expected = 1 - (1 + 0.75 + 0.75 + 1) / 4
    got = dice_loss(_one_hot(pred), _one_hot(target), include_background=True)
    assert float(got) == pytest.approx(expected)


# --- against the slow references on random maps --------------------------------------

# MSE-based losses under both class reductions; Dice has none to choose (None).
LOSS_READINGS = [(loss, reduction) for loss in ALL_LOSSES
                 for reduction in (("sum", "mean") if loss in MSE_BASED else (None,))]


@pytest.mark.parametrize(("loss", "class_reduction"), LOSS_READINGS,
                         ids=lambda v: getattr(v, "__name__", str(v)))
@pytest.mark.parametrize("size", [(16, 16), (18, 30), (13, 7)])
@pytest.mark.parametrize("soft", [False, True])
def test_matches_slow_reference(loss, class_reduction, size, soft):
    kw = {"class_reduction": class_reduction} if class_reduction else {}
    g = torch.Generator().manual_seed(zlib.crc32(repr((loss.__name__, size, soft)).encode()))
    if soft:
        pred = torch.rand(3, 4, *size, generator=g, dtype=torch.float64).softmax(1)
        target = torch.rand(3, 4, *size, generator=g, dtype=torch.float64).softmax(1)
    else:
        # Mostly-agreeing maps so that some patch losses exceed β and some do not.
        target_ids = torch.randint(0, 4, (3, *size), generator=g)
        pred_ids = torch.where(torch.rand(3, *size, generator=g) < 0.6, target_ids,
                               torch.randint(0, 4, (3, *size), generator=g))
        pred, target = _one_hot(pred_ids), _one_hot(target_ids)
    per_pair = loss(pred, target, reduction="none", **kw)
    expected = torch.tensor([SLOW[loss](pred[b], target[b], **kw) for b in range(3)], dtype=torch.float64)
    assert per_pair.shape == (3,)
    torch.testing.assert_close(per_pair, expected, rtol=1e-10, atol=1e-12)
    torch.testing.assert_close(loss(pred, target, **kw), per_pair.mean())


@pytest.mark.parametrize("loss", ALL_LOSSES, ids=lambda f: f.__name__)
def test_perfect_prediction_scores_zero(loss):
    ids = torch.randint(0, 4, (2, 18, 30), generator=torch.Generator().manual_seed(1))
    assert float(loss(_one_hot(ids), _one_hot(ids))) == 0.0


def test_patch_bounds_follow_tensor_split():
    for length in (7, 16, 18, 30, 144, 256):
        sizes = [len(part) for part in torch.tensor_split(torch.arange(length), 4)]
        bounds = patch_bounds(length, 4)
        assert [b - a for a, b in pairwise(bounds)] == sizes


def test_warp_loss_names():
    assert warp_loss("dice") is dice_loss
    ids = torch.randint(0, 4, (2, 2, 12, 16), generator=torch.Generator().manual_seed(3))
    pred, target = _one_hot(ids[0]), _one_hot(ids[1])
    for name, fn in (("mse", mse_loss), ("top_mse", top_mse_loss)):
        for reduction in ("sum", "mean"):  # MSE-based losses come with their class reduction bound
            assert torch.equal(warp_loss(name, reduction)(pred, target), fn(pred, target, class_reduction=reduction))
        assert torch.equal(warp_loss(name)(pred, target), fn(pred, target, class_reduction="sum"))
    with pytest.raises(ValueError, match="class_reduction"):
        warp_loss("top_mse", "max")
    for unknown in ("l1", "top-mse", "Dice"):  # one spelling per loss: no silent conversions
        with pytest.raises(ValueError):
            warp_loss(unknown)
