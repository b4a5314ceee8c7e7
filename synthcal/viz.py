"""Pictures for people: montages of samples and semantic overlays (NumPy in, NumPy out).

:func:`sample_montage` is ``synthcal show``'s picture: samples as
[image | semantic | overlay] strips on a grid, under a header strip naming the
three columns and above a legend strip of the scene's classes (a box of each
class's palette colour and its name).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from synthcal.scenes import colorize

__all__ = ["colorize", "overlay", "sample_strip", "tile", "labelled_rows", "non_empty_examples", "write_png",
           "STRIP_COLUMNS", "LegendEntry", "Montage", "sample_montage"]

# One RGB triple per class id: a scene's (4, 3) uint8 array or a list of triples.
Palette = np.ndarray | Sequence[Sequence[int]]
# The panels of a :func:`sample_strip`, left to right: the montage's column headers.
STRIP_COLUMNS = ("image", "semantic", "overlay")
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_BLACK = (0, 0, 0)


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
    """One sample as [image | coloured semantic | overlay] (:data:`STRIP_COLUMNS`), (H, 3W + 2·gap, 3)."""
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


@dataclass(frozen=True)
class LegendEntry:
    """One class in a montage's legend: its name, colour and the box drawn in that colour.

    Attributes:
        name: the class name.
        colour: its palette RGB triple.
        box: ``(x0, y0, x1, y1)`` pixels of the filled box in the montage, ends exclusive.
    """

    name: str
    colour: tuple[int, int, int]
    box: tuple[int, int, int, int]


@dataclass(frozen=True)
class Montage:
    """:func:`sample_montage`'s picture and what was drawn around the samples.

    Attributes:
        picture: (header + grid + legend, W, 3) uint8 RGB.
        header_height: rows of the header strip at the top (the grid starts below it).
        legend: the legend's entries, class id order.
    """

    picture: np.ndarray
    header_height: int
    legend: tuple[LegendEntry, ...]


def _text_style(panel_width: int) -> tuple[float, int]:
    """Font scale and thickness for captions over panels ``panel_width`` pixels wide."""
    scale = max(0.4, min(1.0, panel_width / 320))
    return scale, 1 if scale < 0.7 else 2


def _header(width: int, spans: Sequence[tuple[str, int, int]], scale: float, thick: int, gap: int) -> np.ndarray:
    """A white strip ``width`` wide with each ``(text, left, right)`` centred over its span."""
    text_h = cv2.getTextSize("Ay", _FONT, scale, thick)[0][1]
    strip = np.full((text_h + 3 * gap, width, 3), 255, np.uint8)
    for text, left, right in spans:
        text_w = cv2.getTextSize(text, _FONT, scale, thick)[0][0]
        cv2.putText(strip, text, (left + max(0, (right - left - text_w) // 2), gap + text_h), _FONT, scale, _BLACK,
                    thick, cv2.LINE_AA)
    return strip


def _legend(width: int, classes: Sequence[str], palette: Palette, scale: float, thick: int,
            gap: int) -> tuple[np.ndarray, list[LegendEntry]]:
    """A white strip of ``[box] name`` entries, wrapped to ``width``; boxes relative to the strip."""
    text_h = cv2.getTextSize("Ay", _FONT, scale, thick)[0][1]
    side, line = text_h + 4, text_h + 4 + 2 * gap
    placed: list[tuple[str, tuple[int, int, int], int, int]] = []  # name, colour, x, y of each entry
    x, y = gap, gap
    for name, rgb in zip(classes, _triples(palette), strict=True):
        entry_w = side + gap + cv2.getTextSize(name, _FONT, scale, thick)[0][0] + 3 * gap
        if x > gap and x + entry_w > width:  # wrap: the next entry does not fit on this line
            x, y = gap, y + line
        placed.append((name, (rgb[0], rgb[1], rgb[2]), x, y))
        x += entry_w
    strip = np.full((y + line, width, 3), 255, np.uint8)
    entries = []
    for name, colour, x, y in placed:
        # A grey frame outside the box: a white or black class stays visible, its box pixels stay its colour.
        cv2.rectangle(strip, (x - 1, y - 1), (x + side, y + side), (128, 128, 128), 1)
        strip[y:y + side, x:x + side] = colour
        cv2.putText(strip, name, (x + side + gap, y + text_h + 2), _FONT, scale, _BLACK, thick, cv2.LINE_AA)
        entries.append(LegendEntry(name, colour, (x, y, x + side, y + side)))
    return strip, entries


def sample_montage(images: np.ndarray, semantics: np.ndarray, palette: Palette, classes: Sequence[str],
                   columns: int | None = None, gap: int = 6) -> Montage:
    """Samples as [image | semantic | overlay] strips on a grid, with column headers and a class legend.

    Args:
        images: (N, H, W, 3) uint8 RGB.
        semantics: (N, H, W) uint8 class ids.
        palette: one RGB triple per class id (the scene's).
        classes: one name per class id (the scene's).
        columns: strips per row (default: about square, :func:`tile`).
        gap: white pixels between strips and around the grid.

    Returns:
        :class:`Montage`: the header strip (:data:`STRIP_COLUMNS` over each strip's
        panels), the grid of :func:`tile`, the legend strip (every class, id order).
    """
    strips = [sample_strip(image, semantic, palette) for image, semantic in zip(images, semantics, strict=True)]
    grid = tile(strips, columns=columns, gap=gap)
    width = images.shape[2]
    per_row = columns or math.ceil(math.sqrt(len(strips)))
    scale, thick = _text_style(width)
    # sample_strip's panels are 2 pixels apart; tile puts strip c at gap + c · (strip width + gap).
    spans = [(name, left + p * (width + 2), left + p * (width + 2) + width)
             for left in (gap + c * (strips[0].shape[1] + gap) for c in range(min(per_row, len(strips))))
             for p, name in enumerate(STRIP_COLUMNS)]
    header = _header(grid.shape[1], spans, scale, thick, gap)
    legend, entries = _legend(grid.shape[1], classes, palette, scale, thick, gap)
    top = len(header) + len(grid)
    placed = tuple(LegendEntry(e.name, e.colour, (e.box[0], e.box[1] + top, e.box[2], e.box[3] + top))
                   for e in entries)
    return Montage(np.concatenate([header, grid, legend]), len(header), placed)
