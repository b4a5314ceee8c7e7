"""The RGB of an OSM scene: the procedural scenes' material kit on real geometry.

Textures come from the material map (:mod:`..dressing`); on top, RGB only:
lane lines (from ``lanes``), stop lines where roads meet, zebra crossings
(``highway=crossing`` nodes and ``footway=crossing`` ways), red (or, where
tagged, green) cycle surfaces and red cycle crossings, kerbs, roofs with shadows
(``building``), trees (``natural=tree`` nodes, ``natural=tree_row`` ways and a
seeded scatter on wide grass) and cars on the lanes — distractors the class map
never sees. Right-hand traffic. All randomness from one seeded generator, in a
fixed order.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
import shapely
from shapely.ops import substring

from ..dressing import (
    CAR_COLOURS,
    ROOFS,
    Car,
    MaterialLook,
    Tree,
    add_grain,
    base_colours,
    car_outline,
    cars_on_road,
    draw_car,
    draw_tree,
    fill_rgb,
    shade,
)
from ..intersection import LOOKS as KIT_LOOKS
from ..roadkit import SHIFT, Point, circle
from .classes import LANE_WIDTH, parse_metres
from .paint import Painted, Road
from .read import Feature, Frame

__all__ = ["LOOKS", "dress"]

LOOKS = KIT_LOOKS + (
    MaterialLook((70, 128, 80), (92, 150, 98), 8),  # green cycle surface
    MaterialLook((58, 86, 112), (74, 104, 128), 4),  # water
)
WHITE = (226, 226, 220)


# --------------------------------------------------------------------------- geometry helpers (metres)
def _tangent(line: Any, s: float) -> tuple[float, float]:
    """Unit direction of ``line`` at arc length ``s``."""
    length = line.length
    a, b = line.interpolate(max(s - 0.5, 0.0)), line.interpolate(min(s + 0.5, length))
    dx, dy = b.x - a.x, b.y - a.y
    norm = math.hypot(dx, dy) or 1.0
    return dx / norm, dy / norm


def _rect(centre: tuple[float, float], t: tuple[float, float], along: float, across: float) -> shapely.Polygon:
    """A rectangle (metres) centred at ``centre``, ``along`` long in direction ``t``, ``across`` wide."""
    n = (-t[1], t[0])
    a, c = along / 2, across / 2
    return shapely.Polygon([(centre[0] + sa * a * t[0] + sc * c * n[0], centre[1] + sa * a * t[1] + sc * c * n[1])
                            for sa, sc in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def _lanes(road: Road) -> int:
    try:
        lanes = int(road.tags.get("lanes", ""))
    except ValueError:
        lanes = 0
    return lanes if lanes > 0 else max(1, int(round(2 * road.half_width / LANE_WIDTH)))


# --------------------------------------------------------------------------- markings
def _lane_lines(road: Road, window: Any) -> list[Any]:
    """Dashed lines between the lanes (3 m dashes, 6 m gaps, 0.12 m wide) inside ``window``."""
    lanes, out = _lanes(road), list[Any]()
    if lanes < 2 or road.line.length < 1.0:
        return out
    for k in range(1, lanes):
        lateral = -road.half_width + 2 * road.half_width * k / lanes
        offset = road.line.offset_curve(lateral) if abs(lateral) > 1e-6 else road.line
        for part in shapely.get_parts(offset.intersection(window)):
            if part.geom_type != "LineString":
                continue
            for s in np.arange(1.0, part.length, 9.0):
                out.append(substring(part, float(s), float(min(s + 3.0, part.length))).buffer(0.06))
    return out


def _junctions(roads: list[Road]) -> dict[tuple[float, float], list[int]]:
    """Road vertices of degree ≥ 3 (ways share their junction nodes) → the roads through them."""
    degree: dict[tuple[float, float], int] = {}
    members: dict[tuple[float, float], list[int]] = {}
    for k, road in enumerate(roads):
        coords = [(round(x, 2), round(y, 2)) for x, y in road.line.coords]
        for i, key in enumerate(coords):
            degree[key] = degree.get(key, 0) + (1 if i in (0, len(coords) - 1) else 2)
            members.setdefault(key, []).append(k)
    return {key: members[key] for key, d in degree.items() if d >= 3 and len(set(members[key])) >= 2}


def _stop_lines(roads: list[Road]) -> list[Any]:
    """A 0.4 m bar across the inbound half of every arm, just outside the junction box."""
    out = []
    for point, ids in _junctions(roads).items():
        for k in sorted(set(ids)):
            road = roads[k]
            others = max((roads[i].half_width for i in set(ids) if i != k), default=0.0)
            s0 = road.line.project(shapely.Point(point))
            for sign in (-1.0, 1.0):
                s = s0 + sign * (others + 1.5)
                if not 0.0 < s < road.line.length:
                    continue
                t = _tangent(road.line, s)
                arm = (sign * t[0], sign * t[1])  # pointing away from the junction
                left = (-arm[1], arm[0])  # inbound traffic (driving on the right) uses this half
                p = road.line.interpolate(s)
                centre = (p.x + left[0] * road.half_width / 2, p.y + left[1] * road.half_width / 2)
                out.append(_rect(centre, left, road.half_width, 0.4))
    return out


def _crossing_points(features: list[Feature], road_union: Any) -> list[tuple[float, float]]:
    """Where zebras go: ``highway=crossing`` nodes and the middle of each ``footway=crossing`` way on the road."""
    points = []
    for f in features:
        marked = f.tags.get("crossing", "marked") not in ("unmarked", "no", "informal")
        if f.kind == "point" and f.tags.get("highway") == "crossing" and marked:
            points.append((f.geometry.x, f.geometry.y))
        elif f.kind == "line" and f.tags.get("footway") == "crossing" and marked and not road_union.is_empty:
            for piece in shapely.get_parts(f.geometry.intersection(road_union)):
                if piece.length > 0.5:
                    mid = piece.interpolate(0.5, normalized=True)
                    points.append((mid.x, mid.y))
    return points


def _zebras(points: list[tuple[float, float]], roads: list[Road]) -> list[Any]:
    """Zebra stripes: bars along the road, 3 m long, 0.5 m wide, 0.5 m apart, across the carriageway."""
    out: list[Any] = []
    seen: list[tuple[float, float]] = []
    for p in points:
        if any(math.hypot(p[0] - q[0], p[1] - q[1]) < 3.0 for q in seen):
            continue  # a crossing node and its footway=crossing way
        seen.append(p)
        near = [(r.line.distance(shapely.Point(p)), r) for r in roads]
        near = [(d, r) for d, r in near if d <= r.half_width + 1.0]
        if not near:
            continue
        _, road = min(near, key=lambda item: item[0])
        s = road.line.project(shapely.Point(p))
        t, c = _tangent(road.line, s), road.line.interpolate(s)
        n = (-t[1], t[0])
        for lateral in np.arange(-road.half_width + 0.5, road.half_width - 0.2, 1.0):
            out.append(_rect((c.x + n[0] * lateral, c.y + n[1] * lateral), t, 3.0, 0.5))
    return out


def _mask(shapes: list[Any], frame: Frame) -> np.ndarray:
    """Anti-aliased uint8 mask (0..255) of polygons given in metres."""
    mask = np.zeros((frame.height, frame.width), np.uint8)
    if shapes:
        union = frame.to_pixels(shapely.union_all(shapes).intersection(frame.window(2.0)))
        for polygon in shapely.get_parts(union):
            if polygon.geom_type == "Polygon" and not polygon.is_empty:
                rings = [polygon.exterior, *polygon.interiors]
                pts = [np.round(np.asarray(r.coords)[:, :2] * (1 << SHIFT)).astype(np.int32) for r in rings]
                cv2.fillPoly(mask, pts, 255, cv2.LINE_AA, SHIFT)
    return mask


def _blend(rgb: np.ndarray, mask: np.ndarray, colour: tuple[int, int, int]) -> None:
    """``rgb`` toward ``colour`` by ``mask``/255 (integer arithmetic, in place)."""
    m = mask.astype(np.int32)[..., None]
    rgb[...] = ((rgb.astype(np.int32) * (255 - m) + np.array(colour, np.int32) * m) // 255).astype(np.uint8)


def _junction_mask(painted: Painted, frame: Frame) -> np.ndarray:
    """Pixels covered by two or more carriageways, grown by 1 m: no lane lines there."""
    count = np.zeros((frame.height, frame.width), np.uint8)
    for road in painted.roads:
        count += (_mask([road.polygon], frame) > 127).astype(np.uint8)
    grow = max(1, int(round(frame.ppm)))
    return cv2.dilate((count >= 2).astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)).astype(bool)


def _markings(rgb: np.ndarray, painted: Painted, features: list[Feature], frame: Frame) -> None:
    """Lane lines (not inside junctions), stop lines and zebras, white on the RGB."""
    window = frame.window(2.0)
    lines = [d for road in painted.roads for d in _lane_lines(road, window)]
    mask = _mask(lines, frame)
    mask[_junction_mask(painted, frame)] = 0
    _blend(rgb, mask, WHITE)
    zebras = _zebras(_crossing_points(features, painted.layers.get("1", shapely.Polygon())), painted.roads)
    mask = _mask(_stop_lines(painted.roads) + zebras, frame)
    mask[painted.canvas.semantic != 1] = 0  # on the carriageway only
    _blend(rgb, mask, WHITE)


# --------------------------------------------------------------------------- cars
def _image_angle(t: tuple[float, float]) -> float:
    """Image angle (degrees, 0 = +u, 90 = +v) of a metric direction ``(E, N)``."""
    return math.degrees(math.atan2(-t[1], t[0]))


def _lane_cars(road: Road, frame: Frame, rng: np.random.Generator) -> list[Car]:
    """Candidate cars along every lane of a road (right-hand traffic)."""
    lanes, out = _lanes(road), []
    oneway = road.tags.get("oneway", "no")
    for k in range(lanes):
        lateral = -road.half_width + 2 * road.half_width * (k + 0.5) / lanes
        forward = oneway in ("yes", "true", "1") or (oneway != "-1" and lateral < 0)
        s = rng.uniform(2.0, 12.0)
        while s < road.line.length - 3.0:
            length = rng.uniform(4.0, 5.0) if rng.uniform() < 0.9 else 6.5
            if rng.uniform() < 0.45:
                t = _tangent(road.line, s)
                p = road.line.interpolate(s)
                centre = frame.pixels(p.x - t[1] * lateral, p.y + t[0] * lateral)
                heading = _image_angle(t) + (0.0 if forward else 180.0)
                out.append(Car((float(centre[0]), float(centre[1])), heading, length * frame.ppm,
                               rng.uniform(1.75, 2.0) * frame.ppm, CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]))
            s += length + rng.uniform(5.0, 30.0)
    return out


# --------------------------------------------------------------------------- trees and buildings
def _trees(features: list[Feature], semantic: np.ndarray, frame: Frame, rng: np.random.Generator) -> list[Tree]:
    """Mapped trees and tree rows, then a seeded scatter on grass at least 3.5 m from anything else."""
    ppm, trees = frame.ppm, []
    spots: list[tuple[float, float, dict[str, str]]] = []
    for f in features:
        if f.kind == "point" and f.tags.get("natural") == "tree":
            spots.append((f.geometry.x, f.geometry.y, f.tags))
        elif f.kind == "line" and f.tags.get("natural") == "tree_row":
            spots += [(p.x, p.y, f.tags) for p in (f.geometry.interpolate(s) for s in np.arange(2.0, f.geometry.length,
                                                                                               8.0))]
    for x, y, tags in spots:
        crown = parse_metres(tags.get("diameter_crown"))
        radius = crown / 2 if crown else rng.uniform(2.5, 4.0)
        height = parse_metres(tags.get("height")) or rng.uniform(7.0, 12.0)
        u, v = frame.pixels(x, y)
        trees.append(Tree((float(u), float(v)), radius * ppm, height * ppm))
    step = 4
    grass = (semantic[::step, ::step] == 2).astype(np.uint8)
    size = int(7 * ppm / step) | 1
    wide = cv2.erode(grass, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)))
    h, w = semantic.shape
    for _ in range(int(frame.width_m * frame.height_m / 60)):
        x, y = rng.uniform(0, w), rng.uniform(0, h)
        radius, height = rng.uniform(2.5, 5.0) * ppm, rng.uniform(6, 14) * ppm
        apart = all(math.hypot(x - t.centre[0], y - t.centre[1]) > 0.9 * (radius + t.radius) for t in trees)
        if wide[min(int(y) // step, wide.shape[0] - 1), min(int(x) // step, wide.shape[1] - 1)] and apart:
            trees.append(Tree((x, y), radius, height))
    return trees


def _buildings(features: list[Feature], frame: Frame) -> list[tuple[Any, float]]:
    """(footprint in pixels, height in px) of every building."""
    out = []
    clip = frame.window(5.0)
    for f in features:
        if f.kind != "area" or ("building" not in f.tags and "building:part" not in f.tags):
            continue
        levels = parse_metres(f.tags.get("building:levels"))
        height = parse_metres(f.tags.get("height")) or (3.0 * levels if levels else 9.0)
        shape = f.geometry.intersection(clip)
        if not shape.is_empty:
            out.append((frame.to_pixels(shape), height * frame.ppm))
    return out


def _polygons(geometry: Any) -> list[list[Point]]:
    """Exterior rings (pixels) of a geometry's polygons."""
    return [[(float(x), float(y)) for x, y in np.asarray(p.exterior.coords)[:, :2]]
            for p in shapely.get_parts(geometry) if p.geom_type == "Polygon" and not p.is_empty]


def _shadow(mask: np.ndarray, footprint: Any, offset: Point) -> None:
    """An extruded footprint's shadow: the footprint moved by ``offset`` and the quads its edges sweep."""
    for ring in _polygons(footprint):
        fill_rgb(mask, ring, 255)
        fill_rgb(mask, [(x + offset[0], y + offset[1]) for x, y in ring], 255)
        for a, b in zip(ring[:-1], ring[1:], strict=True):
            fill_rgb(mask, [a, b, (b[0] + offset[0], b[1] + offset[1]), (a[0] + offset[0], a[1] + offset[1])], 255)


def _roof(rgb: np.ndarray, footprint: Any, rng: np.random.Generator, ppm: float) -> None:
    """A flat roof: darker parapet, the roof inset 0.6 m."""
    roof = np.array(ROOFS[int(rng.integers(len(ROOFS)))], np.int32)
    for ring in _polygons(footprint):
        fill_rgb(rgb, ring, roof * 13 // 16)
    for ring in _polygons(footprint.buffer(-0.6 * ppm, join_style="mitre")):
        fill_rgb(rgb, ring, roof)


# --------------------------------------------------------------------------- the RGB
def dress(painted: Painted, features: list[Feature], frame: Frame, rng: np.random.Generator) -> np.ndarray:
    """The scene's RGB (H, W, 3) uint8 from its painted maps and features."""
    canvas, ppm = painted.canvas, frame.ppm
    rgb = base_colours(canvas.material, LOOKS, rng)
    crossing = (canvas.bike_trace == 1) & (canvas.semantic == 1)  # red cycle crossings over the road
    red = np.array([150, 58, 52], np.uint16) * 5
    rgb[crossing] = ((rgb[crossing].astype(np.uint16) * 3 + red) >> 3).astype(np.uint8)
    _markings(rgb, painted, features, frame)
    add_grain(rgb, canvas.material, LOOKS, rng)
    road = (canvas.semantic == 1).astype(np.uint8)
    kerb = (road - cv2.erode(road, np.ones((3, 3), np.uint8))).astype(bool)
    rgb[kerb] = ((rgb[kerb].astype(np.uint16) + 170) >> 1).astype(np.uint8)

    azimuth = math.radians(rng.uniform(200, 245))
    sun = (0.85 * math.cos(azimuth), 0.85 * math.sin(azimuth))
    candidates = [car for r in painted.roads for car in _lane_cars(r, frame, rng)]
    cars = cars_on_road(candidates, canvas.semantic)
    mask = np.zeros(canvas.semantic.shape, np.uint8)
    for car in cars:
        fill_rgb(mask, [(x + sun[0] * 1.2 * ppm, y + sun[1] * 1.2 * ppm) for x, y in car_outline(car)], 255)
    shade(rgb, mask, 120)
    for car in cars:
        draw_car(rgb, car)
    buildings = _buildings(features, frame)
    trees = _trees(features, canvas.semantic, frame, rng)
    mask[...] = 0
    for footprint, height in buildings:
        _shadow(mask, footprint, (sun[0] * height, sun[1] * height))
    for t in trees:
        fill_rgb(mask, circle((t.centre[0] + sun[0] * t.height, t.centre[1] + sun[1] * t.height), t.radius, 15.0), 255)
    shade(rgb, mask, 105)
    for footprint, _ in buildings:
        _roof(rgb, footprint, rng, ppm)
    for t in trees:
        draw_tree(rgb, t, rng)
    return rgb
