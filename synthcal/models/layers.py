"""Small building blocks shared by the networks of :mod:`synthcal.models`."""

from __future__ import annotations

from torch import nn

__all__ = ["conv_norm", "conv_bn_relu"]


def conv_norm(in_channels: int, out_channels: int, kernel_size: int = 3, stride: int = 1,
              batch_norm: bool = True) -> list[nn.Module]:
    """Convolution ("same" padding for odd kernels), then batch norm if ``batch_norm``.

    Args:
        in_channels: input channels.
        out_channels: output channels.
        kernel_size: odd kernel size.
        stride: convolution stride.
        batch_norm: follow the convolution by ``BatchNorm2d``; without it the
            convolution has a bias.

    Returns:
        The layers, mapping (B, in_channels, H, W) to (B, out_channels, ⌈H/stride⌉, ⌈W/stride⌉).
    """
    # No bias under batch norm: its shift makes it redundant.
    conv = nn.Conv2d(in_channels, out_channels, kernel_size, stride, kernel_size // 2, bias=not batch_norm)
    return [conv, nn.BatchNorm2d(out_channels)] if batch_norm else [conv]


def conv_bn_relu(in_channels: int, out_channels: int, kernel_size: int = 3, stride: int = 1,
                 batch_norm: bool = True) -> nn.Sequential:
    """Convolution ("same" padding for odd kernels) → batch norm (if ``batch_norm``) → ReLU.

    Args: as :func:`conv_norm`.

    Returns:
        A module mapping (B, in_channels, H, W) to (B, out_channels, ⌈H/stride⌉, ⌈W/stride⌉).
    """
    return nn.Sequential(*conv_norm(in_channels, out_channels, kernel_size, stride, batch_norm), nn.ReLU(inplace=True))
