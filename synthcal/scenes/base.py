"""The scene record shared by built-in and user scenes, and how to look at one.

A scene is a bird's-eye RGB image and a semantic map of the same size (SPEC §2,
§4): bird's-eye pixel ``(u, v)`` is ground point ``(x, y) = (u, v)``. Class ids
are 0..3, 0 always being background.

Example
-------
>>> import numpy as np
>>> semantic = np.array([[0, 1], [2, 3]], np.uint8)
>>> colorize(semantic, ((0, 0, 0), (9, 9, 9), (0, 200, 0), (200, 0, 0)))[1, 1].tolist()
[200, 0, 0]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

__all__ = ["Scene", "SceneError", "NUM_CLASSES", "colorize", "draw_scene", "freeze", "file_not_found"]

NUM_CLASSES = 4


class SceneError(ValueError):
    """A scene cannot be built or loaded; the message names the file, key and value."""


def file_not_found(path: Path) -> str:
    """``file not found: PATH``, and where a relative path was looked for (a configuration's paths
    are relative to its own folder, not to where the command runs)."""
    shown = str(path) if path.is_absolute() else f"{path} (looked for {path.absolute()})"
    return f"file not found: {shown}"


@dataclass(frozen=True)
class Scene:
    """A bird's-eye scene.

    Attributes:
        name: scene name (``intersection-3``, ``soccer`` or the user's key).
        image: (Hs, Ws, 3) uint8 RGB bird's-eye view, read-only.
        semantic: (Hs, Ws) uint8 class ids in 0..3 (0 = background), read-only.
        classes: 4 class names, index = class id, ``classes[0] == "background"``.
        palette: 4 RGB display colours, one per class.
        heading_deg: added to every pan (SPEC §2).
        camera_position: default ``(X, Y, Z)`` in bird's-eye pixels (``Z`` the
            height), used when a grid leaves X/Y/Z to the scene, and the anchor
            of a relative grid (:attr:`anchor`); None if the scene has none.
        pixels_per_metre: ground scale of the bird's-eye image.
        description: one line for listings.
        field: the playing field, the polygon ``iou_part`` is clipped to (SPEC §4,
            §8): ``(u, v)`` vertices in bird's-eye pixels, or None for the whole
            scene (:meth:`field_polygon` resolves it).
    """

    name: str
    image: np.ndarray
    semantic: np.ndarray
    classes: tuple[str, ...]
    palette: tuple[tuple[int, int, int], ...]
    heading_deg: float = 0.0
    camera_position: tuple[float, float, float] | None = None
    pixels_per_metre: float = 10.0
    description: str = ""
    field: tuple[tuple[float, float], ...] | None = None

    @property
    def anchor(self) -> tuple[float, float]:
        """Where a relative grid's X/Y offsets start (``xy_relative``, SPEC §3).

        The camera position's ``(X, Y)`` when the scene has one, else the scene
        centre ``(Ws / 2, Hs / 2)`` — ``(650, 950)`` for a 1300 × 1900 scene, the
        centre of the paper's intersection grid.
        """
        if self.camera_position is not None:
            return float(self.camera_position[0]), float(self.camera_position[1])
        height, width = self.semantic.shape[:2]
        return width / 2.0, height / 2.0

    def field_polygon(self) -> list[list[float]]:
        """The field's vertices ``[[u, v], ...]``; the scene rectangle ``[-0.5, Ws − 0.5] × [-0.5, Hs − 0.5]`` by default."""
        if self.field is not None:
            return [[float(u), float(v)] for u, v in self.field]
        height, width = self.semantic.shape[:2]
        return [[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]]


def freeze(array: np.ndarray) -> np.ndarray:
    """``array`` made C-contiguous (copied only if needed) and read-only: cached scenes are shared."""
    array = np.ascontiguousarray(array)
    array.flags.writeable = False
    return array


def colorize(semantic: np.ndarray, palette: Sequence[Sequence[int]]) -> np.ndarray:
    """Paint a class map with one colour per class.

    Args:
        semantic: (H, W) integer class ids.
        palette: one RGB triple per class id.

    Returns:
        (H, W, 3) uint8 RGB.

    Raises:
        SceneError: a class id has no palette entry.
    """
    colours = np.asarray(palette, dtype=np.uint8).reshape(-1, 3)
    semantic = np.asarray(semantic)
    if semantic.size and int(semantic.max()) >= len(colours):
        raise SceneError(f"semantic map holds class id {int(semantic.max())} but the palette has "
                         f"only {len(colours)} colours")
    return colours[semantic]


def _legend(scene: Scene, width: int) -> np.ndarray:
    """A strip with the scene name and one swatch + name per class, (h, width, 3) uint8."""
    scale = max(0.6, width / 2200.0)
    row = int(40 * scale)
    strip = np.full((row * 2, width, 3), 255, np.uint8)
    font, thick = cv2.FONT_HERSHEY_SIMPLEX, max(1, int(round(2 * scale)))
    title = f"{scene.name}  ({scene.semantic.shape[1]} x {scene.semantic.shape[0]} px, " \
            f"{scene.pixels_per_metre:g} px/m)"
    cv2.putText(strip, title, (int(10 * scale), int(row * 0.7)), font, 0.8 * scale, (0, 0, 0), thick, cv2.LINE_AA)
    x = int(10 * scale)
    for class_id, (name, colour) in enumerate(zip(scene.classes, scene.palette, strict=True)):
        y0 = row + int(row * 0.15)
        cv2.rectangle(strip, (x, y0), (x + int(row * 0.7), y0 + int(row * 0.7)), tuple(int(c) for c in colour), -1)
        cv2.rectangle(strip, (x, y0), (x + int(row * 0.7), y0 + int(row * 0.7)), (0, 0, 0), 1)
        label = f"{class_id} {name}"
        cv2.putText(strip, label, (x + int(row * 0.9), row + int(row * 0.7)), font, 0.7 * scale, (0, 0, 0),
                    thick, cv2.LINE_AA)
        (tw, _), _ = cv2.getTextSize(label, font, 0.7 * scale, thick)
        x += int(row * 0.9) + tw + int(row * 0.8)
    return strip


def draw_scene(scene: Scene) -> np.ndarray:
    """The bird's-eye RGB beside its palette-coloured semantic map, with a legend.

    Args:
        scene: any scene.

    Returns:
        (Hs + legend, 2 Ws + gap, 3) uint8 RGB picture (written by ``synthcal scene``).
    """
    height, width = scene.semantic.shape
    gap = max(8, width // 100)
    panel = np.full((height, 2 * width + gap, 3), 255, np.uint8)
    panel[:, :width] = scene.image
    panel[:, width + gap:] = colorize(scene.semantic, scene.palette)
    return np.concatenate([_legend(scene, panel.shape[1]), panel], axis=0)
