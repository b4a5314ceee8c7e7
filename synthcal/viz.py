"""Pictures for people: montages of samples and semantic overlays (NumPy in, NumPy out)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from synthcal.scenes import colorize

__all__ = ["colorize", "overlay", "sample_strip", "tile", "labelled_rows", "non_empty_examples", "write_png"]

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


def non_empty_examples(semantic: np.ndarray, count: int, min_fraction: float = 0.35) -> np.ndarray:
    """Indices of ``count`` samples worth showing: the first whose maps are mostly labelled.

    The first samples (in pool order) whose semantic map has at least
    ``min_fraction`` non-background pixels; if too few have, the most labelled
    of the rest fill up — never an all-background sample while a labelled one is left.

    Args:
        semantic: (N, H, W) class maps.
        count: how many to pick (at most N).

    Returns:
        (min(count, N),) int64 indices, ascending.
    """
    semantic = np.asarray(semantic)
    fractions = np.count_nonzero(semantic.reshape(len(semantic), -1), axis=1) / max(semantic[0].size, 1)
    good = np.flatnonzero(fractions >= min_fraction)[:count]
    if len(good) < count:
        rest = np.setdiff1d(np.arange(len(semantic)), good)
        best = rest[np.argsort(-fractions[rest], kind="stable")][: count - len(good)]
        good = np.concatenate([good, best])
    return np.sort(good).astype(np.int64)


def labelled_rows(rows: Sequence[tuple[str, Sequence[np.ndarray]]], gap: int = 6) -> np.ndarray:
    """A montage with one row per label: the label on the left, then its equal-sized pictures.

    Args:
        rows: ``(label, pictures)`` pairs; every picture (H, W, 3) uint8 of one size.
        gap: white pixels between pictures and around the montage.

    Returns:
        (rows · (H + gap) + gap, label width + columns · (W + gap) + gap, 3) uint8 RGB.
    """
    if not rows or not any(pictures for _, pictures in rows):
        raise ValueError("nothing to tile")
    h, w = next(pictures[0] for _, pictures in rows if pictures).shape[:2]
    font, scale = cv2.FONT_HERSHEY_SIMPLEX, max(0.35, min(1.0, h / 100))
    thick = 1 if scale < 0.7 else 2
    label_width = max(cv2.getTextSize(label, font, scale, thick)[0][0] for label, _ in rows) + 2 * gap
    columns = max(len(pictures) for _, pictures in rows)
    canvas = np.full((len(rows) * (h + gap) + gap, label_width + columns * (w + gap) + gap, 3), 255, np.uint8)
    for r, (label, pictures) in enumerate(rows):
        top = gap + r * (h + gap)
        (_, text_h), _ = cv2.getTextSize(label, font, scale, thick)
        cv2.putText(canvas, label, (gap, top + (h + text_h) // 2), font, scale, (0, 0, 0), thick, cv2.LINE_AA)
        for c, picture in enumerate(pictures):
            left = label_width + gap + c * (w + gap)
            canvas[top:top + h, left:left + w] = picture
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
