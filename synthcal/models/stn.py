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

Architectures (input (B, 8, H, W) of the ``image_size`` given at construction)
------------------------------------------------------------------------------
Both end in fully connected layers on the *flattened* feature map (no pooling to a
fixed grid: the paper names none), so each network is built for one image size
``(W, H)`` and says so when given another.

* :class:`BaselineSTN` (Sha et al. as the paper describes them: the classic STN
  localisation network of Jaderberg et al., two convolutional "location layers",
  then the FC regressor): conv 7×7 stride 2 → max-pool 2 → ReLU; conv 5×5 →
  max-pool 2 → ReLU; flatten; FC → ReLU → FC(8). No residuals; no normalisation by
  default. Features at /8 (``2·width × 9 × 16`` at 128 × 72).
* :class:`CcbvSTN` (the public re-implementation of Sha et al. that practitioners
  use, github.com/evs-broadcast/CCBV, ``models.py``; written here from its
  description): three :class:`CcbvBlock` (residual conv–BN–LeakyReLU), each
  followed by a max-pool of 4, 2, 2 (floor); channels 16, 32, 64; flatten; FC
  9216 → 4096 → 1024 → 8 with ReLU at 256 × 144 (64 × 9 × 16 = 9,216 features).
  At other sizes the flattened count follows the input and the hidden widths
  scale with it (:func:`ccbv_hidden`).
* :class:`ProposedSTN` (the paper's): three :class:`LocBlock` (residual, each
  halves the resolution: /8 overall, ``4·width × 9 × 16`` at 128 × 72);
  :class:`SelfAttention2d` (Vaswani et al.'s scaled dot-product attention over the
  positions, residual and layer norm); flatten; three FC layers
  (→ 256 → 64 → 8, ReLU between).

Batch normalisation
-------------------
Each network takes ``batch_norm``, so that BN is an ablation row rather than a
confound between models. Defaults keep each network as it is described: the
proposed STN's LocBlocks and the CCBV blocks have it (``True``), the baseline's
two location layers do not (``False``). Without BN a convolution gets a bias;
with it, BN follows each convolution (before the pool and activation in the
baseline). The self-attention's layer norm is not batch norm and stays.

Example
-------
>>> import torch
>>> stn = ProposedSTN(image_size=(64, 36))
>>> h = stn(torch.rand(2, 8, 36, 64))
>>> bool((h == torch.tensor(IDENTITY_H8)).all())
True
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from .layers import conv_bn_relu, conv_norm

__all__ = [
    "IDENTITY_H8",
    "h_bar_matrix",
    "normalization_matrix",
    "compose_homography",
    "LocBlock",
    "SelfAttention2d",
    "CcbvBlock",
    "ccbv_hidden",
    "BaselineSTN",
    "CcbvSTN",
    "ProposedSTN",
]

IDENTITY_H8 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)


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


def _regression_head(in_features: int, hidden: tuple[int, ...]) -> nn.Sequential:
    """Flatten, FC layers with ReLU between, 8 outputs initialised to the identity ``H̄``."""
    layers: list[nn.Module] = []
    for width in hidden:
        layers += [nn.Linear(in_features, width), nn.ReLU(inplace=True)]
        in_features = width
    last = nn.Linear(in_features, 8)
    nn.init.zeros_(last.weight)
    with torch.no_grad():
        last.bias.copy_(torch.tensor(IDENTITY_H8))
    return nn.Sequential(nn.Flatten(), *layers, last)


@torch.no_grad()
def _feature_count(features: nn.Module, in_channels: int, image_size: tuple[int, int]) -> int:
    """Number of values ``features`` gives for one (in_channels, H, W) input (eval mode: no BN update)."""
    was_training = features.training
    features.eval()
    count = features(torch.zeros(1, in_channels, image_size[1], image_size[0])).numel()
    features.train(was_training)
    return count


def _checked_input(x: Tensor, image_size: tuple[int, int], name: str) -> Tensor:
    """``x`` of the size the network was built for, in contiguous (NCHW) memory.

    One-hot maps (``one_hot_maps`` moves the class axis) and their concatenation
    arrive in channels-last memory; with such an input the backward pass of a
    LocBlock corrupted the heap in torch 2.13's CPU (oneDNN) convolutions
    (``free(): invalid size``, segfaults; gone with ``torch.backends.mkldnn.enabled =
    False`` or a contiguous input), so the networks take a contiguous copy.
    """
    if (x.shape[-1], x.shape[-2]) != tuple(image_size):
        raise ValueError(f"{name} was built for {image_size[0]} × {image_size[1]} inputs (W × H), "
                         f"got {x.shape[-1]} × {x.shape[-2]}")
    return x.contiguous()


class LocBlock(nn.Module):
    """Residual localisation block of the proposed STN (a ResNet basic block).

    ``main``: conv 3×3 stride 2 → BN → ReLU → conv 3×3 → BN;
    ``shortcut``: conv 1×1 stride 2 → BN; output ``ReLU(main + shortcut)``.
    ``batch_norm=False`` drops the three BNs (the convolutions then have biases).

    Shapes: (B, in_channels, H, W) → (B, out_channels, ⌈H/2⌉, ⌈W/2⌉).
    """

    def __init__(self, in_channels: int, out_channels: int, batch_norm: bool = True):
        super().__init__()
        self.main = nn.Sequential(
            conv_bn_relu(in_channels, out_channels, 3, stride=2, batch_norm=batch_norm),
            *conv_norm(out_channels, out_channels, 3, batch_norm=batch_norm),
        )
        self.shortcut = nn.Sequential(*conv_norm(in_channels, out_channels, 1, stride=2, batch_norm=batch_norm))

    def forward(self, x: Tensor) -> Tensor:
        return torch.relu(self.main(x) + self.shortcut(x))


class SelfAttention2d(nn.Module):
    """Self-attention over the positions of a feature map (Vaswani et al., 2017).

    The ``H·W`` positions are the tokens, their ``C`` channels the features:
    ``Q, K, V`` are linear projections (one ``C → 3C`` layer, ``heads`` heads of
    ``C / heads`` features), each head computes scaled dot-product attention
    ``softmax(Q Kᵀ / √d) V`` over all positions, the heads are concatenated and
    projected (``C → C``), then added to the input and layer-normalised over the
    channels ("Add & Norm"). No positional encoding: the flattening that follows
    keeps every position in its place.

    Args:
        channels: ``C``.
        heads: number of heads; divides ``C``.

    Shapes: (B, C, H, W) → (B, C, H, W).
    """

    def __init__(self, channels: int, heads: int = 1):
        super().__init__()
        if channels % heads:
            raise ValueError(f"heads ({heads}) must divide channels ({channels})")
        self.heads = heads
        self.qkv = nn.Linear(channels, 3 * channels)
        self.out = nn.Linear(channels, channels)
        self.norm = nn.LayerNorm(channels)

    def forward(self, x: Tensor) -> Tensor:
        b, c, h, w = x.shape
        tokens = x.flatten(2).transpose(1, 2)  # (B, HW, C)
        q, k, v = self.qkv(tokens).unflatten(-1, (3, self.heads, c // self.heads)).permute(2, 0, 3, 1, 4)
        attended = F.scaled_dot_product_attention(q, k, v)  # (B, heads, HW, C / heads)
        tokens = self.norm(tokens + self.out(attended.transpose(1, 2).flatten(2)))
        return tokens.transpose(1, 2).reshape(b, c, h, w)


class BaselineSTN(nn.Module):
    """Sha et al.'s STN: two conv localisation layers, then the FC regressor.

    Args:
        in_channels: input channels (4 + 4 for map ⊕ template).
        image_size: ``(W, H)`` of the inputs (keyword only: the FC layers depend on it).
        width: channels of the first convolution (then 2·width).
        hidden: width of the hidden FC layer.
        batch_norm: BN after each convolution (off by default: the paper's
            description has none; module docstring).

    Shapes: (B, in_channels, H, W) → (B, 8) values of ``H̄``.
    """

    def __init__(self, in_channels: int = 8, *, image_size: tuple[int, int], width: int = 32, hidden: int = 128,
                 batch_norm: bool = False):
        super().__init__()
        self.image_size = (int(image_size[0]), int(image_size[1]))
        self.features = nn.Sequential(
            *conv_norm(in_channels, width, 7, stride=2, batch_norm=batch_norm),
            nn.MaxPool2d(2, ceil_mode=True), nn.ReLU(True),
            *conv_norm(width, 2 * width, 5, batch_norm=batch_norm), nn.MaxPool2d(2, ceil_mode=True), nn.ReLU(True),
        )
        self.head = _regression_head(_feature_count(self.features, in_channels, image_size), (hidden,))

    def forward(self, x: Tensor) -> Tensor:
        x = _checked_input(x, self.image_size, type(self).__name__)
        return self.head(self.features(x))


def _conv_bn_leaky(in_channels: int, out_channels: int, batch_norm: bool) -> nn.Sequential:
    """Conv 3×3 (with bias, as the public layers keep it under BN: same parameter count) → BN → LeakyReLU."""
    norm = [nn.BatchNorm2d(out_channels)] if batch_norm else []
    return nn.Sequential(nn.Conv2d(in_channels, out_channels, 3, padding=1), *norm, nn.LeakyReLU(inplace=True))


class CcbvBlock(nn.Module):
    """Residual block of the CCBV localisation network, then its max-pool.

    ``a = f₁(x)``, ``out = pool(f₂(f₂(a) + a))`` with ``fᵢ`` conv 3×3 → BN →
    LeakyReLU (slope 0.01); ``f₂`` is one layer applied twice, its weights (and its
    BN's statistics) shared, as in the public code. ``batch_norm=False`` drops both BNs.

    Shapes: (B, in_channels, H, W) → (B, out_channels, ⌊H/pool⌋, ⌊W/pool⌋).
    """

    def __init__(self, in_channels: int, out_channels: int, pool: int, batch_norm: bool = True):
        super().__init__()
        self.first = _conv_bn_leaky(in_channels, out_channels, batch_norm)
        self.second = _conv_bn_leaky(out_channels, out_channels, batch_norm)
        self.pool = nn.MaxPool2d(pool)

    def forward(self, x: Tensor) -> Tensor:
        a = self.first(x)
        return self.pool(self.second(self.second(a) + a))


# The public network's flattened features and hidden FC widths at its 256 × 144 input.
CCBV_FEATURES = 9216
CCBV_HIDDEN = (4096, 1024)


def ccbv_hidden(features: int) -> tuple[int, int]:
    """Hidden FC widths of :class:`CcbvSTN` for ``features`` flattened inputs.

    The public widths (4096, 1024) at its 9,216 features; for fewer features (a
    smaller working resolution) both scale by ``features / 9216``, rounded, at least
    8, so that each layer keeps the public network's reduction ratios (9216 : 4096 :
    1024) instead of widening the features; never scaled up: beyond 256 × 144 the
    first layer grows with the input and the rest stays the public size.

    >>> ccbv_hidden(9216), ccbv_hidden(2048), ccbv_hidden(512), ccbv_hidden(20000)
    ((4096, 1024), (910, 228), (228, 57), (4096, 1024))
    """
    scale = min(1.0, features / CCBV_FEATURES)
    first, second = (max(8, round(width * scale)) for width in CCBV_HIDDEN)
    return first, second


class CcbvSTN(nn.Module):
    """The CCBV re-implementation of Sha et al.'s STN (module docstring).

    Args:
        in_channels: input channels (4 + 4 for map ⊕ template).
        image_size: ``(W, H)`` of the inputs (keyword only: the FC layers depend on
            it); at least 16 × 16 (the pools divide by 16).
        batch_norm: the blocks' BNs (on by default, as the public code).
        widths: channels of the three blocks.
        hidden: hidden FC widths (None: :func:`ccbv_hidden` of the feature count).

    Shapes: (B, in_channels, H, W) → (B, 8) values of ``H̄``.
    """

    def __init__(self, in_channels: int = 8, *, image_size: tuple[int, int], batch_norm: bool = True,
                 widths: tuple[int, int, int] = (16, 32, 64), hidden: tuple[int, int] | None = None):
        super().__init__()
        self.image_size = (int(image_size[0]), int(image_size[1]))
        if min(self.image_size) < 16:
            raise ValueError(f"CcbvSTN needs inputs of at least 16 × 16 (pools 4, 2, 2), got {self.image_size}")
        channels = (in_channels, *widths)
        self.features = nn.Sequential(*(CcbvBlock(channels[k], channels[k + 1], pool, batch_norm)
                                        for k, pool in enumerate((4, 2, 2))))
        count = _feature_count(self.features, in_channels, self.image_size)
        self.head = _regression_head(count, hidden if hidden is not None else ccbv_hidden(count))

    def forward(self, x: Tensor) -> Tensor:
        x = _checked_input(x, self.image_size, type(self).__name__)
        return self.head(self.features(x))


class ProposedSTN(nn.Module):
    """The paper's STN: three LocBlocks, self-attention, three FC layers.

    Args:
        in_channels: input channels (4 + 4 for map ⊕ template).
        image_size: ``(W, H)`` of the inputs (keyword only: the FC layers depend on it).
        width: channels of the first LocBlock (then 2·, 4·width).
        hidden: widths of the two hidden FC layers.
        heads: attention heads.
        batch_norm: the LocBlocks' BNs (on by default; module docstring).

    Shapes: (B, in_channels, H, W) → (B, 8) values of ``H̄``.
    """

    def __init__(self, in_channels: int = 8, *, image_size: tuple[int, int], width: int = 32,
                 hidden: tuple[int, int] = (256, 64), heads: int = 1, batch_norm: bool = True):
        super().__init__()
        self.image_size = (int(image_size[0]), int(image_size[1]))
        self.features = nn.Sequential(
            LocBlock(in_channels, width, batch_norm),
            LocBlock(width, 2 * width, batch_norm),
            LocBlock(2 * width, 4 * width, batch_norm),
            SelfAttention2d(4 * width, heads),
        )
        self.head = _regression_head(_feature_count(self.features, in_channels, image_size), tuple(hidden))

    def forward(self, x: Tensor) -> Tensor:
        x = _checked_input(x, self.image_size, type(self).__name__)
        return self.head(self.features(x))
