"""Pictures for people: montages of samples and semantic overlays (NumPy in, NumPy out)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from synthcal.generate.scenes import colorize

__all__ = ["colorize", "overlay", "sample_strip", "tile", "write_png"]

# One RGB triple per class id: a scene's (4, 3) uint8 array or a list of triples.
Palette = np.ndarray | Sequence[Sequence[int]]


def _triples(palette: Palette) -> list[list[int]]:
    """The palette as the list of RGB triples :func:`colorize` takes."""
    return np.asarray(palette, np.uint8).reshape(-1, 3).tolist()


def overlay(image: np.ndarray, semantic: np.ndarray, palette: Palette, alpha: float = 0.5) -> np.ndarray:
    """RGB with the coloured semantic map blended over its labelled pixels."""
    coloured = colorize(semantic, _triples(palette)).astype(np.float32)
    out = image.astype(np.float32)
    labelled = semantic > 0
    out[labelled] = (1 - alpha) * out[labelled] + alpha * coloured[labelled]
    return out.astype(np.uint8)


def sample_strip(image: np.ndarray, semantic: np.ndarray, palette: Palette, gap: int = 2) -> np.ndarray:
    """One sample as [image | coloured semantic | overlay], (H, 3W + 2·gap, 3)."""
    spacer = np.full((image.shape[0], gap, 3), 255, np.uint8)
    parts = [image, spacer, colorize(semantic, _triples(palette)), spacer, overlay(image, semantic, palette)]
    return np.concatenate(parts, axis=1)


def tile(pictures: list[np.ndarray], columns: int | None = None, gap: int = 6) -> np.ndarray:
    """Equal-sized (H, W, 3) pictures on a white grid, row-major."""
    if not pictures:
        raise ValueError("nothing to tile")
    columns = columns or math.ceil(math.sqrt(len(pictures)))
    rows = math.ceil(len(pictures) / columns)
    h, w = pictures[0].shape[:2]
    canvas = np.full((rows * (h + gap) + gap, columns * (w + gap) + gap, 3), 255, np.uint8)
    for k, picture in enumerate(pictures):
        r, c = divmod(k, columns)
        canvas[gap + r * (h + gap): gap + r * (h + gap) + h, gap + c * (w + gap): gap + c * (w + gap) + w] = picture
    return canvas


def write_png(path: str | Path, rgb: np.ndarray) -> Path:
    """Write an RGB picture as PNG (atomically: temporary name, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    if not cv2.imwrite(str(tmp), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise OSError(f"{path}: could not write the PNG")
    tmp.replace(path)
    return path
