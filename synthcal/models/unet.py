"""UNet segmenting RGB views into class logits (SPEC §7), trained with cross-entropy.

Architecture
------------
``depth`` levels of down-sampling. Each level is two (conv 3×3 → BN → ReLU); the
encoder halves the resolution with 2×2 max-pooling and doubles the channels
(``width · 2^level``); the decoder upsamples bilinearly *to the skip
connection's size* (so any H, W work, e.g. 144 = 9 · 16 and odd sizes),
concatenates the skip and applies two convolutions; a final 1×1 convolution gives
the logits.

Example
-------
>>> import torch
>>> UNet(width=8, depth=3)(torch.rand(2, 3, 36, 64)).shape
torch.Size([2, 4, 36, 64])
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from .layers import conv_bn_relu

__all__ = ["UNet", "segmentation_loss"]


def _double_conv(in_channels: int, out_channels: int) -> nn.Sequential:
    return nn.Sequential(conv_bn_relu(in_channels, out_channels), conv_bn_relu(out_channels, out_channels))


class UNet(nn.Module):
    """RGB → per-pixel class logits.

    Args:
        in_channels: input channels (3 for RGB).
        num_classes: output classes (4: background + 3).
        width: channels at full resolution.
        depth: number of down-sampling steps.

    Shapes: (B, in_channels, H, W) float in [0, 1] (or standardised) →
    (B, num_classes, H, W) logits.
    """

    def __init__(self, in_channels: int = 3, num_classes: int = 4, width: int = 16, depth: int = 4):
        super().__init__()
        channels = [width * 2**level for level in range(depth + 1)]
        self.encoder = nn.ModuleList(
            [_double_conv(in_channels, channels[0])]
            + [_double_conv(channels[i], channels[i + 1]) for i in range(depth)]
        )
        self.decoder = nn.ModuleList(
            [_double_conv(channels[i + 1] + channels[i], channels[i]) for i in reversed(range(depth))]
        )
        self.classifier = nn.Conv2d(channels[0], num_classes, 1)

    def forward(self, x: Tensor) -> Tensor:
        skips = []
        for level, block in enumerate(self.encoder):
            if level:
                x = F.max_pool2d(x, 2, ceil_mode=True)
            x = block(x)
            skips.append(x)
        skips.pop()
        for block in self.decoder:
            skip = skips.pop()
            x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            x = block(torch.cat([x, skip], dim=1))
        return self.classifier(x)


def segmentation_loss(logits: Tensor, target: Tensor, class_weights: Tensor | None = None) -> Tensor:
    """Cross-entropy ``L_CE`` of class logits against class ids.

    Args:
        logits: (B, C, H, W).
        target: (B, H, W) integer class ids.
        class_weights: (C,) weight of each class (None: the plain cross-entropy); the
            mean is then over the pixels' weights, as ``torch.nn.functional.cross_entropy``.

    Returns:
        Scalar mean over pixels and batch.
    """
    weight = None if class_weights is None else class_weights.to(logits.device, logits.dtype)
    return F.cross_entropy(logits, target.long(), weight=weight)
