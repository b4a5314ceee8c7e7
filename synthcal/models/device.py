"""Choosing the torch device by name.

Example
-------
>>> device_from_name("cpu")
device(type='cpu')
"""

from __future__ import annotations

import torch

__all__ = ["device_from_name"]


def device_from_name(name: str = "auto") -> torch.device:
    """The device called ``name``.

    Args:
        name: ``"auto"`` (CUDA when available, else CPU), ``"cpu"``, ``"cuda"`` or
            any string ``torch.device`` accepts (``"cuda:1"``).

    Returns:
        The device.

    Raises:
        RuntimeError: ``name`` asks for CUDA and none is available.
    """
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    device = torch.device(name)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise RuntimeError(f"device {name!r} requested but CUDA is not available")
    return device
