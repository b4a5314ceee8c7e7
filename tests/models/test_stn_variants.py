"""The CCBV localisation network against its description, and the batch-norm switch of every STN."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from synthcal.models import BaselineSTN, CcbvBlock, CcbvSTN, ProposedSTN
from synthcal.models.stn import IDENTITY_H8


def _conv3(cin: int, cout: int, bn: bool) -> int:
    """Parameters of a 3×3 convolution with bias, then BN (weight and bias) if ``bn``."""
    return cin * cout * 9 + cout + (2 * cout if bn else 0)


def _fc(cin: int, cout: int) -> int:
    return cin * cout + cout


def test_ccbv_at_256_by_144_is_the_public_network():
    """evs-broadcast/CCBV at 256 × 144: channels 16/32/64, pools 4/2/2 → 64 × 9 × 16 = 9,216 features,
    FC 9216 → 4096 → 1024 → 8; each block has two conv–BN–LeakyReLU layers, the second applied twice."""
    torch.manual_seed(0)
    stn = CcbvSTN(image_size=(256, 144))
    x = torch.rand(2, 8, 144, 256)
    assert stn.features(x).shape == (2, 64, 144 // 4 // 2 // 2, 256 // 4 // 2 // 2) == (2, 64, 9, 16)
    linears = [m for m in stn.head if isinstance(m, nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(9216, 4096), (4096, 1024), (1024, 8)]
    expected = sum(_conv3(cin, cout, True) + _conv3(cout, cout, True) for cin, cout in [(8, 16), (16, 32), (32, 64)])
    expected += _fc(9216, 4096) + _fc(4096, 1024) + _fc(1024, 8)
    assert sum(p.numel() for p in stn.parameters()) == expected == 42_029_608
    assert [type(b) for b in stn.features] == [CcbvBlock] * 3
    assert [b.pool.kernel_size for b in stn.features] == [4, 2, 2]
    assert sum(isinstance(m, nn.LeakyReLU) for m in stn.modules()) == 6
    # A fresh network returns the identity H̄ (last layer zero, bias identity).
    assert torch.equal(stn(x), torch.tensor([IDENTITY_H8, IDENTITY_H8]))


@pytest.mark.parametrize(("size", "features"), [((128, 72), 64 * 4 * 8), ((64, 36), 64 * 2 * 4), ((16, 16), 64)])
def test_ccbv_fc_widths_scale_with_the_work_size(size, features):
    """Flattened count from the floor pools; hidden widths 4096 and 1024 times features / 9216, at least 8."""
    stn = CcbvSTN(image_size=size)
    linears = [m for m in stn.head if isinstance(m, nn.Linear)]
    scale = features / 9216
    assert [(m.in_features, m.out_features) for m in linears] == [
        (features, max(8, round(4096 * scale))), (max(8, round(4096 * scale)), max(8, round(1024 * scale))),
        (max(8, round(1024 * scale)), 8)]
    assert stn(torch.rand(1, 8, size[1], size[0])).shape == (1, 8)
    with pytest.raises(ValueError, match="at least 16 × 16"):
        CcbvSTN(image_size=(64, 12))


def _norms(module: nn.Module) -> int:
    return sum(isinstance(m, nn.BatchNorm2d) for m in module.modules())


def _conv_shapes(module: nn.Module) -> list[tuple[int, int, tuple[int, ...]]]:
    return [(m.in_channels, m.out_channels, m.kernel_size) for m in module.modules() if isinstance(m, nn.Conv2d)]


def _conv_biases(module: nn.Module) -> list[bool]:
    return [m.bias is not None for m in module.modules() if isinstance(m, nn.Conv2d)]


@pytest.mark.parametrize(("cls", "default", "count", "options"), [
    (BaselineSTN, False, 2, {"width": 4}),     # one BN per location layer
    (ProposedSTN, True, 9, {"width": 4}),      # three per LocBlock: main (2) and shortcut (1)
    (CcbvSTN, True, 6, {}),                    # two per block (the shared second layer's counts once)
])
def test_batch_norm_switch(cls, default, count, options):
    default_net = cls(image_size=(64, 36), **options)
    on, off = (cls(image_size=(64, 36), batch_norm=flag, **options) for flag in (True, False))
    assert _norms(default_net) == (count if default else 0)
    assert (_norms(on), _norms(off)) == (count, 0)
    # The same convolutions either way; BN replaces a convolution's bias except in CCBV (the public code keeps it).
    assert _conv_shapes(on) == _conv_shapes(off)
    assert all(_conv_biases(off))
    if cls is not CcbvSTN:
        assert not any(_conv_biases(on))
    for net in (on, off):  # both variants train
        net.train()
        net(torch.rand(3, 8, 36, 64)).square().sum().backward()
        assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in net.parameters() if p.requires_grad)
