"""Junction layouts described as data, painted by one builder.

A :class:`Layout` is a list of :class:`Leg` (a road leaving the junction centre at
an image angle, with lanes, an optional median and a cross-section per side), an
optional :class:`Roundabout`, :class:`Slip` corners (free right-turn lanes around a
traffic island) and :class:`BikeTrack` (bicycle paths on their own). Lengths are in
metres; :func:`paint_network` converts them with the scene's pixels per metre.

Cross-section of a leg, from its centre line outward (each side on its own)::

    | median/2 | lanes × lane_width | verge (2) | bike (3) | walk (0) | ...
      island        road (1)          grass      red path   pavement

See ``roadkit`` for the painting order (outermost layer first).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .roadkit import FAR, Canvas, Point, arc, at, dashes, line_intersection, normal, strip, unit

__all__ = ["Side", "Leg", "Roundabout", "Slip", "BikeTrack", "Layout", "LegGeometry", "Network",
           "paint_network", "network_markings", "lane_centres", "Material"]


class Material:
    """Material ids of the appearance map (colours and textures: ``dressing``)."""

    COURTYARD, SIDEWALK, ASPHALT, GRASS, BIKE, CONCRETE, PARKING, COBBLES = range(8)


@dataclass(frozen=True)
class Side:
    """One side of a leg, beyond the kerb (metres; 0 leaves a part out)."""

    verge: float = 2.0
    bike: float = 0.0
    walk: float = 2.5
    trees: bool = False  # street trees on the verge: RGB only, crowns overhang the road


@dataclass(frozen=True)
class Leg:
    """A road leaving the junction; ``right`` faces the next leg clockwise on screen."""

    angle: float
    lanes: int = 1
    lane_width: float = 3.25
    median: float = 0.0
    median_length: float | None = None  # None: the whole leg (dual carriageway); else a splitter
    left: Side = Side()
    right: Side = Side()


@dataclass(frozen=True)
class Roundabout:
    """A circulating carriageway around a grass island, with a cycle ring outside."""

    radius: float = 20.0  # outer kerb of the carriageway
    lanes: int = 1
    island: float = 11.0  # grass island radius
    apron: float = 2.0  # paved (class 0) truck apron around the island
    verge: float = 3.0
    bike: float = 2.5
    walk: float = 3.0


@dataclass(frozen=True)
class Slip:
    """A free right-turn lane cutting the corner after leg ``corner`` (clockwise)."""

    corner: int
    radius: float = 42.0
    lane: float = 4.0
    island: str = "grass"  # or "paved" (class 0)


@dataclass(frozen=True)
class BikeTrack:
    """A bicycle path on its own, from the junction's cycle network to the border."""

    angle: float
    width: float = 3.0
    verge: float = 1.5  # grass on each side


@dataclass(frozen=True)
class Layout:
    """Everything that defines a built-in intersection."""

    name: str
    description: str
    legs: tuple[Leg, ...]
    sectors: tuple[str, ...]  # per corner after each leg: "buildings", "park" or "parking"
    roundabout: Roundabout | None = None
    slips: tuple[Slip, ...] = ()
    bike_tracks: tuple[BikeTrack, ...] = ()
    kerb_radius: float = 7.0
    zebras: bool = True  # zebra crossings at every leg's mouth (RGB only)
    textures: str = "default"  # the material colours and grain (a key of ``intersection.TEXTURES``)
    cars: int = 24
    size: tuple[int, int] = (1300, 1900)
    centre: tuple[float, float] = (650.0, 950.0)
    seed: int = 1000


@dataclass
class LegGeometry:
    """A leg in pixels: half widths per layer and where its straight part starts."""

    leg: Leg
    angle: float
    half_width: float  # road, kerb to centre line
    median: float  # full median width (0 = none)
    lane: float  # lane width
    offsets: dict[str, tuple[float, float, float]]  # side → (verge, bike, walk) outer edges
    clear: float = 0.0  # s where both kerbs are straight (past every corner)
    marks_start: float = 0.0  # s of the first longitudinal marking


@dataclass
class Network:
    """The painted geometry the dressing needs (cars, markings, trees)."""

    centre: Point
    ppm: float
    legs: list[LegGeometry]
    roundabout: Roundabout | None
    slip_lanes: list[tuple[Point, float, float, float]] = field(default_factory=list)  # (O, r0, a0, a1)


def _geometry(leg: Leg, ppm: float) -> LegGeometry:
    median = leg.median * ppm
    half = leg.lanes * leg.lane_width * ppm + median / 2
    offsets = {}
    for name, side in (("left", leg.left), ("right", leg.right)):
        verge = half + side.verge * ppm
        bike = verge + side.bike * ppm
        offsets[name] = (verge, bike, bike + side.walk * ppm)
    return LegGeometry(leg, leg.angle % 360.0, half, median, leg.lane_width * ppm, offsets)


def _corner(
    c: Point, gi: LegGeometry, gj: LegGeometry, di: float, dj: float, r: float
) -> tuple[Point, Point, Point, Point, float, float] | None:
    """Fillet of radius ``r`` between leg i's line at right offset ``di`` and leg j's at left ``dj``.

    Returns (Q, O, T_i, T_j, s_i, t_j): the corner, the circle centre, the tangent
    points and their distances along each leg; None if the legs are too straight.
    """
    gap = (gj.angle - gi.angle) % 360.0
    if gap > 165.0 or gap < 5.0:
        return None
    ei, ni, ej, nj = unit(gi.angle), normal(gi.angle), unit(gj.angle), normal(gj.angle)
    q = line_intersection(at(c, ei, ni, 0, di), ei, at(c, ej, nj, 0, -dj), ej)
    o = line_intersection(at(c, ei, ni, 0, di + r), ei, at(c, ej, nj, 0, -dj - r), ej)
    if q is None or o is None:
        return None
    Q = at(c, ei, ni, q[0], di)
    O = at(c, ei, ni, o[0], di + r)
    return Q, O, at(c, ei, ni, o[0], di), at(c, ej, nj, o[1], -dj), o[0], o[1]


def _fillet(Q: Point, O: Point, Ti: Point, Tj: Point, r: float) -> list[Point]:
    a0 = math.atan2(Ti[1] - O[1], Ti[0] - O[0])
    a1 = math.atan2(Tj[1] - O[1], Tj[0] - O[0])
    return [Q] + arc(O, r, a0, a1)


def _hull(c: Point, geoms: list[LegGeometry], layer: int | None) -> list[Point]:
    """Convex hull of the legs' start edges: fills the notch of reflex corners."""
    pts = []
    for g in geoms:
        e, n = unit(g.angle), normal(g.angle)
        left = g.half_width if layer is None else g.offsets["left"][layer]
        right = g.half_width if layer is None else g.offsets["right"][layer]
        pts += [at(c, e, n, 0, -left), at(c, e, n, 0, right)]
    ordered = sorted(pts, key=lambda p: math.atan2(p[1] - c[1], p[0] - c[0]))
    return ordered  # star-shaped around c, which is enough for cv2.fillPoly


def paint_network(canvas: Canvas, layout: Layout, ppm: float) -> Network:
    """Paint the roads, verges, bicycle paths, pavements and islands of ``layout``.

    Layers go outermost first (see ``roadkit``): pavement and verges, bicycle-path
    bands, roads with their corners, then islands.

    Args:
        canvas: class + material maps, already holding the corner sectors.
        layout: the junction.
        ppm: pixels per metre.

    Returns:
        The painted geometry (pixels), for markings, cars and trees.
    """
    geoms = sorted((_geometry(leg, ppm) for leg in layout.legs), key=lambda g: g.angle)
    R = _ring_radii(layout.roundabout, ppm)
    _paint_sides(canvas, layout, geoms, R, ppm)
    _paint_bike_bands(canvas, layout, geoms, R, ppm)
    network = Network(layout.centre, ppm, geoms, layout.roundabout)
    islands = _paint_roads(canvas, layout, network, R)
    _paint_islands(canvas, network, islands, R)
    for g in geoms:
        g.clear = max(g.clear, g.half_width)
    return network


def _ring_radii(ring: Roundabout | None, ppm: float) -> dict[str, float]:
    """Outer radii (px) of the roundabout's road, verge, bicycle and pavement rings; {} without one."""
    R: dict[str, float] = {}
    if ring is not None:
        R["road"] = ring.radius * ppm
        R["verge"] = R["road"] + ring.verge * ppm
        R["bike"] = R["verge"] + ring.bike * ppm
        R["walk"] = R["bike"] + ring.walk * ppm
    return R


def _paint_sides(canvas: Canvas, layout: Layout, geoms: list[LegGeometry], R: dict[str, float], ppm: float) -> None:
    """1. pavement, 2. verges (nested strips, mitred by overpainting); lone bicycle paths get grass verges."""
    c = layout.centre
    for layer, cls, mat in ((2, 0, Material.SIDEWALK), (0, 2, Material.GRASS)):
        name = "walk" if layer == 2 else "verge"
        if layout.roundabout is not None:
            canvas.disc(c, R[name], cls, mat)
        for g in geoms:
            canvas.polygon(strip(c, g.angle, -g.offsets["left"][layer], g.offsets["right"][layer]), cls, mat)
        canvas.polygon(_hull(c, geoms, layer), cls, mat)
        if layer == 0:
            for t in layout.bike_tracks:
                half = (t.width / 2 + t.verge) * ppm
                canvas.polygon(strip(c, t.angle, -half, half, _track_start(c, t, geoms, R, ppm)), 2, Material.GRASS)


def _paint_bike_bands(
    canvas: Canvas, layout: Layout, geoms: list[LegGeometry], R: dict[str, float], ppm: float
) -> None:
    """3. bicycle-path bands (run on across the neighbour's verge up to its kerb)."""
    c, ring = layout.centre, layout.roundabout
    if ring is not None and ring.bike > 0:
        canvas.annulus(c, R["verge"], R["bike"], 3, Material.BIKE)
    for g in geoms:
        for name, sign in (("left", -1.0), ("right", 1.0)):
            verge, bike, _ = g.offsets[name]
            if bike > verge:
                s0 = 0.0
                if ring is not None:  # start inside the cycle ring, not across the ring's verge
                    mid_r, mid_d = (R["verge"] + R["bike"]) / 2, (verge + bike) / 2
                    s0 = math.sqrt(max(mid_r ** 2 - mid_d ** 2, 0.0))
                l0, l1 = sorted((sign * verge, sign * bike))
                canvas.polygon(strip(c, g.angle, l0, l1, s0), 3, Material.BIKE)
    for t in layout.bike_tracks:
        half = t.width / 2 * ppm
        canvas.polygon(strip(c, t.angle, -half, half, _track_start(c, t, geoms, R, ppm)), 3, Material.BIKE)


def _paint_roads(
    canvas: Canvas, layout: Layout, network: Network, R: dict[str, float]
) -> list[tuple[list[Point], str]]:
    """4. roads, with rounded kerbs or slip lanes at the corners.

    Sets each leg's ``clear`` and the network's ``slip_lanes``.

    Returns:
        The slip islands to paint, as (polygon, island kind).
    """
    c, ppm, geoms = network.centre, network.ppm, network.legs
    for g in geoms:
        canvas.polygon(strip(c, g.angle, -g.half_width, g.half_width), 1, Material.ASPHALT)
    canvas.polygon(_hull(c, geoms, None), 1, Material.ASPHALT)
    if layout.roundabout is not None:
        canvas.disc(c, R["road"], 1, Material.ASPHALT)
        for g in geoms:
            g.clear = math.sqrt(max(R["road"] ** 2 - g.half_width ** 2, 0.0)) + 0.5 * ppm
        return []
    slips = {s.corner % len(geoms): s for s in layout.slips}
    islands = []
    for i, gi in enumerate(geoms):
        island = _paint_corner(canvas, layout, network, gi, geoms[(i + 1) % len(geoms)], slips.get(i))
        if island is not None:
            islands.append(island)
    return islands


def _paint_corner(
    canvas: Canvas, layout: Layout, network: Network, gi: LegGeometry, gj: LegGeometry, slip: Slip | None
) -> tuple[list[Point], str] | None:
    """The rounded kerb (or slip lane) between leg ``gi`` and the next leg clockwise ``gj``.

    Returns:
        The slip island to paint later, or None.
    """
    c, ppm = network.centre, network.ppm
    r = (slip.radius if slip else layout.kerb_radius) * ppm
    corner = _corner(c, gi, gj, gi.half_width, gj.half_width, r)
    if corner is None:
        return None
    Q, O, Ti, Tj, si, tj = corner
    canvas.polygon(_fillet(Q, O, Ti, Tj, r), 1, Material.ASPHALT)
    gi.clear, gj.clear = max(gi.clear, si), max(gj.clear, tj)
    if not slip:
        return None
    network.slip_lanes.append((O, r + slip.lane * ppm / 2,
                               math.atan2(Ti[1] - O[1], Ti[0] - O[0]),
                               math.atan2(Tj[1] - O[1], Tj[0] - O[0])))
    return _slip_island(c, gi, gj, O, r, slip, ppm)


def _paint_islands(
    canvas: Canvas, network: Network, islands: list[tuple[list[Point], str]], R: dict[str, float]
) -> None:
    """5. islands: medians and splitters, slip islands, the roundabout's island."""
    c, ppm, ring = network.centre, network.ppm, network.roundabout
    for g in network.legs:
        if g.median > 0:
            start = (R["road"] + 0.5 * ppm) if ring is not None else max(g.clear - 2 * ppm, g.half_width)
            _paint_median(canvas, c, g, start, ppm)
    for points, kind in islands:
        canvas.polygon(points, *((2, Material.GRASS) if kind == "grass" else (0, Material.CONCRETE)))
    if ring is not None:
        canvas.disc(c, (ring.island + ring.apron) * ppm, 0, Material.COBBLES)
        canvas.disc(c, ring.island * ppm, 2, Material.GRASS)


def _paint_median(canvas: Canvas, c: Point, g: LegGeometry, start: float, ppm: float) -> None:
    """A leg's median (or splitter, narrowing to 35 %) from ``start`` px, with rounded ends."""
    length = FAR if g.leg.median_length is None else g.leg.median_length * ppm
    narrow = g.median if g.leg.median_length is None else 0.35 * g.median
    cls, mat = (2, Material.GRASS) if g.median >= 1.6 * ppm else (0, Material.CONCRETE)
    e, n = unit(g.angle), normal(g.angle)
    canvas.polygon([at(c, e, n, start, -g.median / 2), at(c, e, n, start + length, -narrow / 2),
                    at(c, e, n, start + length, narrow / 2), at(c, e, n, start, g.median / 2)], cls, mat)
    canvas.disc(at(c, e, n, start, 0), g.median / 2, cls, mat)
    canvas.disc(at(c, e, n, start + length, 0), narrow / 2, cls, mat)


def _track_start(c: Point, t: BikeTrack, geoms: list[LegGeometry], R: dict, ppm: float) -> float:
    """Where a lone bicycle path starts: inside the cycle ring, or where it meets the
    bicycle path of a leg either side of it (else just beyond the widest leg)."""
    if R:
        return (R["verge"] + R["bike"]) / 2
    et, hits = unit(t.angle), []
    before = max(geoms, key=lambda g: (g.angle - t.angle) % 360.0)  # the legs either side of the track
    after = min(geoms, key=lambda g: (g.angle - t.angle) % 360.0)
    for g, name, sign in ((before, "right", 1.0), (after, "left", -1.0)):
        e, n = unit(g.angle), normal(g.angle)
        verge, bike, _ = g.offsets[name]
        if bike > verge:
            hit = line_intersection(c, et, at(c, e, n, 0, sign * (verge + bike) / 2), e)
            if hit is not None and hit[0] > 0 and hit[1] > 0:
                hits.append(hit[0])
    return max(hits) if hits else max(max(g.offsets["left"][1], g.offsets["right"][1]) for g in geoms) * 1.2


def _slip_island(
    c: Point, gi: LegGeometry, gj: LegGeometry, O: Point, r: float, slip: Slip, ppm: float
) -> tuple[list[Point], str]:
    """Curved-triangle island between the slip lane and the two main roads, and its kind."""
    gap_px = 1.0 * ppm
    outer = r + slip.lane * ppm
    ei, ni, ej, nj = unit(gi.angle), normal(gi.angle), unit(gj.angle), normal(gj.angle)
    p0 = line_intersection(at(c, ei, ni, 0, gi.half_width + gap_px), ei, at(c, ej, nj, 0, -gj.half_width - gap_px), ej)
    s_o = line_intersection(at(c, ei, ni, 0, gi.half_width + r), ei, at(c, ej, nj, 0, -gj.half_width - r), ej)
    if p0 is None or s_o is None:  # _corner found these legs' corner, so their lines do meet
        raise ValueError(f"slip lane at corner {slip.corner}: the legs at {gi.angle}° and {gj.angle}° are parallel")
    along = math.sqrt(max(outer ** 2 - (r - gap_px) ** 2, 0.0))
    P0 = at(c, ei, ni, p0[0], gi.half_width + gap_px)
    P1 = at(c, ei, ni, s_o[0] - along, gi.half_width + gap_px)
    P2 = at(c, ej, nj, s_o[1] - along, -gj.half_width - gap_px)
    a1 = math.atan2(P1[1] - O[1], P1[0] - O[0])
    a2 = math.atan2(P2[1] - O[1], P2[0] - O[0])
    return [P0] + arc(O, outer, a1, a2), slip.island


def network_markings(net: Network, zebras: bool = True) -> tuple[list[list[Point]], list[list[Point]]]:
    """White road markings as polygons (pixels), RGB only.

    Sets each leg's ``marks_start``. ``zebras`` False leaves the zebra crossings
    out; the stop lines stay where they would be.

    Returns:
        ``(white, teeth)``: zebra stripes, stop lines, lane and centre lines, bike
        path centre lines; and give-way triangles at roundabout entries.
    """
    ppm, ring = net.ppm, net.roundabout
    white: list[list[Point]] = []
    teeth: list[list[Point]] = []
    for g in net.legs:
        if ring is not None:
            zebra0 = (ring.radius + ring.verge + ring.bike) * ppm + 1.0 * ppm
            teeth += _give_way_teeth(net, g)
        else:
            zebra0 = g.clear + 1.0 * ppm
        white += _leg_markings(net, g, zebra0, zebras)
    if ring is not None and ring.lanes > 1:
        white += _ring_lane_divider(net.centre, ring, ppm)
    return white, teeth


def _give_way_teeth(net: Network, g: LegGeometry) -> list[list[Point]]:
    """Give-way triangles across a roundabout entry (left = inbound)."""
    c, ppm = net.centre, net.ppm
    e, n = unit(g.angle), normal(g.angle)
    teeth = []
    z = g.clear + 0.3 * ppm
    lat = -g.median / 2 - 0.3 * ppm
    while lat - 0.5 * ppm > -g.half_width:
        teeth.append([at(c, e, n, z, lat), at(c, e, n, z, lat - 0.5 * ppm), at(c, e, n, z + 0.6 * ppm,
                                                                                lat - 0.25 * ppm)])
        lat -= 0.8 * ppm
    return teeth


def _leg_markings(net: Network, g: LegGeometry, zebra0: float, zebras: bool = True) -> list[list[Point]]:
    """One leg's zebra from ``zebra0`` px (unless ``zebras`` is False), stop line, centre and lane lines,
    bicycle-path centre lines."""
    c, ppm = net.centre, net.ppm
    thin = 0.15 * ppm
    white = []
    # zebra: 0.5 m stripes every metre along the road, sparing the median
    lat = -g.half_width + 0.5 * ppm
    while zebras and lat + 0.5 * ppm < g.half_width - 0.25 * ppm:
        if g.median == 0 or abs(lat + 0.25 * ppm) > g.median / 2 + 0.3 * ppm:
            white.append(strip(c, g.angle, lat, lat + 0.5 * ppm, zebra0, zebra0 + 4 * ppm))
        lat += 1.0 * ppm
    stop = zebra0 + 5 * ppm
    if net.roundabout is None:
        inbound = (-g.half_width + 0.2 * ppm, -g.median / 2 - 0.1 * ppm)
        white.append(strip(c, g.angle, *inbound, stop, stop + 0.4 * ppm))
    g.marks_start = stop + 0.4 * ppm
    white += _lane_lines(c, g, ppm, thin)
    for name, sign in (("left", -1.0), ("right", 1.0)):
        verge, bike, _ = g.offsets[name]
        if bike - verge >= 2.4 * ppm:  # two-way bicycle path: dashed centre line
            lat = sign * (verge + bike) / 2
            white += dashes(c, g.angle, lat, zebra0 + 6 * ppm, FAR, 1 * ppm, 1 * ppm, 0.1 * ppm)
    return white


def _lane_lines(c: Point, g: LegGeometry, ppm: float, thin: float) -> list[list[Point]]:
    """Centre line (without a median), lane dividers and edge lines of a leg from ``marks_start``."""
    white = []
    s0 = g.marks_start
    if g.median == 0:
        if g.leg.lanes == 1:
            white += dashes(c, g.angle, 0, s0 + 1 * ppm, FAR, 3 * ppm, 6 * ppm, thin)
        else:
            white.append(strip(c, g.angle, -thin, thin, s0, FAR))
    for sign in (-1.0, 1.0):
        for k in range(1, g.leg.lanes):
            lat = sign * (g.median / 2 + k * g.lane)
            white += dashes(c, g.angle, lat, s0 + 1 * ppm, FAR, 3 * ppm, 9 * ppm, thin)
        if g.leg.lanes > 1:
            lat = sign * (g.half_width - 0.35 * ppm)
            white.append(strip(c, g.angle, lat - thin / 2, lat + thin / 2, s0, FAR))
    return white


def _ring_lane_divider(c: Point, ring: Roundabout, ppm: float) -> list[list[Point]]:
    """Dashed lane divider on a roundabout's circulating carriageway."""
    thin = 0.15 * ppm
    r = (ring.radius - (ring.radius - ring.island - ring.apron) / 2) * ppm
    count = int(2 * math.pi * r / (4 * ppm))
    white = []
    for k in range(count):
        a0 = 2 * math.pi * k / count
        inner = arc(c, r - thin, a0, a0 + 0.5 * 2 * math.pi / count, 2.0)
        outer = arc(c, r + thin, a0, a0 + 0.5 * 2 * math.pi / count, 2.0)
        white.append(inner + outer[::-1])
    return white


def lane_centres(g: LegGeometry) -> list[tuple[float, float]]:
    """(lateral offset, driving sign) of every lane: +1 drives away from the junction."""
    out = []
    for sign in (-1.0, 1.0):
        for k in range(g.leg.lanes):
            out.append((sign * (g.median / 2 + (k + 0.5) * g.lane), sign))
    return out

