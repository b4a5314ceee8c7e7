"""Appearance of the bird's-eye RGB: textures and distractors absent from the class map.

Textures come from a material map (finer than the classes: pavement and courtyards
differ, a car park is class 0 but looks like asphalt). Distractors — cars, roofs,
trees, shadows — are painted on the RGB only, so the class map never sees them.

Determinism: every random draw comes from the scene's own ``np.random.Generator``
in a fixed order, and all pixel arithmetic is integer (bit-exact ``cv2`` 8-bit
resizes and box filters, integer blends), so the RGB is bit-identical on every
machine.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .roadkit import SHIFT, Point, circle, fixed

__all__ = ["MaterialLook", "base_colours", "add_grain", "shade", "fill_rgb", "Building", "place_buildings",
           "draw_building", "building_shadow", "Tree", "draw_tree", "Car", "draw_car", "car_outline", "cars_on_road", "CAR_COLOURS"]


@dataclass(frozen=True)
class MaterialLook:
    """A material's appearance: colour drifts from ``a`` to ``b`` with low-frequency noise."""

    a: tuple[int, int, int]
    b: tuple[int, int, int]
    grain: int  # amplitude of per-pixel luminance noise, grey levels


def _low_noise(shape: tuple[int, int], cell: int, rng: np.random.Generator) -> np.ndarray:
    """(H, W) uint8 smooth noise with features of about ``cell`` px (bit-exact resize)."""
    h, w = shape
    small = rng.integers(0, 256, (h // cell + 2, w // cell + 2), dtype=np.uint8)
    big = cv2.resize(small, ((w // cell + 2) * cell, (h // cell + 2) * cell), interpolation=cv2.INTER_LINEAR_EXACT)
    return big[:h, :w]


def base_colours(material: np.ndarray, looks: Sequence[MaterialLook], rng: np.random.Generator) -> np.ndarray:
    """Per-material colours with blotchy low-frequency variation and soft borders.

    Args:
        material: (H, W) uint8 material ids, indices into ``looks``.
        looks: appearance per material id.
        rng: the scene's generator.

    Returns:
        (H, W, 3) uint8 RGB.
    """
    low = (_low_noise(material.shape, 64, rng).astype(np.uint16) * 3 + _low_noise(material.shape, 12, rng)) >> 2
    a = np.array([m.a for m in looks], np.int32)[material]
    b = np.array([m.b for m in looks], np.int32)[material]
    rgb = a + (((b - a) * low[..., None].astype(np.int32)) >> 8)
    # a 3 × 3 box filter softens the aliased class borders in the RGB only
    return cv2.blur(rgb.astype(np.uint8), (3, 3))


def add_grain(rgb: np.ndarray, material: np.ndarray, looks: Sequence[MaterialLook], rng: np.random.Generator) -> None:
    """Add per-pixel luminance noise of the material's amplitude to ``rgb`` (in place)."""
    amp = np.array([m.grain for m in looks], np.int32)[material]
    noise = (rng.integers(-128, 128, material.shape, dtype=np.int32) * amp) >> 7
    rgb[...] = np.clip(rgb.astype(np.int32) + noise[..., None], 0, 255).astype(np.uint8)


def shade(rgb: np.ndarray, mask: np.ndarray, strength: int) -> None:
    """Darken ``rgb`` in place by up to ``strength``/256 where ``mask`` (uint8) is 255."""
    soft = cv2.blur(mask, (5, 5))
    factor = 256 - ((soft.astype(np.uint32) * strength) >> 8)
    rgb[...] = ((rgb.astype(np.uint32) * factor[..., None]) >> 8).astype(np.uint8)


def fill_rgb(rgb: np.ndarray, points: Sequence[Point], colour: Sequence[int] | np.ndarray | int) -> None:
    """Anti-aliased polygon on the RGB (``colour``: (3,) values) or a uint8 mask (a single value)."""
    value = tuple(int(v) for v in np.ravel(colour)) if np.ndim(colour) else int(np.asarray(colour))
    cv2.fillPoly(rgb, [fixed(points)], value, cv2.LINE_AA, SHIFT)


def _box(centre: Point, angle_deg: float, length: float, width: float) -> list[Point]:
    """Corners of a rectangle centred at ``centre``, its length along ``angle_deg``."""
    e = (math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)))
    n = (-e[1], e[0])
    hl, hw = length / 2, width / 2
    return [(centre[0] + sl * hl * e[0] + sw * hw * n[0], centre[1] + sl * hl * e[1] + sw * hw * n[1])
            for sl, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def _local(centre: Point, angle_deg: float, pts: Sequence[tuple[float, float]]) -> list[Point]:
    """Local (along, across) coordinates → image points."""
    e = (math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg)))
    return [(centre[0] + x * e[0] - y * e[1], centre[1] + x * e[1] + y * e[0]) for x, y in pts]


# --------------------------------------------------------------------------- buildings
ROOFS = ((158, 72, 52), (128, 60, 48), (72, 74, 80), (58, 62, 72), (112, 84, 64), (176, 176, 170),
         (166, 156, 136), (210, 210, 204), (96, 108, 94), (92, 102, 118), (140, 96, 70))


@dataclass(frozen=True)
class Building:
    """A footprint (image points), its height in px and its roof."""

    corners: tuple[Point, ...]
    angle: float
    height: float
    roof: tuple[int, int, int]
    kind: str  # "gable" or "flat"


def place_buildings(free: np.ndarray, rng: np.random.Generator, tries: int, angles: Sequence[float],
                    ppm: float, margin_m: float = 1.5) -> list[Building]:
    """Drop buildings at random where ``free`` allows, never overlapping.

    Args:
        free: (H, W) bool, True where a building may stand; updated in place.
        rng: the scene's generator.
        tries: candidate count (each accepted or rejected).
        angles: orientations to choose from (usually the legs' angles).
        ppm: pixels per metre.
        margin_m: gap kept around each building.

    Returns:
        The accepted buildings.
    """
    h, w = free.shape
    grow = int(round(margin_m * ppm))
    out = []
    for _ in range(tries):
        x, y = rng.uniform(0, w), rng.uniform(0, h)
        angle = float(angles[int(rng.integers(len(angles)))]) + (90.0 if rng.uniform() < 0.5 else 0.0)
        length, depth = rng.uniform(12, 38) * ppm, rng.uniform(8, 16) * ppm
        height = rng.uniform(5, 22) * ppm
        roof, kind = ROOFS[int(rng.integers(len(ROOFS)))], ("gable" if rng.uniform() < 0.55 else "flat")
        corners = _box((x, y), angle, length, depth)
        pts = fixed(corners)
        bx, by, bw, bh = cv2.boundingRect(pts >> SHIFT)
        x0, y0, x1, y1 = max(bx - grow, 0), max(by - grow, 0), min(bx + bw + grow + 1, w), min(by + bh + grow + 1, h)
        if x1 - x0 < bw + 2 * grow or y1 - y0 < bh + 2 * grow:
            continue  # touches the border: keep buildings whole
        local = np.zeros((y1 - y0, x1 - x0), np.uint8)
        shifted = pts - np.array([x0, y0], np.int32) * (1 << SHIFT)
        cv2.fillPoly(local, [shifted], 1, cv2.LINE_8, SHIFT)
        cv2.polylines(local, [shifted], True, 1, 2 * grow + 1, cv2.LINE_8, SHIFT)
        if np.any(local.astype(bool) & ~free[y0:y1, x0:x1]):
            continue
        free[y0:y1, x0:x1] &= ~local.astype(bool)
        out.append(Building(tuple(corners), angle, height, roof, kind))
    return out


def building_shadow(b: Building, sun: Point) -> list[Point]:
    """Shadow of an extruded footprint: hull of the footprint and its projection."""
    pts = list(b.corners) + [(x + sun[0] * b.height, y + sun[1] * b.height) for x, y in b.corners]
    hull = cv2.convexHull(np.asarray(pts, np.float32))[:, 0, :]
    return [(float(x), float(y)) for x, y in hull]


def draw_building(rgb: np.ndarray, b: Building, rng: np.random.Generator, ppm: float) -> None:
    """Roof seen from above: two lit/shaded planes and a ridge, or flat with a parapet."""
    p = b.corners
    roof = np.array(b.roof, np.int32)
    lit, dark = np.clip(roof * 17 // 16, 0, 255), roof * 12 // 16
    if b.kind == "gable":
        m0, m1 = ((p[0][0] + p[3][0]) / 2, (p[0][1] + p[3][1]) / 2), ((p[1][0] + p[2][0]) / 2, (p[1][1] + p[2][1]) / 2)
        fill_rgb(rgb, [p[0], p[1], m1, m0], lit)
        fill_rgb(rgb, [m0, m1, p[2], p[3]], dark)
        cv2.line(rgb, tuple(fixed([m0])[0]), tuple(fixed([m1])[0]), tuple(int(v) for v in roof * 9 // 16), 2,
                 cv2.LINE_AA, SHIFT)
    else:
        fill_rgb(rgb, p, roof * 14 // 16)
        inset = 0.6 * ppm
        cx, cy = sum(q[0] for q in p) / 4, sum(q[1] for q in p) / 4
        inner = []
        for x, y in p:  # corners pulled toward the centre by the parapet width
            k = inset / max(math.hypot(cx - x, cy - y), 1.0)
            inner.append((x + (cx - x) * k, y + (cy - y) * k))
        fill_rgb(rgb, inner, roof)
        for _ in range(int(rng.integers(0, 4))):  # rooftop units
            u, v = rng.uniform(0.2, 0.8), rng.uniform(0.25, 0.75)
            x = p[0][0] + u * (p[1][0] - p[0][0]) + v * (p[3][0] - p[0][0])
            y = p[0][1] + u * (p[1][1] - p[0][1]) + v * (p[3][1] - p[0][1])
            unit_box = _box((x, y), b.angle, rng.uniform(1.5, 3.5) * ppm, rng.uniform(1.2, 2.5) * ppm)
            fill_rgb(rgb, unit_box, (150, 150, 152))


# --------------------------------------------------------------------------- trees
@dataclass(frozen=True)
class Tree:
    """A crown of ``radius`` px at ``centre``; ``height`` px sets its shadow."""

    centre: Point
    radius: float
    height: float


def draw_tree(rgb: np.ndarray, t: Tree, rng: np.random.Generator) -> None:
    """A dark crown with lighter clumps, lit from the side opposite the shadow."""
    base = np.array((46, 78, 34), np.int32) + rng.integers(-8, 9, 3)
    fill_rgb(rgb, circle(t.centre, t.radius, 12.0), base)
    for _ in range(7):
        a, d = rng.uniform(0, 2 * math.pi), rng.uniform(0, 0.6) * t.radius
        r = rng.uniform(0.3, 0.5) * t.radius
        tone = base + rng.integers(5, 30)
        fill_rgb(rgb, circle((t.centre[0] + d * math.cos(a), t.centre[1] + d * math.sin(a)), r, 20.0), tone)


# --------------------------------------------------------------------------- cars
CAR_COLOURS = ((225, 225, 222), (20, 22, 26), (150, 152, 156), (175, 30, 30), (30, 60, 140), (90, 92, 98),
               (200, 200, 195), (40, 90, 60), (215, 170, 40), (110, 20, 30), (60, 110, 170))


@dataclass(frozen=True)
class Car:
    """A car at ``centre`` heading along ``angle`` (degrees), sizes in px."""

    centre: Point
    angle: float
    length: float
    width: float
    colour: tuple[int, int, int]


def car_outline(car: Car) -> list[Point]:
    """Body outline with chamfered corners."""
    L, W, k = car.length / 2, car.width / 2, car.width * 0.18
    return _local(car.centre, car.angle, [(-L + k, -W), (L - k, -W), (L, -W + k), (L, W - k), (L - k, W),
                                          (-L + k, W), (-L, W - k), (-L, -W + k)])


def cars_on_road(cars: Sequence[Car], semantic: np.ndarray) -> list[Car]:
    """The cars wholly on road (class 1 of ``semantic``, (H, W)) and clear of an earlier kept one, in order."""
    h, w = semantic.shape
    kept: list[Car] = []
    for car in cars:
        pts = np.round(np.asarray(car_outline(car) + [car.centre])).astype(int)
        inside = (pts[:, 0] >= 0) & (pts[:, 0] < w) & (pts[:, 1] >= 0) & (pts[:, 1] < h)
        if not inside.all() or np.any(semantic[pts[:, 1], pts[:, 0]] != 1):
            continue
        if any(math.hypot(car.centre[0] - o.centre[0], car.centre[1] - o.centre[1]) < 0.55 * (car.length + o.length)
               for o in kept):
            continue
        kept.append(car)
    return kept


def draw_car(rgb: np.ndarray, car: Car) -> None:
    """Body, darker windscreen and rear window, slightly lighter roof."""
    L, W = car.length / 2, car.width / 2
    body = np.array(car.colour, np.int32)
    glass = (38, 44, 52)
    fill_rgb(rgb, car_outline(car), body)
    fill_rgb(rgb, _local(car.centre, car.angle, [(0.12 * L, -0.82 * W), (0.5 * L, -0.88 * W), (0.5 * L, 0.88 * W),
                                                   (0.12 * L, 0.82 * W)]), glass)
    fill_rgb(rgb, _local(car.centre, car.angle, [(-0.78 * L, -0.8 * W), (-0.5 * L, -0.82 * W), (-0.5 * L, 0.82 * W),
                                                   (-0.78 * L, 0.8 * W)]), glass)
    fill_rgb(rgb, _local(car.centre, car.angle, [(-0.5 * L, -0.75 * W), (0.12 * L, -0.75 * W), (0.12 * L, 0.75 * W),
                                                   (-0.5 * L, 0.75 * W)]), np.clip(body + 14, 0, 255))
