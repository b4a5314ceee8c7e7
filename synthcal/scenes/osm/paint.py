"""The semantic map and material map of an OSM scene, from its features (SPEC §4).

Layers are painted in :data:`~.classes.PAINT_ORDER` (later wins), each the
union of its features' geometry clipped to the window: areas as they are, lines
buffered to their width (round caps and joins, so legs meet without notches),
then the cycle strips that roads carry. Class maps are drawn without
anti-aliasing (8-connected fills, 1/16-pixel vertex precision), so they only
hold the ids written; a polygon and its holes are filled in one ``cv2`` call.

Everything is computed in frame metres and moved to pixels last.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import shapely

from ..network import Material
from ..roadkit import SHIFT, Canvas
from .classes import PAINT_ORDER, ClassRules, Strip, classify, line_width, strips
from .read import Feature, Frame

__all__ = ["GREEN_BIKE", "WATER", "Road", "Painted", "paint_classes", "fill_geometry", "material_of"]

GREEN_BIKE, WATER = 8, 9  # material ids beyond network.Material


@dataclass(frozen=True)
class Road:
    """A carriageway: its centre line and half width (m), tags, and its polygon (m)."""

    line: Any
    half_width: float
    tags: dict[str, str]
    polygon: Any


@dataclass
class Painted:
    """What :func:`paint_classes` produced.

    Attributes:
        canvas: semantic, material and bicycle-trace maps.
        roads: the carriageways (lines of class road), in file order.
        layers: the painted geometry per step, in frame metres (for tests and the RGB).
    """

    canvas: Canvas
    roads: list[Road] = field(default_factory=list)
    layers: dict[str, Any] = field(default_factory=dict)


def material_of(class_id: int, tags: dict[str, str]) -> int:
    """The material a feature of ``class_id`` is drawn with."""
    if class_id == 1:
        return Material.ASPHALT
    if class_id == 2:
        return Material.GRASS
    if class_id == 3:
        return GREEN_BIKE if _green(tags) else Material.BIKE
    if tags.get("natural") == "water" or tags.get("waterway") == "riverbank":
        return WATER
    if tags.get("amenity") == "parking":
        return Material.PARKING
    if "building" in tags or "building:part" in tags:
        return Material.CONCRETE
    if tags.get("surface") in ("sett", "cobblestone", "paving_stones"):
        return Material.COBBLES
    return Material.SIDEWALK


def _green(tags: dict[str, str]) -> bool:
    colour = tags.get("surface:colour") or tags.get("cycleway:surface:colour") or tags.get("colour") or ""
    return colour.lower() == "green"


def fill_geometry(canvas: Canvas, geometry: Any, class_id: int, material: int) -> None:
    """Fill a (multi)polygon given in pixels into the class, material and bicycle-trace maps."""
    for polygon in shapely.get_parts(geometry):
        if polygon.is_empty or polygon.geom_type != "Polygon":
            continue
        rings = [polygon.exterior, *polygon.interiors]
        pts = [np.round(np.asarray(r.coords)[:, :2] * (1 << SHIFT)).astype(np.int32) for r in rings]
        cv2.fillPoly(canvas.semantic, pts, int(class_id), cv2.LINE_8, SHIFT)
        cv2.fillPoly(canvas.material, pts, int(material), cv2.LINE_8, SHIFT)
        if class_id == 3:
            cv2.fillPoly(canvas.bike_trace, pts, 1, cv2.LINE_8, SHIFT)


def _shape(feature: Feature, class_id: int) -> Any:
    """A feature's painted area in metres: areas as they are, lines buffered to their width."""
    if feature.kind == "area":
        return feature.geometry
    if feature.kind == "line":
        return feature.geometry.buffer(line_width(feature.tags, class_id) / 2, quad_segs=4)
    return None


def _band(line: Any, strip: Strip) -> Any:
    """The strip ``near ≤ lateral ≤ far`` on one side of ``line`` (single-sided buffers: + left, − right)."""
    outer = line.buffer(strip.side * strip.far, single_sided=True)
    if strip.near <= 1e-9:
        return outer
    return outer.difference(line.buffer(strip.side * strip.near, single_sided=True))


def _sidewalks(road: Road) -> list[Any]:
    """Pavement strips (class 0) the road's ``sidewalk`` tag asks for."""
    value = road.tags.get("sidewalk", "")
    sides = {"both": (1, -1), "left": (1,), "right": (-1,)}.get(value, ())
    return [_band(road.line, Strip(side, road.half_width, road.half_width + 2.0, "walk")) for side in sides]


def _group(shapes: Iterable[tuple[int, Any]]) -> dict[int, Any]:
    """Union of shapes per material, materials in first-seen order."""
    parts: dict[int, list[Any]] = {}
    for material, shape in shapes:
        parts.setdefault(material, []).append(shape)
    return {material: shapely.union_all(items) for material, items in parts.items()}


def _layer_shapes(features: list[Feature], rules: ClassRules, class_id: int, roads: list[Road]) -> list[tuple[int, Any]]:
    """(material, shape) of every feature painted as ``class_id``; collects the roads."""
    out = []
    for feature in features:
        if classify(feature.tags, rules) != class_id:
            continue
        shape = _shape(feature, class_id)
        if shape is None or shape.is_empty:
            continue
        out.append((material_of(class_id, feature.tags), shape))
        if class_id == 1 and feature.kind == "line":
            roads.append(Road(feature.geometry, line_width(feature.tags, 1) / 2, feature.tags, shape))
    return out


def _strip_shapes(roads: list[Road]) -> list[tuple[int, Any]]:
    """Cycle strips of every road, each minus the *other* roads' carriageways."""
    out = []
    for k, road in enumerate(roads):
        bands = strips(road.tags, road.half_width)
        if not bands:
            continue
        others = shapely.union_all([r.polygon for i, r in enumerate(roads) if i != k])
        for strip in bands:
            band = _band(road.line, strip)
            if strip.kind == "track":
                band = band.difference(road.polygon)
            band = band.difference(others) if not others.is_empty else band
            out.append((GREEN_BIKE if _green(road.tags) else Material.BIKE, band))
    return out


def paint_classes(features: list[Feature], rules: ClassRules, frame: Frame) -> Painted:
    """Paint the class and material maps of the window.

    Args:
        features: what :func:`~.read.read_osm` found.
        rules: the tag → class selectors.
        frame: the scene's frame.

    Returns:
        The canvas, the carriageways and the painted layers (in metres).
    """
    canvas = Canvas(frame.width, frame.height, 0, Material.COURTYARD)
    painted = Painted(canvas)
    clip = frame.window(1.0 / frame.ppm)
    for class_id in PAINT_ORDER:
        shapes = _layer_shapes(features, rules, class_id, painted.roads)
        if class_id == 0:  # pavements along roads belong to the background layer
            tags_roads = [Road(f.geometry, line_width(f.tags, 1) / 2, f.tags, None) for f in features
                          if f.kind == "line" and classify(f.tags, rules) == 1]
            shapes += [(Material.SIDEWALK, s) for road in tags_roads for s in _sidewalks(road)]
        _paint(painted, str(class_id), shapes, class_id, clip, frame)
    _paint(painted, "strips", _strip_shapes(painted.roads), 3, clip, frame)
    return painted


def _paint(painted: Painted, name: str, shapes: list[tuple[int, Any]], class_id: int, clip: Any, frame: Frame) -> None:
    """Union, clip and fill one layer; record its geometry (metres) under ``name``."""
    union = []
    for material, shape in _group(shapes).items():
        shape = shape.intersection(clip)
        if shape.is_empty:
            continue
        fill_geometry(painted.canvas, frame.to_pixels(shape), class_id, material)
        union.append(shape)
    painted.layers[name] = shapely.union_all(union) if union else shapely.Polygon()
