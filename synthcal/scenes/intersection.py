"""Built-in procedural road intersections ``intersection-1`` … ``intersection-5`` (SPEC §4).

Frame and scale: 1300 (wide) × 1900 (tall) bird's-eye pixels at 10 px per metre
(130 m × 190 m); the junction centre is ``(u, v) = (650, 950)``, so the paper's grid
(X 600..700, Y 900..1000, Z 50..100 px = 5–10 m) puts every camera over the
junction. Every road runs to the scene border. Image angles: 0° = +u (east on
screen), 90° = +v (south on screen).

Classes (semantic ids)

====  ===============  ====================================================
id    name             what it covers
====  ===============  ====================================================
0     background       buildings, pavements, courtyards, car parks, paved
                       islands and roundabout aprons — everything else
1     road             carriageways incl. their markings (markings are RGB
                       only), slip lanes, the roundabout's ring, crossings
2     terrain          grass: verges, parks, grass medians and islands
3     bicycle path     red cycle paths (along roads, cycle rings, lone tracks)
====  ===============  ====================================================

Distractors are in the RGB only: cars on the lanes and in car parks, roofs of
buildings of many colours, trees (crowns overhang roads), shadows of buildings,
trees and cars, white markings (zebras, stop lines, lane lines, give-way
triangles), red bicycle crossings over the road (class 1), and car parks that
look like roads but are class 0.

The five layouts (complexity rises 1 → 5, as in the paper):

1. A plain orthogonal crossing of two single-carriageway roads; one two-way
   cycle path along the north–south road; three blocks of buildings and a park.
2. Also a plain four-leg crossing, but skewed (the minor road crosses at 65°), the
   main road twice as wide (two lanes each way) with cycle paths on both sides; a
   car park in one corner.
3. Five legs: an east–west dual carriageway (grass median, street trees) with
   cycle paths on both sides, a southern leg with a splitter island and a cycle
   path, a northern leg with a cycle path and a diagonal north-eastern leg; two
   parks with footpaths.
4. Six legs: two dual carriageways crossing (medians, parallel cycle paths on both
   sides of all four), two diagonal single roads, free right-turn slip lanes
   around grass traffic islands in two corners, a lone cycle track through a park.
5. A two-lane roundabout with a grass central island and paved apron, a cycle ring
   around it, six roads (two dual carriageways, four with splitter islands,
   parallel cycle paths on every leg), two lone cycle tracks, parks with
   footpaths, a car park.

Each layout is data (:class:`~synthcal.scenes.network.Layout`) fed to one
builder; randomness (roof colours, cars, trees) comes from the layout's fixed seed.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .dressing import (
    CAR_COLOURS,
    Car,
    MaterialLook,
    Tree,
    add_grain,
    base_colours,
    building_shadow,
    car_outline,
    cars_on_road,
    draw_building,
    draw_car,
    draw_tree,
    fill_rgb,
    place_buildings,
    shade,
)
from .network import (
    BikeTrack,
    Layout,
    Leg,
    LegGeometry,
    Material,
    Network,
    Roundabout,
    Side,
    Slip,
    lane_centres,
    network_markings,
    paint_network,
)
from .roadkit import FAR, SHIFT, Canvas, Point, at, circle, fixed, normal, strip, unit

__all__ = ["CLASSES", "PALETTE", "LAYOUTS", "TEXTURES", "build_intersection"]

CLASSES = ("background", "road", "terrain", "bicycle path")
PALETTE = ((0, 0, 0), (128, 64, 128), (107, 196, 64), (230, 40, 60))
PPM = 10.0

LOOKS = (
    MaterialLook((146, 142, 134), (170, 165, 155), 9),  # courtyard paving
    MaterialLook((168, 166, 160), (192, 188, 180), 7),  # pavement
    MaterialLook((72, 73, 77), (98, 98, 102), 9),  # asphalt
    MaterialLook((56, 100, 38), (106, 140, 60), 14),  # grass
    MaterialLook((144, 56, 50), (172, 78, 64), 8),  # red cycle path
    MaterialLook((182, 180, 172), (202, 199, 191), 6),  # concrete island
    MaterialLook((62, 62, 66), (84, 84, 88), 8),  # car-park asphalt
    MaterialLook((128, 116, 104), (162, 150, 134), 20),  # cobbled apron
)


def _retextured(**looks: MaterialLook) -> tuple[MaterialLook, ...]:
    """The default textures with some materials (``ASPHALT=...``: :class:`Material` names) replaced."""
    table = list(LOOKS)
    for name, look in looks.items():
        table[getattr(Material, name)] = look
    return tuple(table)


# Texture sets by name (``Layout.textures``): the same material map, other colours and grain.
TEXTURES: dict[str, tuple[MaterialLook, ...]] = {
    "default": LOOKS,
    "concrete": _retextured(ASPHALT=MaterialLook((150, 148, 140), (172, 170, 162), 6),
                            BIKE=MaterialLook((120, 48, 44), (150, 66, 56), 8)),
    "dry": _retextured(ASPHALT=MaterialLook((88, 86, 84), (112, 110, 106), 11),
                       GRASS=MaterialLook((128, 122, 70), (160, 150, 92), 14)),
    "dark": _retextured(ASPHALT=MaterialLook((44, 45, 50), (64, 64, 70), 7),
                        GRASS=MaterialLook((38, 84, 30), (70, 112, 44), 12),
                        SIDEWALK=MaterialLook((150, 120, 100), (176, 146, 124), 9)),
    "bright": _retextured(BIKE=MaterialLook((168, 72, 60), (196, 96, 80), 8),
                          COURTYARD=MaterialLook((120, 120, 116), (150, 150, 146), 10)),
}

_walk = Side(verge=2.0, walk=3.0)
_tree_walk = Side(verge=3.0, walk=3.0, trees=True)
_cycle = Side(verge=2.0, bike=2.2, walk=2.5)
_cycle_trees = Side(verge=3.0, bike=2.2, walk=2.5, trees=True)
_cycle2 = Side(verge=2.5, bike=3.0, walk=2.5)  # two-way cycle path

LAYOUTS: dict[str, Layout] = {
    "intersection-1": Layout(
        "intersection-1", "plain 4-leg crossing, one two-way cycle path",
        legs=(Leg(0), Leg(90, lane_width=3.5, left=_cycle2), Leg(180, right=_tree_walk),
              Leg(270, lane_width=3.5, right=_cycle2)),
        sectors=("buildings", "buildings", "park", "buildings"), cars=14, seed=1001),
    "intersection-2": Layout(
        "intersection-2", "skewed 4-leg crossing, wide main road with cycle paths both sides",
        legs=(Leg(0, lanes=2, left=_cycle, right=_cycle), Leg(65, left=_tree_walk, right=_walk),
              Leg(180, lanes=2, left=_cycle, right=_cycle), Leg(245)),
        sectors=("buildings", "parking", "buildings", "park"), cars=20, seed=1002),
    "intersection-3": Layout(
        "intersection-3", "5-leg junction, dual carriageway with median, splitter island, cycle paths",
        legs=(Leg(0, lanes=2, median=4.0, left=_cycle, right=_cycle_trees),
              Leg(90, median=2.5, median_length=18.0, left=_cycle, right=_walk),
              Leg(180, lanes=2, median=4.0, left=_cycle_trees, right=_cycle),
              Leg(270, left=_walk, right=Side(verge=2.5, bike=2.0, walk=2.5)), Leg(318, lane_width=3.0)),
        sectors=("buildings", "park", "buildings", "buildings", "park"), cars=26, seed=1003),
    "intersection-4": Layout(
        "intersection-4", "6-leg junction, two dual carriageways, slip lanes around islands, parallel cycle paths",
        legs=(Leg(0, lanes=2, median=3.0, left=_cycle, right=_cycle),
              Leg(90, lanes=2, median=3.0, left=_cycle, right=_cycle),
              Leg(137, left=_tree_walk, right=_walk), Leg(180, lanes=2, median=3.0, left=_cycle, right=_cycle),
              Leg(270, lanes=2, median=3.0, left=_cycle, right=_cycle), Leg(312, left=_walk, right=_tree_walk)),
        sectors=("buildings", "park", "buildings", "parking", "park", "buildings"),
        slips=(Slip(0), Slip(3, island="paved")), bike_tracks=(BikeTrack(292),), cars=34, seed=1004),
    "intersection-5": Layout(
        "intersection-5", "two-lane roundabout, cycle ring, six legs with islands, lone cycle tracks",
        legs=(Leg(0, lanes=2, median=3.0, left=_cycle, right=_cycle),
              Leg(58, median=3.0, median_length=22.0, left=_cycle, right=_cycle_trees),
              Leg(118, median=3.0, median_length=22.0, left=_cycle, right=_cycle),
              Leg(180, lanes=2, median=3.0, left=_cycle_trees, right=_cycle),
              Leg(238, median=3.0, median_length=22.0, left=_cycle, right=_cycle),
              Leg(296, median=3.0, median_length=22.0, left=_cycle, right=_cycle)),
        sectors=("park", "buildings", "parking", "park", "buildings", "park"),
        roundabout=Roundabout(radius=24.0, lanes=2, island=12.0, apron=2.5),
        bike_tracks=(BikeTrack(150), BikeTrack(328)),
        cars=36, seed=1005),
    # intersection-1's family: its topology (legs at 0/90/180/270°, centre (650, 950)), other cross-sections
    "intersection-1a": Layout(
        "intersection-1a", "intersection-1's crossing, two lanes each way east-west with cycle paths, 4 m corners",
        legs=(Leg(0, lanes=2, left=_cycle, right=_cycle), Leg(90, lane_width=3.5, right=_walk),
              Leg(180, lanes=2, left=_cycle, right=_cycle), Leg(270, lane_width=3.5, left=_tree_walk)),
        sectors=("buildings", "park", "buildings", "buildings"), kerb_radius=4.0, textures="concrete", cars=18,
        seed=1101),
    "intersection-1b": Layout(
        "intersection-1b", "intersection-1's crossing, two dual carriageways, cycle paths all round, 12 m corners",
        legs=tuple(Leg(angle, lanes=2, median=3.0, left=_cycle, right=_cycle) for angle in (0, 90, 180, 270)),
        sectors=("park", "buildings", "park", "buildings"), kerb_radius=12.0, zebras=False, textures="dry", cars=24,
        seed=1102),
    "intersection-1c": Layout(
        "intersection-1c", "intersection-1's crossing, narrow tree-lined roads, no cycle paths, 5 m corners",
        legs=tuple(Leg(angle, lane_width=3.0, left=_tree_walk, right=_tree_walk) for angle in (0, 90, 180, 270)),
        sectors=("buildings", "parking", "buildings", "park"), kerb_radius=5.0, textures="dark", cars=12, seed=1103),
    "intersection-1d": Layout(
        "intersection-1d", "intersection-1's crossing, splitter islands north-south, two-way cycle paths east-west",
        legs=(Leg(0, left=_cycle2, right=_cycle2), Leg(90, median=2.5, median_length=18.0, left=_walk, right=_cycle),
              Leg(180, left=_cycle2, right=_cycle2),
              Leg(270, median=2.5, median_length=18.0, left=_cycle, right=_walk)),
        sectors=("park", "buildings", "buildings", "park"), kerb_radius=9.0, textures="bright", cars=16, seed=1104),
}


def _sector_polygon(c: Point, a0: float, a1: float) -> list[Point]:
    """Wedge from the centre between two image angles (clockwise from a0 to a1)."""
    span = (a1 - a0) % 360.0
    steps = max(2, int(span / 20) + 2)
    return [c] + [at(c, unit(a0 + span * k / (steps - 1)), (0, 0), FAR, 0) for k in range(steps)]


def _paint_sectors(canvas: Canvas, layout: Layout, rng: np.random.Generator) -> None:
    """Parks (grass, with a winding footpath) in the corners marked ``park``; the rest stays class 0."""
    c, angles = layout.centre, sorted(leg.angle % 360.0 for leg in layout.legs)
    for i, kind in enumerate(layout.sectors):
        a0, a1 = angles[i], angles[(i + 1) % len(angles)]
        if kind != "park":
            continue
        canvas.polygon(_sector_polygon(c, a0, a1), 2, Material.GRASS)
        span = (a1 - a0) % 360.0
        # footpath: a quadratic curve from one leg's pavement to the other's, through the park
        d0, d1 = rng.uniform(35, 60) * PPM, rng.uniform(35, 60) * PPM
        p0, p2 = at(c, unit(a0 + 4), (0, 0), d0, 0), at(c, unit(a1 - 4), (0, 0), d1, 0)
        p1 = at(c, unit(a0 + span / 2), (0, 0), (d0 + d1) * rng.uniform(0.75, 1.1), 0)
        t = np.linspace(0.0, 1.0, 40)[:, None]
        curve = (1 - t) ** 2 * np.array(p0) + 2 * t * (1 - t) * np.array(p1) + t ** 2 * np.array(p2)
        pts = [fixed(curve)]
        cv2.polylines(canvas.semantic, pts, False, 0, int(2.5 * PPM), cv2.LINE_8, SHIFT)
        cv2.polylines(canvas.material, pts, False, Material.SIDEWALK, int(2.5 * PPM), cv2.LINE_8, SHIFT)


def _parking_lots(canvas: Canvas, layout: Layout, rng: np.random.Generator) -> list[tuple[Point, float, float, float]]:
    """One car park per ``parking`` corner: (centre, angle, length, depth) in px, painted as class 0."""
    c, angles = layout.centre, sorted(leg.angle % 360.0 for leg in layout.legs)
    lots = []
    for i, kind in enumerate(layout.sectors):
        if kind != "parking":
            continue
        a0, a1 = angles[i], angles[(i + 1) % len(angles)]
        mid = a0 + ((a1 - a0) % 360.0) / 2
        free = canvas.material == Material.COURTYARD
        for _ in range(60):
            length, depth = rng.uniform(38, 52) * PPM, 23.0 * PPM
            angle = a0 if rng.uniform() < 0.5 else a1
            centre = at(c, unit(mid), (0, 0), rng.uniform(30, 75) * PPM, 0)
            box = strip(centre, angle, -depth / 2, depth / 2, -length / 2, length / 2)
            mask = np.zeros_like(canvas.material)
            cv2.fillPoly(mask, [fixed(box)], 1, cv2.LINE_8, SHIFT)
            inside = mask.astype(bool)
            if inside.sum() > 0 and np.all(free[inside]) and inside.sum() > 0.95 * length * depth:
                canvas.polygon(box, 0, Material.PARKING)
                lots.append((centre, angle, length, depth))
                break
    return lots


def _lot_marks_and_cars(lot: tuple[Point, float, float, float], rng: np.random.Generator):
    """Bay lines (two rows back to back around a central aisle pattern) and parked cars."""
    centre, angle, length, depth = lot
    lines, cars = [], []
    bay, row = 2.5 * PPM, 5.0 * PPM
    rows = (-depth / 2 + 0.5 * PPM, depth / 2 - 0.5 * PPM - row)  # two rows along the long sides
    count = int((length - PPM) / bay)
    for r0 in rows:
        for k in range(count + 1):
            s = -length / 2 + 0.5 * PPM + k * bay
            lines.append(strip(centre, angle, r0, r0 + row, s - 0.06 * PPM, s + 0.06 * PPM))
            if k < count and rng.uniform() < 0.65:
                spot = at(centre, unit(angle), normal(angle), s + bay / 2, r0 + row / 2)
                heading = angle + 90.0 + (180.0 if rng.uniform() < 0.5 else 0.0)
                cars.append(Car(spot, heading, rng.uniform(4.0, 4.8) * PPM, rng.uniform(1.75, 1.95) * PPM,
                                CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]))
    return lines, cars


def _border_distance(c: Point, angle: float, size: tuple[int, int]) -> float:
    """Distance from ``c`` along ``angle`` to the scene border (px)."""
    e, (w, h) = unit(angle), size
    ts = [t for t in ((-c[0]) / e[0] if e[0] < -1e-9 else None, (w - 1 - c[0]) / e[0] if e[0] > 1e-9 else None,
                      (-c[1]) / e[1] if e[1] < -1e-9 else None, (h - 1 - c[1]) / e[1] if e[1] > 1e-9 else None)
          if t is not None]
    return min(ts)


def _traffic(net: Network, canvas: Canvas, layout: Layout, rng: np.random.Generator) -> list[Car]:
    """Cars on the lanes (queues at the stop lines) and on the roundabout, all on class-1 road."""
    cars: list[Car] = []
    for g in net.legs:
        end = _border_distance(net.centre, g.angle, layout.size) - 3 * PPM
        for lat, sign in lane_centres(g):
            cars += _lane_cars(net.centre, g, lat, sign, end, rng)
    if net.roundabout is not None:
        cars += _ring_cars(net.centre, net.roundabout, rng)
    return cars_on_road(cars, canvas.semantic)[: layout.cars]


def _lane_cars(c: Point, g: LegGeometry, lat: float, sign: float, end: float, rng: np.random.Generator) -> list[Car]:
    """Cars along one lane up to ``end`` px: inbound lanes (sign < 0) start with a queue at the stop line."""
    cars = []
    s = g.marks_start + 1.5 * PPM + (0 if sign < 0 else rng.uniform(0, 20) * PPM)
    queue = int(rng.integers(0, 4)) if sign < 0 else 0
    while s < end:
        length = rng.uniform(4.0, 5.0) * PPM if rng.uniform() < 0.9 else 6.5 * PPM
        if rng.uniform() < 0.5 or queue > 0:
            spot = at(c, unit(g.angle), normal(g.angle), s + length / 2, lat + rng.uniform(-0.2, 0.2) * PPM)
            cars.append(Car(spot, g.angle + (0.0 if sign > 0 else 180.0), length,
                            rng.uniform(1.75, 2.0) * PPM, CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]))
        s += length + (rng.uniform(1.5, 2.5) if queue > 0 else rng.uniform(6, 30)) * PPM
        queue -= 1
    return cars


def _ring_cars(c: Point, ring: Roundabout, rng: np.random.Generator) -> list[Car]:
    """Two to four cars on each lane of a roundabout's carriageway."""
    cars = []
    width = ring.radius - ring.island - ring.apron
    for lane in range(ring.lanes):
        r = (ring.radius - (lane + 0.5) * width / ring.lanes) * PPM
        for a in rng.uniform(0, 2 * math.pi, int(rng.integers(2, 5))):
            spot = (c[0] + r * math.cos(a), c[1] + r * math.sin(a))
            cars.append(Car(spot, math.degrees(a) - 90.0, 4.5 * PPM, 1.85 * PPM,
                            CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]))
    return cars


def _trees(net: Network, canvas: Canvas, layout: Layout, rng: np.random.Generator) -> list[Tree]:
    """Street trees on verges marked ``trees`` and scattered trees on wide grass."""
    c, trees = net.centre, []
    for g in net.legs:
        end = _border_distance(c, g.angle, layout.size)
        for name, sign in (("left", -1.0), ("right", 1.0)):
            side = getattr(g.leg, name)
            if not side.trees:
                continue
            lat = sign * (g.half_width + side.verge * PPM / 2)
            s = g.marks_start + 6 * PPM
            while s < end:
                trees.append(Tree(at(c, unit(g.angle), normal(g.angle), s, lat), rng.uniform(2.6, 3.8) * PPM,
                                  rng.uniform(7, 11) * PPM))
                s += rng.uniform(8, 11) * PPM
    # grass at least 3.5 m from anything else, found on a 4× coarser grid (fast erosion)
    grass = (canvas.semantic[::4, ::4] == 2).astype(np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(7 * PPM / 4) | 1, int(7 * PPM / 4) | 1))
    wide = cv2.erode(grass, kernel)
    h, w = canvas.semantic.shape
    for _ in range(260):
        x, y = rng.uniform(0, w), rng.uniform(0, h)
        radius, height = rng.uniform(2.5, 5.0) * PPM, rng.uniform(6, 14) * PPM
        apart = all(math.hypot(x - t.centre[0], y - t.centre[1]) > 0.9 * (radius + t.radius) for t in trees)
        if wide[int(y) // 4, int(x) // 4] and apart:
            trees.append(Tree((x, y), radius, height))
    return trees


def build_intersection(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Paint one intersection.

    Args:
        layout: the junction (see :data:`LAYOUTS`).

    Returns:
        ``(image, semantic)``: (H, W, 3) uint8 RGB and (H, W) uint8 class ids 0..3,
        ``(W, H) = layout.size``.
    """
    rng = np.random.default_rng(layout.seed)
    width, height = layout.size
    canvas = Canvas(width, height, 0, Material.COURTYARD)
    _paint_sectors(canvas, layout, rng)
    net = paint_network(canvas, layout, PPM)
    lots = _parking_lots(canvas, layout, rng)
    free = cv2.erode((canvas.material == Material.COURTYARD).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    buildings = place_buildings(free, rng, 500, [g.angle for g in net.legs], PPM)

    looks = TEXTURES[layout.textures]
    rgb = base_colours(canvas.material, looks, rng)
    crossing = (canvas.bike_trace == 1) & (canvas.semantic == 1)  # red bicycle crossings over the road
    red = np.array([150, 58, 52], np.uint16) * 5
    rgb[crossing] = ((rgb[crossing].astype(np.uint16) * 3 + red) >> 3).astype(np.uint8)
    white, teeth = network_markings(net, layout.zebras)
    parked = []
    for lot in lots:
        lines, cars = _lot_marks_and_cars(lot, rng)
        white += lines
        parked += cars
    for poly in white + teeth:
        fill_rgb(rgb, poly, (226, 226, 220))
    add_grain(rgb, canvas.material, looks, rng)
    # kerbs: a light rim where the road meets anything else
    road = (canvas.semantic == 1).astype(np.uint8)
    kerb = (road - cv2.erode(road, np.ones((3, 3), np.uint8))).astype(bool)
    rgb[kerb] = ((rgb[kerb].astype(np.uint16) + 170) >> 1).astype(np.uint8)

    azimuth = math.radians(rng.uniform(200, 245))  # shadows fall up-left on screen
    sun = (0.85 * math.cos(azimuth), 0.85 * math.sin(azimuth))
    cars = _traffic(net, canvas, layout, rng) + parked
    mask = np.zeros((height, width), np.uint8)
    for car in cars:
        fill_rgb(mask, [(x + sun[0] * 1.2 * PPM, y + sun[1] * 1.2 * PPM) for x, y in car_outline(car)], 255)
    shade(rgb, mask, 120)
    for car in cars:
        draw_car(rgb, car)
    trees = _trees(net, canvas, layout, rng)
    mask[...] = 0
    for b in buildings:
        fill_rgb(mask, building_shadow(b, sun), 255)
    for t in trees:
        fill_rgb(mask, circle((t.centre[0] + sun[0] * t.height, t.centre[1] + sun[1] * t.height), t.radius, 15.0), 255)
    shade(rgb, mask, 105)
    for b in buildings:
        draw_building(rgb, b, rng, PPM)
    for t in trees:
        draw_tree(rgb, t, rng)
    return rgb, canvas.semantic
