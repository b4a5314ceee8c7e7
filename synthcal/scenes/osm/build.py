"""Intersection scenes from OpenStreetMap: any real junction becomes a scene (SPEC §4).

:func:`build_osm_scene` reads an extract (``.osm``, ``.osm.pbf``, ``.osm.bz2``)
around a centre ``(lat, lon)`` and paints the bird's-eye semantic map and a
plausible RGB in the frame of SPEC §4 (:mod:`.read`): a transverse Mercator
centred on the centre, ``u = (W − 1)/2 + E·ppm``, ``v = (H − 1)/2 − N·ppm``, north
up — or turned about the centre by ``rotation_deg`` (a bearing ``b`` drawn at ``b + r``,
clockwise on screen), e.g. to line a junction's legs up with a built-in layout's
(:func:`~.junctions.layout_rotation`). The defaults (130 × 190 m at 10 px/m: 1300 × 1900 px) put the paper's
intersection grid (X 600–700, Y 900–1000) over the centre.

Classes: 1 road (carriageways), 2 terrain (grass, parks, scrub), 3 bicycle path,
0 everything else; the tag → class mapping and the painting order are in
:mod:`.classes`, overridable with ``classes``. The RGB (:mod:`.dress`) is
seeded: the same file, centre, size, scale, classes and seed give byte-identical
arrays.

A scene is built once per content: its key is the SHA-256 of the file's bytes and
of the settings; the arrays are kept in the process and, as two PNG files, in the
cache folder (``$SYNTHCAL_CACHE/osm``, default ``~/.cache/synthcal/osm``).

Data © OpenStreetMap contributors, under the Open Database Licence (ODbL);
:func:`osm_attributes` is what a store records about its source.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from synthcal.utils.atomic import atomic_write

from ..base import Scene, SceneError, file_not_found, freeze
from ..intersection import PALETTE
from .classes import CLASS_NAMES, ClassRules, class_rules, relevant_keys
from .read import Frame, centre_inside, read_osm

__all__ = ["build_osm_scene", "paint_window", "forget_scenes_in_memory", "osm_attributes", "file_sha256",
           "OSM_LICENCE", "OSM_ATTRIBUTION", "cache_folder"]

OSM_LICENCE = "ODbL-1.0"
OSM_ATTRIBUTION = "© OpenStreetMap contributors"
# Bump when the painting changes: cached scenes of an older painter are then rebuilt.
# 2: ways with nodes missing from the extract are kept as their located runs (were dropped).
PAINTER_VERSION = 2

_MEMORY: dict[str, Scene] = {}
# What reading found, per cache key (``missing_nodes``, ``cut_ways``): the store's provenance.
_READINGS: dict[str, dict[str, int]] = {}
_HASHES: dict[tuple[str, int, int], str] = {}


def forget_scenes_in_memory() -> None:
    """Drop the scene this process keeps in memory, so the next build reads the disk cache (or paints)."""
    _MEMORY.clear()


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's bytes (remembered per path, size and modification time)."""
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    if key not in _HASHES:
        digest = hashlib.sha256()
        with path.open("rb") as stream:
            for block in iter(lambda: stream.read(1 << 20), b""):
                digest.update(block)
        _HASHES[key] = digest.hexdigest()
    return _HASHES[key]


def cache_folder() -> Path:
    """Where built OSM scenes are kept: ``$SYNTHCAL_CACHE/osm``, else ``~/.cache/synthcal/osm``."""
    root = os.environ.get("SYNTHCAL_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "synthcal") / "osm"


def _check_file(where: str, path: Path) -> None:
    if not path.is_file():
        raise SceneError(f"{where}.file: {file_not_found(path)}")
    if not os.access(path, os.R_OK):
        raise SceneError(f"{where}.file: cannot read {path} (permission denied)")


def _check_numbers(where: str, path: Path, center: Sequence[float], size_m: Sequence[float],
                   ppm: float) -> tuple[tuple[float, float], tuple[float, float], float]:
    """The centre, size and scale as floats, checked (messages name the file, key and value)."""
    try:
        lat, lon = (float(c) for c in center)
        width, height = (float(s) for s in size_m)
        scale = float(ppm)
    except (TypeError, ValueError):
        raise SceneError(f"{where} ({path}): center (lat, lon), size_m (width, height) and pixels_per_metre must "
                         f"be numbers (values {center!r}, {size_m!r}, {ppm!r})") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise SceneError(f"{where}.center ({path}): (lat, lon) must lie in -90..90, -180..180 (value {lat}, {lon})")
    if not (width > 0 and height > 0 and math.isfinite(width * height)):
        raise SceneError(f"{where}.size_m ({path}): width and height in metres must be > 0 (value {width}, {height})")
    if not (scale > 0 and math.isfinite(scale)):
        raise SceneError(f"{where}.pixels_per_metre ({path}): must be > 0 (value {scale})")
    if round(width * scale) < 1 or round(height * scale) < 1:
        raise SceneError(f"{where}.size_m ({path}): {width} × {height} m at {scale} px/m is less than one pixel")
    return (lat, lon), (width, height), scale


def _check_rotation(where: str, path: Path, rotation_deg: float) -> float:
    try:
        rotation = float(rotation_deg)
    except (TypeError, ValueError):
        rotation = math.nan
    if not math.isfinite(rotation):
        raise SceneError(f"{where}.rotation_deg ({path}): must be a finite number of degrees (value {rotation_deg!r})")
    return rotation


def _cache_key(digest: str, frame: Frame, classes: Mapping[str, Sequence[str]] | None, seed: int) -> str:
    settings = {"file": digest, "center": [frame.lat, frame.lon], "size_m": [frame.width_m, frame.height_m],
                "ppm": frame.ppm, "classes": {k: list(v) for k, v in (classes or {}).items()}, "seed": seed,
                "painter": PAINTER_VERSION}
    if frame.rotation_deg != 0.0:  # north-up scenes keep the keys of their cache entries
        settings["rotation_deg"] = frame.rotation_deg
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()


def _load_cached(folder: Path) -> tuple[np.ndarray, np.ndarray, dict[str, int]] | None:
    if not all((folder / name).is_file() for name in ("image.png", "semantic.png", "reading.json")):
        return None
    image = cv2.imread(str(folder / "image.png"), cv2.IMREAD_COLOR)
    semantic = cv2.imread(str(folder / "semantic.png"), cv2.IMREAD_UNCHANGED)
    try:
        reading = json.loads((folder / "reading.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):  # a damaged cache entry is rebuilt
        return None
    if image is None or semantic is None or semantic.ndim != 2 or not isinstance(reading, dict):
        return None
    return np.ascontiguousarray(image[..., ::-1]), semantic, reading


def _store_cached(folder: Path, image: np.ndarray, semantic: np.ndarray, reading: dict[str, int]) -> None:
    """Write the two PNGs and what reading found (atomically); a cache that cannot be written is skipped."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with atomic_write(folder / "reading.json") as tmp:
            tmp.write_text(json.dumps(reading), encoding="utf-8")
        for name, array in (("semantic.png", semantic), ("image.png", image[..., ::-1])):
            ok, encoded = cv2.imencode(".png", array)
            if not ok:
                return
            with atomic_write(folder / name) as tmp:
                tmp.write_bytes(encoded.tobytes())
    except OSError:
        pass


def paint_window(path: Path, where: str, frame: Frame, rules: ClassRules,
                 seed: int) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """Read an extract's window and paint it, bypassing every cache.

    Returns:
        ``(image, semantic, reading)``: (H, W, 3) uint8 RGB and (H, W) uint8 class map of
        ``frame``, and what reading found (``missing_nodes``, ``cut_ways``).
    """
    from .dress import dress
    from .paint import paint_classes

    try:
        data = read_osm(path, frame, relevant_keys(rules))
    except SceneError as exc:
        raise SceneError(f"{where}.file: {exc}") from None
    box = data.header_box or data.data_box
    if box is None:
        raise SceneError(f"{where}.file: {path} holds no map data (no road, path, area or tree)")
    if not centre_inside(box, frame.lat, frame.lon):
        raise SceneError(f"{where}.center: ({frame.lat}, {frame.lon}) lies outside the data of {path} "
                         f"(lat {box[1]:.6f}..{box[3]:.6f}, lon {box[0]:.6f}..{box[2]:.6f})")
    painted = paint_classes(data.features, rules, frame)
    if not (painted.canvas.semantic == 1).any():
        raise SceneError(f"{where}.center: no road in the {frame.width_m:g} × {frame.height_m:g} m window around "
                         f"({frame.lat}, {frame.lon}) in {path}")
    rgb = dress(painted, data.features, frame, np.random.default_rng(seed))
    return rgb, painted.canvas.semantic, {"missing_nodes": data.missing_nodes, "cut_ways": data.cut_ways}


def build_osm_scene(
    path: str | os.PathLike,
    center: Sequence[float],
    size_m: Sequence[float] = (130.0, 190.0),
    pixels_per_metre: float = 10.0,
    *,
    name: str | None = None,
    seed: int = 0,
    classes: Mapping[str, Sequence[str]] | None = None,
    rotation_deg: float = 0.0,
    cache: bool = True,
) -> Scene:
    """Build the scene of an OpenStreetMap extract around ``center``.

    Args:
        path: ``.osm``, ``.osm.pbf`` or ``.osm.bz2`` file.
        center: ``(lat, lon)`` in WGS84 degrees: the scene centre.
        size_m: ``(width, height)`` of the window in metres (east–west, north–south).
        pixels_per_metre: scale; the scene is ``round(size_m · ppm)`` pixels.
        name: scene name (default: the file name without suffixes).
        seed: the RGB's random seed (cars, roofs, trees, textures).
        classes: overrides of the tag → class mapping, class name → selectors
            (:func:`~.classes.class_rules`).
        rotation_deg: the window turned about the centre (:class:`~.read.Frame`): a road at
            bearing ``b`` (clockwise from north) runs at screen bearing ``b + rotation_deg``
            (clockwise from up); 0 is north up.
        cache: keep the result in the process and on disk (:func:`cache_folder`) and
            read it back; False builds afresh and keeps nothing.

    Returns:
        The scene (read-only arrays), camera position at the centre, 7.5 m up.

    Raises:
        SceneError: missing or unreadable file, centre outside the file's data,
            no road in the window, unknown class or bad selector in ``classes``,
            size or scale ≤ 0, a rotation that is not a finite number — the message names the file, key and value.
    """
    path = Path(path)
    name = name or path.name.split(".")[0]
    where = f"scene {name!r}: osm"
    _check_file(where, path)
    (lat, lon), (width, height), ppm = _check_numbers(where, path, center, size_m, pixels_per_metre)
    rotation = _check_rotation(where, path, rotation_deg)
    rules = class_rules(classes, f"{where}.classes ({path})")
    frame = Frame(lat, lon, width, height, ppm, rotation)
    key = _cache_key(file_sha256(path), frame, classes, int(seed))
    if not cache:
        image, semantic, _READINGS[key] = paint_window(path, where, frame, rules, int(seed))
        return _scene(name, path, frame, image, semantic)
    if key not in _MEMORY:
        built = _load_cached(cache_folder() / key)
        if built is None:
            built = paint_window(path, where, frame, rules, int(seed))
            _store_cached(cache_folder() / key, *built)
        image, semantic, _READINGS[key] = built
        _MEMORY.clear()  # scenes are large: keep one
        _MEMORY[key] = _scene(name, path, frame, image, semantic)
    scene = _MEMORY[key]
    return scene if scene.name == name else _scene(name, path, frame, scene.image, scene.semantic)


def _scene(name: str, path: Path, frame: Frame, image: np.ndarray, semantic: np.ndarray) -> Scene:
    w, h = frame.width, frame.height
    turned = f", turned (rotation_deg {frame.rotation_deg:g})" if frame.rotation_deg else ""
    return Scene(name, freeze(image), freeze(semantic), CLASS_NAMES, PALETTE, heading_deg=0.0,
                 camera_position=(w / 2, h / 2, 7.5 * frame.ppm), pixels_per_metre=frame.ppm,
                 description=f"OpenStreetMap {path.name} around ({frame.lat:.6f}, {frame.lon:.6f}), "
                             f"{frame.width_m:g} × {frame.height_m:g} m{turned}; {OSM_ATTRIBUTION} (ODbL)")


def osm_attributes(path: str | os.PathLike, center: Sequence[float], size_m: Sequence[float],
                   pixels_per_metre: float, classes: Mapping[str, Sequence[str]] | None = None,
                   seed: int = 0, rotation_deg: float = 0.0) -> dict[str, Any]:
    """What a store records about an OSM scene's source: file hash, centre, size, scale, licence,
    ``rotation_deg`` where it is not 0 (north-up stores keep their attributes),
    and what reading found: ``missing_nodes`` (nodes of the ways reaching the window that the
    extract lacks; those ways are kept as their located runs) and ``cut_ways`` (how many ways).

    The counts come from the scene's build (:func:`build_osm_scene` with the same
    arguments; built here if it was not).
    """
    path = Path(path)
    frame = Frame(float(center[0]), float(center[1]), float(size_m[0]), float(size_m[1]), float(pixels_per_metre),
                  float(rotation_deg))
    key = _cache_key(file_sha256(path), frame, classes, int(seed))
    if key not in _READINGS:
        build_osm_scene(path, center, size_m, pixels_per_metre, seed=seed, classes=classes, rotation_deg=rotation_deg)
    turn = {"rotation_deg": frame.rotation_deg} if frame.rotation_deg else {}
    return {
        "kind": "openstreetmap", "file": path.name, "sha256": file_sha256(path),
        "center": [float(c) for c in center], "size_m": [float(s) for s in size_m],
        "pixels_per_metre": float(pixels_per_metre), "classes": {k: list(v) for k, v in (classes or {}).items()},
        "seed": int(seed), **turn, "licence": OSM_LICENCE, "attribution": OSM_ATTRIBUTION, **_READINGS[key],
    }
