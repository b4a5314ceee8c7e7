"""User scenes: a bird's-eye RGB PNG plus a semantic PNG (SPEC §4).

The semantic PNG is either

* single-channel (8- or 16-bit) class ids, each in 0..3 — a 3-channel PNG whose
  channels are all equal counts as single-channel; or
* colours, with ``palette = {class_id: (r, g, b)}`` mapping every colour that
  occurs to its class (an alpha channel is ignored).

Every error is a :class:`SceneError` naming the scene, the key (``image``,
``semantic``, ``palette``, ``classes``, ``camera_position``, ``pixels_per_metre``),
the file where one is involved, and the offending value (for a bad pixel, one
position where it occurs, as row and column).

Example
-------
>>> import tempfile, pathlib, numpy as np, cv2
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = cv2.imwrite(str(d / "rgb.png"), np.zeros((4, 6, 3), np.uint8))
>>> _ = cv2.imwrite(str(d / "ids.png"), np.full((4, 6), 2, np.uint8))
>>> load_user_scene("mine", d / "rgb.png", d / "ids.png").semantic.shape
(4, 6)
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np

from .base import NUM_CLASSES, Scene, SceneError, file_not_found, freeze

__all__ = ["load_user_scene", "DEFAULT_CLASSES", "DEFAULT_PALETTE"]

DEFAULT_CLASSES = ("background", "class 1", "class 2", "class 3")
DEFAULT_PALETTE = ((0, 0, 0), (128, 64, 128), (107, 196, 64), (230, 40, 60))


def _read(name: str, key: str, path: Path, flags: int) -> np.ndarray:
    if not path.is_file():
        raise SceneError(f"scene {name!r}: {key}: {file_not_found(path)}")
    array = cv2.imread(str(path), flags)
    if array is None:
        raise SceneError(f"scene {name!r}: {key}: cannot read {path} as an image (PNG expected)")
    return array


def _first(mask: np.ndarray) -> tuple[int, int]:
    row, col = np.argwhere(mask)[0]
    return int(row), int(col)


def _check_palette(name: str, palette: Mapping[int, Sequence[int]]) -> dict[int, tuple[int, int, int]]:
    checked: dict[int, tuple[int, int, int]] = {}
    for class_id, colour in palette.items():
        if not isinstance(class_id, (int, np.integer)) or not 0 <= int(class_id) < NUM_CLASSES:
            raise SceneError(f"scene {name!r}: palette: class id {class_id!r} is not one of 0..{NUM_CLASSES - 1}")
        values = tuple(colour)
        if len(values) != 3 or any(not isinstance(c, (int, np.integer)) or not 0 <= int(c) <= 255 for c in values):
            raise SceneError(f"scene {name!r}: palette: colour {colour!r} of class {class_id} is not 3 integers 0..255")
        r, g, b = (int(c) for c in values)
        checked[int(class_id)] = (r, g, b)
    owners: dict[tuple[int, int, int], int] = {}
    for class_id, colour in checked.items():
        if colour in owners:
            raise SceneError(f"scene {name!r}: palette: colour {colour} is given to classes "
                             f"{owners[colour]} and {class_id}")
        owners[colour] = class_id
    return checked


def _ids(name: str, path: Path, raw: np.ndarray) -> np.ndarray:
    """Class ids from a single-channel map, checked to lie in 0..3."""
    bad = raw >= NUM_CLASSES
    if bad.any():
        row, col = _first(bad)
        raise SceneError(f"scene {name!r}: semantic: {path} holds class id {int(raw[row, col])} at row {row}, "
                         f"column {col}; class ids must be 0..{NUM_CLASSES - 1} (or give a palette)")
    return raw.astype(np.uint8)


def _from_colours(name: str, path: Path, rgb: np.ndarray, palette: dict[int, tuple[int, int, int]]) -> np.ndarray:
    """Class ids from an RGB map through ``palette``; unknown colours are errors."""
    packed = (rgb[..., 0].astype(np.int64) << 16) | (rgb[..., 1].astype(np.int64) << 8) | rgb[..., 2].astype(np.int64)
    keys = np.array(sorted((r << 16) | (g << 8) | b for r, g, b in palette.values()), np.int64)
    lookup = {(r << 16) | (g << 8) | b: class_id for class_id, (r, g, b) in palette.items()}
    pos = np.clip(np.searchsorted(keys, packed), 0, max(len(keys) - 1, 0))
    known = keys[pos] == packed if len(keys) else np.zeros(packed.shape, bool)
    if not known.all():
        row, col = _first(~known)
        colour = tuple(int(c) for c in rgb[row, col])
        raise SceneError(f"scene {name!r}: semantic: {path} has colour {colour} at row {row}, column {col}, "
                         f"which is not in the palette {palette}")
    classes = np.array([lookup[int(k)] for k in keys], np.uint8)
    return classes[pos]


def load_user_scene(
    name: str,
    image_path: str | os.PathLike,
    semantic_path: str | os.PathLike,
    palette: Mapping[int, Sequence[int]] | None = None,
    classes: Sequence[str] | None = None,
    heading_deg: float = 0.0,
    camera_position: Sequence[float] | None = None,
    pixels_per_metre: float = 10.0,
) -> Scene:
    """Read a user scene from two PNG files.

    Args:
        name: the scene's name (its key in ``datasets.yaml``).
        image_path: bird's-eye RGB image (any format cv2 reads; PNG expected).
        semantic_path: (H, W) class ids 0..3, or colours mapped by ``palette``.
        palette: ``{class_id: (r, g, b)}`` for a colour semantic map; also the
            display palette (missing classes get default colours).
        classes: 4 class names (default ``background, class 1, class 2, class 3``).
        heading_deg: added to every pan.
        camera_position: default ``(X, Y, Z)`` in bird's-eye pixels, or None.
        pixels_per_metre: ground scale.

    Returns:
        The scene: (H, W, 3) uint8 RGB and (H, W) uint8 ids, read-only.

    Raises:
        SceneError: missing or unreadable file, size mismatch, class id out of
            range, colour not in the palette, bad palette, classes or camera.
    """
    image_path, semantic_path = Path(image_path), Path(semantic_path)
    checked = _check_palette(name, palette) if palette is not None else None
    names, position = _check_settings(name, classes, camera_position, pixels_per_metre)

    bgr = _read(name, "image", image_path, cv2.IMREAD_COLOR)
    rgb = np.ascontiguousarray(bgr[..., ::-1])
    raw = _read(name, "semantic", semantic_path, cv2.IMREAD_UNCHANGED)
    if raw.shape[:2] != rgb.shape[:2]:
        raise SceneError(f"scene {name!r}: semantic: {semantic_path} is {raw.shape[1]} × {raw.shape[0]} px but "
                         f"image {image_path} is {rgb.shape[1]} × {rgb.shape[0]} px; they must match")
    semantic = _semantic_ids(name, semantic_path, raw, checked)

    display: list[tuple[int, int, int]] = list(DEFAULT_PALETTE)
    for class_id, colour in (checked or {}).items():
        display[class_id] = colour
    return Scene(name, freeze(rgb), freeze(semantic), names, tuple(display), heading_deg=float(heading_deg),
                 camera_position=position, pixels_per_metre=float(pixels_per_metre),
                 description=f"user scene: {image_path.name} + {semantic_path.name}")


def _check_settings(
    name: str, classes: Sequence[str] | None, camera_position: Sequence[float] | None, pixels_per_metre: float
) -> tuple[tuple[str, ...], tuple[float, float, float] | None]:
    """The class names (default :data:`DEFAULT_CLASSES`) and the camera position, checked."""
    names = DEFAULT_CLASSES if classes is None else tuple(str(c) for c in classes)
    if len(names) != NUM_CLASSES:
        raise SceneError(f"scene {name!r}: classes: {list(names)} must name exactly {NUM_CLASSES} classes")
    position = None
    if camera_position is not None:
        values = tuple(float(v) for v in camera_position)
        if len(values) != 3 or not values[2] > 0 or not np.isfinite(values).all():
            raise SceneError(f"scene {name!r}: camera_position: {tuple(camera_position)} must be (X, Y, Z) with Z > 0")
        position = (values[0], values[1], values[2])
    if not 0 < pixels_per_metre < np.inf:
        raise SceneError(f"scene {name!r}: pixels_per_metre: {pixels_per_metre} must be positive")
    return names, position


def _semantic_ids(
    name: str, path: Path, raw: np.ndarray, palette: dict[int, tuple[int, int, int]] | None
) -> np.ndarray:
    """(H, W) uint8 class ids from the semantic file's (H, W) or (H, W, 3|4) BGR(A) array.

    A colour map needs a palette, unless it is grey (then its level is the id); a
    grey map with a palette is looked up as colours (v, v, v).
    """
    if raw.ndim != 3:
        if palette is not None:
            return _from_colours(name, path, np.repeat(raw[..., None], 3, -1), palette)
        return _ids(name, path, raw)
    raw = raw[..., :3][..., ::-1]  # BGR(A) → RGB
    if palette is not None:
        return _from_colours(name, path, raw, palette)
    if not (np.array_equal(raw[..., 0], raw[..., 1]) and np.array_equal(raw[..., 0], raw[..., 2])):
        row, col = _first(~((raw[..., 0] == raw[..., 1]) & (raw[..., 0] == raw[..., 2])))
        raise SceneError(f"scene {name!r}: semantic: {path} is a colour image (e.g. "
                         f"{tuple(int(c) for c in raw[row, col])} at row {row}, column {col}) but no "
                         f"palette maps its colours to classes")
    return _ids(name, path, raw[..., 0])
