"""Spatial transformer networks that refine a matched template's homography.

Convention
----------
An STN reads the input's semantic map ⊕ the matched template's map, (B, 8, H, W),
and regresses 8 values ``h`` of a relative homography
``H̄ = [[h0, h1, h2], [h3, h4, h5], [h6, h7, 1]]``. ``H̄`` maps the *template's*
image to the *input* image in normalised image coordinates
(``x_n = 2x/(W−1) − 1``, ``y_n = 2y/(H−1) − 1``: pixel centres, as
``align_corners=True``). With ``N`` the pixel → normalised matrix and ``H_k`` the
template's bird's-eye → image homography, the estimate is
``H = N⁻¹ H̄ N H_k`` (:func:`compose_homography`). The last layer of each STN
starts with zero weights and the identity as bias, so a fresh STN returns
``H̄ = I`` and ``H = H_k``.

Architectures (input (B, 8, H, W), any H, W ≥ 16)
--------------------------------------------------
* :class:`BaselineSTN` (Sha et al.'s plain localisation network, in the style of
  Jaderberg et al.'s STN): conv 7×7 stride 2 → max-pool 2 → ReLU; conv 5×5 →
  max-pool 2 → ReLU; conv 3×3 → max-pool 2 → ReLU; adaptive average pool to 4 × 4;
  FC → ReLU → FC(8). No normalisation, no residuals.
* :class:`ProposedSTN` (the paper's): stem conv 5×5 stride 2 + BN + ReLU; three
  :class:`LocBlock` (each halves the resolution: /16 overall, 16 × 9 cells at
  256 × 144); :class:`SelfAttention2d` over the cells; adaptive average pool to
  4 × 4; three FC layers (→ 256 → 64 → 8, ReLU between).

Example
-------
>>> import torch
>>> stn = ProposedSTN()
>>> h = stn(torch.rand(2, 8, 36, 64))
>>> bool((h == torch.tensor(IDENTITY_H8)).all())
True
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from .layers import conv_bn_relu

__all__ = [
    "IDENTITY_H8",
    "h_bar_matrix",
    "normalization_matrix",
    "compose_homography",
    "LocBlock",
    "SelfAttention2d",
    "BaselineSTN",
    "ProposedSTN",
]

IDENTITY_H8 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
_POOL = (4, 4)


def h_bar_matrix(h_bar8: Tensor) -> Tensor:
    """The 3 × 3 relative homographies of 8-value STN outputs.

    Args:
        h_bar8: (B, 8).

    Returns:
        (B, 3, 3) with ``[2, 2] = 1``.
    """
    one = torch.ones_like(h_bar8[:, :1])
    return torch.cat([h_bar8, one], dim=1).reshape(-1, 3, 3)


def normalization_matrix(
    image_size: tuple[int, int], dtype: torch.dtype = torch.float64, device: torch.device | None = None
) -> Tensor:
    """``N``: image pixels → normalised coordinates, ``x_n = 2x/(W−1) − 1``.

    Args:
        image_size: ``(width, height)``.
        dtype: result dtype.
        device: result device.

    Returns:
        (3, 3).
    """
    width, height = image_size
    return torch.tensor(
        [[2.0 / (width - 1), 0.0, -1.0], [0.0, 2.0 / (height - 1), -1.0], [0.0, 0.0, 1.0]],
        dtype=dtype, device=device,
    )


def _denormalization_matrix(image_size: tuple[int, int], like: Tensor) -> Tensor:
    """``N⁻¹`` written out (no numerical inversion)."""
    hw, hh = (image_size[0] - 1) / 2.0, (image_size[1] - 1) / 2.0
    return torch.tensor([[hw, 0.0, hw], [0.0, hh, hh], [0.0, 0.0, 1.0]], dtype=like.dtype, device=like.device)


def compose_homography(h_bar8: Tensor, template_H: Tensor, image_size: tuple[int, int]) -> Tensor:
    """Estimated homographies ``H = N⁻¹ H̄ N · H_k``.

    Evaluated as ``H_k + N⁻¹ (H̄ − I) N H_k`` (the same matrix): an identity ``H̄``
    then returns ``H_k`` bit for bit, and small corrections lose no precision.
    Differentiable with respect to ``h_bar8``.

    Args:
        h_bar8: (B, 8) STN outputs.
        template_H: (B, 3, 3) bird's-eye → image homographies of the matched
            templates; the result has their dtype (float64 recommended).
        image_size: ``(width, height)`` of the images.

    Returns:
        (B, 3, 3) bird's-eye → image homographies, with ``H_k``'s depth sign.
    """
    delta = h_bar_matrix(h_bar8.to(template_H.dtype)) - torch.eye(3, dtype=template_H.dtype, device=template_H.device)
    N = normalization_matrix(image_size, template_H.dtype, template_H.device)
    return template_H + _denormalization_matrix(image_size, template_H) @ delta @ N @ template_H


def _pooled_regression_head(in_features: int, hidden: tuple[int, ...]) -> nn.Sequential:
    """Pool to 4 × 4, flatten, FC layers with ReLU between, 8 outputs initialised to the identity."""
    layers: list[nn.Module] = []
    for width in hidden:
        layers += [nn.Linear(in_features, width), nn.ReLU(inplace=True)]
        in_features = width
    last = nn.Linear(in_features, 8)
    nn.init.zeros_(last.weight)
    with torch.no_grad():
        last.bias.copy_(torch.tensor(IDENTITY_H8))
    return nn.Sequential(nn.AdaptiveAvgPool2d(_POOL), nn.Flatten(), *layers, last)


class LocBlock(nn.Module):
    """Residual localisation block of the proposed STN (a ResNet basic block).

    ``main``: conv 3×3 stride 2 → BN → ReLU → conv 3×3 → BN;
    ``shortcut``: conv 1×1 stride 2 → BN; output ``ReLU(main + shortcut)``.

    Shapes: (B, in_channels, H, W) → (B, out_channels, ⌈H/2⌉, ⌈W/2⌉).
    """

    def __init__(self, in_channels: int, out_channels: int):
        super().__init__()
        self.main = nn.Sequential(
            conv_bn_relu(in_channels, out_channels, 3, stride=2),
            nn.Conv2d(out_channels, out_channels, 3, padding=1, bias=False),
            nn.BatchNorm2d(out_channels),
        )
        self.shortcut = nn.Sequential(
            nn.Conv2d(in_channels, out_channels, 1, stride=2, bias=False), nn.BatchNorm2d(out_channels)
        )

    def forward(self, x: Tensor) -> Tensor:
        return torch.relu(self.main(x) + self.shortcut(x))


class SelfAttention2d(nn.Module):
    """Self-attention over the positions of a feature map (SAGAN style).

    Queries and keys are 1×1 projections to ``channels // reduction``, values to
    ``channels``; scaled dot-product attention over all ``H·W`` positions; the
    result is added to the input with a learnt gain ``γ`` that starts at 0, so the
    block starts as the identity and keeps each position's features in place.

    Shapes: (B, C, H, W) → (B, C, H, W).
    """

    def __init__(self, channels: int, reduction: int = 8):
        super().__init__()
        inner = max(channels // reduction, 1)
        self.query = nn.Conv2d(channels, inner, 1)
        self.key = nn.Conv2d(channels, inner, 1)
        self.value = nn.Conv2d(channels, channels, 1)
        self.gamma = nn.Parameter(torch.zeros(1))

    def forward(self, x: Tensor) -> Tensor:
        b, c, h, w = x.shape
        q = self.query(x).flatten(2).transpose(1, 2)  # (B, HW, C')
        k = self.key(x).flatten(2).transpose(1, 2)
        v = self.value(x).flatten(2).transpose(1, 2)  # (B, HW, C)
        attended = F.scaled_dot_product_attention(q, k, v)
        return x + self.gamma * attended.transpose(1, 2).reshape(b, c, h, w)


class BaselineSTN(nn.Module):
    """Sha et al.'s STN: plain conv localisation layers and two FC layers.

    Args:
        in_channels: input channels (4 + 4 for map ⊕ template).
        width: channels of the first convolution (then 2·width).
        hidden: width of the hidden FC layer.

    Shapes: (B, in_channels, H, W) → (B, 8) values of ``H̄``.
    """

    def __init__(self, in_channels: int = 8, width: int = 32, hidden: int = 128):
        super().__init__()
        self.features = nn.Sequential(
            nn.Conv2d(in_channels, width, 7, stride=2, padding=3), nn.MaxPool2d(2, ceil_mode=True), nn.ReLU(True),
            nn.Conv2d(width, 2 * width, 5, padding=2), nn.MaxPool2d(2, ceil_mode=True), nn.ReLU(True),
            nn.Conv2d(2 * width, 2 * width, 3, padding=1), nn.MaxPool2d(2, ceil_mode=True), nn.ReLU(True),
        )
        self.head = _pooled_regression_head(2 * width * _POOL[0] * _POOL[1], (hidden,))

    def forward(self, x: Tensor) -> Tensor:
        return self.head(self.features(x))


class ProposedSTN(nn.Module):
    """The paper's STN: three LocBlocks, self-attention, three FC layers.

    Args:
        in_channels: input channels (4 + 4 for map ⊕ template).
        width: channels of the stem; the LocBlocks have 2·, 4·, 4·width.
        hidden: widths of the two hidden FC layers.
        attention_reduction: channel reduction of the attention's queries/keys.

    Shapes: (B, in_channels, H, W) → (B, 8) values of ``H̄``.
    """

    def __init__(self, in_channels: int = 8, width: int = 32, hidden: tuple[int, int] = (256, 64),
                 attention_reduction: int = 8):
        super().__init__()
        self.features = nn.Sequential(
            conv_bn_relu(in_channels, width, 5, stride=2),
            LocBlock(width, 2 * width),
            LocBlock(2 * width, 4 * width),
            LocBlock(4 * width, 4 * width),
            SelfAttention2d(4 * width, attention_reduction),
        )
        self.head = _pooled_regression_head(4 * width * _POOL[0] * _POOL[1], tuple(hidden))

    def forward(self, x: Tensor) -> Tensor:
        return self.head(self.features(x))
