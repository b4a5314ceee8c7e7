"""A small toolkit that paints road networks into a class map and a material map.

Geometry is described in bird's-eye pixels around a junction centre ``c``. A leg
leaves the centre at image angle ``a`` (0 = +u, 90 = +v, i.e. clockwise on the
screen) with unit direction ``e`` and right-hand normal ``n = (-sin a, cos a)``; a
point of the leg is ``c + s·e + l·n`` (``s`` along, ``l`` across, ``l > 0`` on the
side that faces the next leg clockwise).

Everything is painted as *nested layers*, outermost first, so that the union of
straight strips from the centre produces mitred corners without any polygon
clipping: pavement (class 0) → verges (2) → bicycle-path bands (3) → roads (1) →
islands (medians, splitters, roundabout island: 2 or 0). Bicycle paths are bands
(not nested strips) so that they run on, across the neighbouring leg's verge, up
to its kerb — the Dutch layout with the bicycle crossing at the junction mouth.

Class maps are drawn without anti-aliasing (8-connected fills with 1/16-pixel
vertex precision), so they only ever hold the ids written. All trigonometry uses
``math`` on Python floats (correctly rounded libm calls), never SIMD numpy
kernels, so the rasterised vertices are the same on every machine.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import cv2
import numpy as np

__all__ = [
    "FAR", "Point", "unit", "normal", "at", "line_intersection", "arc", "circle", "fixed",
    "Canvas", "strip", "dashes",
]

Point = tuple[float, float]
FAR = 5000.0  # px: far beyond any scene edge, so legs always reach the border
SHIFT = 4  # fractional bits of cv2 vertex coordinates


def unit(angle_deg: float) -> Point:
    """Unit vector of an image angle in degrees (0 = +u, 90 = +v)."""
    a = math.radians(angle_deg)
    return (math.cos(a), math.sin(a))


def normal(angle_deg: float) -> Point:
    """Right-hand normal of a direction (towards increasing image angles)."""
    a = math.radians(angle_deg)
    return (-math.sin(a), math.cos(a))


def at(c: Point, e: Point, n: Point, s: float, l: float) -> Point:
    """The point ``c + s·e + l·n``."""
    return (c[0] + s * e[0] + l * n[0], c[1] + s * e[1] + l * n[1])


def line_intersection(p: Point, d: Point, q: Point, f: Point) -> tuple[float, float] | None:
    """Parameters ``(s, t)`` with ``p + s·d = q + t·f``; None for (near) parallel lines."""
    det = d[0] * (-f[1]) - d[1] * (-f[0])
    if abs(det) < 1e-9:
        return None
    rx, ry = q[0] - p[0], q[1] - p[1]
    s = (rx * (-f[1]) - ry * (-f[0])) / det
    t = (d[0] * ry - d[1] * rx) / det
    return s, t


def arc(centre: Point, radius: float, a0: float, a1: float, step_deg: float = 4.0) -> list[Point]:
    """Points of the shorter circular arc from angle ``a0`` to ``a1`` (radians), ends included."""
    delta = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
    count = max(2, int(abs(math.degrees(delta)) / step_deg) + 2)
    return [(centre[0] + radius * math.cos(a0 + delta * k / (count - 1)),
             centre[1] + radius * math.sin(a0 + delta * k / (count - 1))) for k in range(count)]


def circle(centre: Point, radius: float, step_deg: float = 3.0) -> list[Point]:
    """Vertices of a full circle (a closed polygon)."""
    count = max(8, int(360.0 / step_deg))
    return [(centre[0] + radius * math.cos(2 * math.pi * k / count),
             centre[1] + radius * math.sin(2 * math.pi * k / count)) for k in range(count)]


def fixed(points: Sequence[Point]) -> np.ndarray:
    """(N, 2) int32 cv2 vertices with ``SHIFT`` fractional bits."""
    return np.round(np.asarray(points, dtype=np.float64) * (1 << SHIFT)).astype(np.int32)


def strip(c: Point, angle_deg: float, l0: float, l1: float, s0: float = 0.0, s1: float = FAR) -> list[Point]:
    """Quadrilateral ``s0 ≤ s ≤ s1, l0 ≤ l ≤ l1`` of the leg at ``angle_deg``."""
    e, n = unit(angle_deg), normal(angle_deg)
    return [at(c, e, n, s0, l0), at(c, e, n, s1, l0), at(c, e, n, s1, l1), at(c, e, n, s0, l1)]


def dashes(c: Point, angle_deg: float, lat: float, s0: float, s1: float, dash: float, gap: float,
           width: float) -> list[list[Point]]:
    """Rectangles of a dashed line along a leg at lateral offset ``lat`` (all in px)."""
    out, s = [], s0
    while s < s1:
        out.append(strip(c, angle_deg, lat - width / 2, lat + width / 2, s, min(s + dash, s1)))
        s += dash + gap
    return out


class Canvas:
    """A class map and a material map painted together (same shapes, uint8).

    Attributes:
        semantic: (H, W) class ids.
        material: (H, W) material ids (appearance only, see ``dressing.Material``).
        bike_trace: (H, W) uint8, 1 wherever a bicycle-path band was ever painted,
            even if a road was painted over it later (red bicycle crossings).
    """

    def __init__(self, width: int, height: int, cls: int, material: int) -> None:
        self.width, self.height = width, height
        self.semantic = np.full((height, width), cls, np.uint8)
        self.material = np.full((height, width), material, np.uint8)
        self.bike_trace = np.zeros((height, width), np.uint8)

    def polygon(self, points: Sequence[Point], cls: int, material: int) -> None:
        """Fill one polygon (one cv2 call per polygon: several in one call would XOR)."""
        pts = [fixed(points)]
        cv2.fillPoly(self.semantic, pts, int(cls), cv2.LINE_8, SHIFT)
        cv2.fillPoly(self.material, pts, int(material), cv2.LINE_8, SHIFT)
        if cls == 3:
            cv2.fillPoly(self.bike_trace, pts, 1, cv2.LINE_8, SHIFT)

    def polygons(self, polys: Iterable[Sequence[Point]], cls: int, material: int) -> None:
        for points in polys:
            self.polygon(points, cls, material)

    def disc(self, centre: Point, radius: float, cls: int, material: int) -> None:
        """Fill a disc of ``radius`` px."""
        self.polygon(circle(centre, radius), cls, material)

    def annulus(self, centre: Point, r0: float, r1: float, cls: int, material: int) -> None:
        """Fill the ring ``r0 ≤ r ≤ r1`` (as a polygon with a hole, one cv2 call)."""
        # one call, even-odd fill: the inner contour is the hole
        pts = [fixed(circle(centre, r1, 2.0)), fixed(circle(centre, r0, 2.0))]
        cv2.fillPoly(self.semantic, pts, int(cls), cv2.LINE_8, SHIFT)
        cv2.fillPoly(self.material, pts, int(material), cv2.LINE_8, SHIFT)
        if cls == 3:
            cv2.fillPoly(self.bike_trace, pts, 1, cv2.LINE_8, SHIFT)
