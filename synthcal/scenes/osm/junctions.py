"""A catalogue of an extract's road junctions, rankable by likeness to a layout (SPEC §4).

What counts
-----------
*Roads* are ways tagged ``highway`` = one of :data:`ROADS` (motorway … residential,
unclassified, living_street, service and the ``_link`` kinds), without ``area=yes``.
A node's *legs* are the road ways leaving it: a way passing through the node counts 2,
a way starting or ending there 1 (a closed way through its first node: 2). A *junction*
is a node with 3 or more legs — two ways joined end to end, or a bend, are not.

Each leg's *bearing* is the compass direction (degrees clockwise from north, 0–360)
from the node to the point 20 m along the leg (:data:`BEARING_REACH_M`; the leg's far
end when it is shorter), in a local tangent plane: far enough to see past the short
first segments OSM ways often have at a junction. ``road_classes`` are the distinct
``highway`` values of the legs; ``cycleway`` tells whether a cycle way touches the node
(``highway=cycleway``, or a path, footway or bridleway with ``bicycle=designated``: the
OSM scene's bicycle-path selectors) or one of its roads carries a cycle track or lane
(``cycleway[:left|:right|:both]=track|lane``).

Likeness
--------
:func:`layout_difference` compares two sets of bearings: the mean angular distance from
each leg to the nearest leg of the other set, averaged both ways, minimised over
rotations (a camera grid's pans cover every direction, so a turned copy of a layout is
the same layout for a dataset). :func:`layout_rotation` is the rotation that minimum is
found at: the turn ``r`` (degrees, clockwise on a north-up map) that brings the legs onto
the reference's, ``bearing + r`` ≈ a reference bearing — what an OSM scene's
``rotation_deg`` takes to draw the junction with its legs along the reference's (its
frame, and its cameras' poses, then aligned with the built-in intersection's). Of equal
minima (a symmetric reference: a cross's every 90°) the smallest turn is taken, the
clockwise one on a tie. :func:`rank` orders junctions by the difference in leg
count to the reference, then by that difference, then by node id. The built-in
intersections' legs (:data:`synthcal.scenes.intersection.LAYOUTS`, image angles: 0° = +u,
east on screen, 90° = +v, south) give their bearings as ``angle + 90°``.

Example
-------
>>> layout_difference((0.0, 90.0, 180.0, 270.0), (30.0, 120.0, 210.0, 300.0))
0.0
>>> layout_rotation((35.0, 125.0, 215.0, 305.0), (0.0, 90.0, 180.0, 270.0))
-35.0
>>> layout_bearings("intersection-1")
(0.0, 90.0, 180.0, 270.0)
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..base import SceneError
from .classes import DEFAULT_CLASSES, parse_selector, strips

__all__ = ["ROADS", "BEARING_REACH_M", "Junction", "find_junctions", "layout_bearings", "layout_difference", "layout_rotation", "rank",
           "write_csv", "datasets_snippet", "mix_name"]

ROADS = frozenset({"motorway", "trunk", "primary", "secondary", "tertiary", "unclassified", "residential",
                   "living_street", "service", "motorway_link", "trunk_link", "primary_link", "secondary_link",
                   "tertiary_link"})
BEARING_REACH_M = 20.0
_EARTH_RADIUS_M = 6371008.8
# The OSM scene's own selectors of separate cycle ways (not its area:highway one: areas have no legs).
_CYCLE_WAYS = tuple(parse_selector(text, "bicycle path") for text in DEFAULT_CLASSES["bicycle path"][:2])
CSV_COLUMNS = ("node_id", "lat", "lon", "legs", "bearings", "road_classes", "cycleway", "difference_deg",
               "rotation_deg")


@dataclass(frozen=True)
class Junction:
    """One road junction of an extract.

    Attributes:
        node_id: the OSM node id.
        lat, lon: its position, WGS84 degrees.
        legs: road ways leaving it (module docstring).
        bearings: the legs' bearings, degrees clockwise from north, ascending.
        road_classes: the legs' distinct ``highway`` values, sorted.
        cycleway: whether a cycle way or a road's cycle strip touches it.
        difference: :func:`layout_difference` to the reference of :func:`rank` (NaN before ranking).
        rotation: :func:`layout_rotation` onto that reference, degrees clockwise (NaN before ranking).
    """

    node_id: int
    lat: float
    lon: float
    legs: int
    bearings: tuple[float, ...]
    road_classes: tuple[str, ...]
    cycleway: bool
    difference: float = float("nan")
    rotation: float = float("nan")


@dataclass
class _Road:
    """A road way as read: its nodes' ids and (lon, lat) degrees, its class, whether it has cycle strips."""

    refs: list[int]
    lonlat: np.ndarray
    highway: str
    strips: bool


class _Reader:
    """Collects road ways and the nodes cycle ways touch, in one pass."""

    def __init__(self) -> None:
        self.roads: list[_Road] = []
        self.cycle_nodes: set[int] = set()
        self.box: list[float] | None = None  # west, south, east, north of every road read

    def way(self, w: Any) -> None:
        tags = dict(w.tags)
        road = tags.get("highway") in ROADS and tags.get("area") != "yes"
        if not road and not any(s.matches(tags) for s in _CYCLE_WAYS):
            return
        refs = [n.ref for n in w.nodes]
        if not road:
            self.cycle_nodes.update(refs)
            return
        if len(refs) < 2 or not all(n.location.valid() for n in w.nodes):
            return  # nodes missing from the extract: no geometry to measure
        lonlat = np.array([(n.location.lon, n.location.lat) for n in w.nodes], np.float64)
        self.roads.append(_Road(refs, lonlat, tags["highway"], bool(strips(tags, 1.0))))
        low, high = lonlat.min(0), lonlat.max(0)
        box = self.box or [low[0], low[1], high[0], high[1]]
        self.box = [min(box[0], low[0]), min(box[1], low[1]), max(box[2], high[0]), max(box[3], high[1])]


def _read(path: Path) -> _Reader:
    import osmium

    reader = _Reader()
    obj: Any
    try:
        processor = (osmium.FileProcessor(str(path)).with_locations("flex_mem")
                     .with_filter(osmium.filter.KeyFilter("highway")))
        for obj in processor:
            if obj.is_way():
                reader.way(obj)
    except (RuntimeError, ValueError, OSError) as exc:
        raise SceneError(f"{path}: cannot read the file as OpenStreetMap data (.osm, .osm.pbf or .osm.bz2): "
                         f"{str(exc).strip() or type(exc).__name__}") from None
    return reader


def _bearing(lonlat: np.ndarray) -> float:
    """Bearing from ``lonlat[0]`` to the point :data:`BEARING_REACH_M` along the polyline (local tangent plane)."""
    scale = np.array([math.cos(math.radians(lonlat[0, 1])), 1.0]) * math.radians(1.0) * _EARTH_RADIUS_M
    metres = (lonlat - lonlat[0]) * scale  # east, north
    steps = np.hypot(*np.diff(metres, axis=0).T)
    reach = np.concatenate([[0.0], np.cumsum(steps)])
    end = int(np.searchsorted(reach, BEARING_REACH_M))
    if end >= len(reach):
        point = metres[-1]
    else:  # interpolate on the segment that crosses the reach
        t = (BEARING_REACH_M - reach[end - 1]) / steps[end - 1]
        point = metres[end - 1] + t * (metres[end] - metres[end - 1])
    return math.degrees(math.atan2(point[0], point[1])) % 360.0


def find_junctions(path: str | Path, bbox: Sequence[float] | None = None, legs: int | None = None) -> list[Junction]:
    """The road junctions of an extract (module docstring), in node-id order.

    Args:
        path: ``.osm``, ``.osm.pbf`` or ``.osm.bz2`` extract.
        bbox: ``(west, south, east, north)`` degrees: only junctions inside it.
        legs: only junctions with exactly this many legs.

    Returns:
        The junctions found (never empty).

    Raises:
        SceneError: an unreadable file, a ``bbox`` that misses the extract's roads, or no
            junction (with the filters asked for); one line naming the file.
    """
    path = Path(path)
    reader = _read(path)
    box = _box_text(bbox) if bbox is not None else ""
    if reader.box is None:
        raise SceneError(f"{path}: no road ways (highway={'|'.join(sorted(ROADS))}), so no junctions")
    west, south, east, north = reader.box
    if bbox is not None and (bbox[0] > east or bbox[2] < west or bbox[1] > north or bbox[3] < south):
        raise SceneError(f"{path}: bbox {box} lies outside the extract's roads "
                         f"({west:.6f},{south:.6f},{east:.6f},{north:.6f})")
    junctions = []
    for node_id, members in sorted(_crossings(reader.roads).items()):
        road, i = members[0]
        lon, lat = road.lonlat[i]
        if bbox is not None and not (bbox[0] <= lon <= bbox[2] and bbox[1] <= lat <= bbox[3]):
            continue
        junction = _junction(node_id, members, node_id in reader.cycle_nodes)
        if junction.legs >= 3 and (legs is None or junction.legs == legs):
            junctions.append(junction)
    if not junctions:
        asked = (f" inside bbox {box}" if bbox is not None else "") + (f" with {legs} legs" if legs is not None else "")
        raise SceneError(f"{path}: no road junctions (nodes with 3 or more road legs){asked}")
    return junctions


def _box_text(bbox: Sequence[float]) -> str:
    return ",".join(f"{v:g}" for v in bbox)


def _crossings(roads: Sequence[_Road]) -> dict[int, list[tuple[_Road, int]]]:
    """Node id → the (road, position) pairs it is on, for nodes on two or more (only they can have 3 legs)."""
    count: dict[int, int] = {}
    for road in roads:
        for ref in road.refs:
            count[ref] = count.get(ref, 0) + 1
    where: dict[int, list[tuple[_Road, int]]] = {}
    for road in roads:
        for i, ref in enumerate(road.refs):
            if count[ref] > 1:
                where.setdefault(ref, []).append((road, i))
    return where


def _junction(node_id: int, members: Sequence[tuple[_Road, int]], cycle: bool) -> Junction:
    """A node's legs: each road it is on, backwards to the road's start and forwards to its end."""
    bearings, classes = [], set()
    for road, i in members:
        for part in (road.lonlat[i::-1], road.lonlat[i:]):
            if len(part) > 1:
                bearings.append(_bearing(part))
        classes.add(road.highway)
        cycle = cycle or road.strips
    lon, lat = members[0][0].lonlat[members[0][1]]
    return Junction(node_id, float(lat), float(lon), len(bearings), tuple(sorted(bearings)), tuple(sorted(classes)),
                    cycle)


def layout_bearings(scene: str) -> tuple[float, ...]:
    """The leg bearings of a built-in intersection (degrees clockwise from north, ascending).

    Raises:
        SceneError: ``scene`` is not a built-in intersection (names the choices).
    """
    from ..intersection import LAYOUTS

    if scene not in LAYOUTS:
        raise SceneError(f"--like: {scene!r} is not a built-in intersection; one of {', '.join(LAYOUTS)}")
    return tuple(sorted((leg.angle + 90.0) % 360.0 for leg in LAYOUTS[scene].legs))


def layout_difference(bearings: Sequence[float], reference: Sequence[float]) -> float:
    """How far two layouts' legs lie apart, in degrees, whatever their orientation (module docstring).

    Args:
        bearings: (n,) leg bearings in degrees.
        reference: (m,) leg bearings in degrees.

    Returns:
        The symmetric mean nearest-leg angular distance, minimised over rotations: 0 for
        a turned copy, at most 90 for two legs each.
    """
    return _best_turn(bearings, reference)[0]


def layout_rotation(bearings: Sequence[float], reference: Sequence[float]) -> float:
    """The turn that lines ``bearings`` up with ``reference`` (module docstring).

    Args:
        bearings: (n,) leg bearings in degrees (clockwise from north).
        reference: (m,) leg bearings in degrees.

    Returns:
        ``r`` in (−180, 180]: the legs turned clockwise by ``r`` (``bearing + r``) lie at
        :func:`layout_difference` from the reference; the smallest such turn, the
        clockwise one on a tie.
    """
    return _best_turn(bearings, reference)[1]


# Costs this close count as equal: a symmetric reference's minima differ by rounding only.
_TIE_DEG = 1e-6


def _best_turn(bearings: Sequence[float], reference: Sequence[float]) -> tuple[float, float]:
    """``(difference, rotation)``: the least symmetric nearest-leg distance over rotations, and where."""
    a, b = np.asarray(bearings, np.float64), np.asarray(reference, np.float64)
    # The cost is piecewise linear in the rotation with its minima where two legs align.
    shifts = (b[:, None] - a[None, :]).ravel()
    distance = np.abs((a[None, :, None] + shifts[:, None, None] - b[None, None, :] + 180.0) % 360.0 - 180.0)
    costs = (distance.min(2).mean(1) + distance.min(1).mean(1)) / 2
    turns = 180.0 - (180.0 - shifts) % 360.0  # in (−180, 180]
    best = float(costs.min())
    tied = turns[costs <= best + _TIE_DEG]
    return best, float(min(tied, key=lambda t: (abs(t), -t)))


def rank(junctions: Iterable[Junction], like: str) -> list[Junction]:
    """Junctions most like a built-in intersection first, each with its :func:`layout_difference`
    and :func:`layout_rotation` onto it.

    Order: difference in leg count, then layout difference, then node id.
    """
    reference = layout_bearings(like)
    scored = []
    for j in junctions:
        difference, rotation = _best_turn(j.bearings, reference)
        scored.append(replace(j, difference=difference, rotation=rotation))
    return sorted(scored, key=lambda j: (abs(j.legs - len(reference)), j.difference, j.node_id))


def write_csv(junctions: Sequence[Junction], path: str | Path) -> None:
    """The catalogue as CSV (:data:`CSV_COLUMNS`; lists joined by ``;``, difference and rotation empty
    unless ranked)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(CSV_COLUMNS)
        for j in junctions:
            writer.writerow([j.node_id, f"{j.lat:.7f}", f"{j.lon:.7f}", j.legs, ";".join(f"{b:.1f}" for b in j.bearings),
                             ";".join(j.road_classes), str(j.cycleway).lower(),
                             *("" if math.isnan(v) else f"{v:.2f}" for v in (j.difference, j.rotation))])


def mix_name(target: str, count: int) -> str:
    """The second store of a built-in intersection whose dictionary is ``count`` junctions:
    ``osm<count>-<k>`` for ``intersection-<k>`` (bench label ``mixed-osm<count>-<k>``)."""
    return f"osm{count}-{target.removeprefix('intersection-')}"


def datasets_snippet(junctions: Sequence[Junction], extract: str | Path, folder: str | Path,
                     size_m: tuple[float, float] = (130.0, 190.0), pool_size: int = 200000,
                     mix_for: str | None = None, align_to: str | None = None) -> str:
    """A ``datasets.yaml`` snippet: each junction an OSM scene and a dataset, and mixed dictionaries.

    Scene and dataset ``osm-<node id>`` (``osm:`` centred on the node, the paper's
    intersection grid). Without ``mix_for``, with two or more junctions, every one is a
    mixed-dictionary target whose templates come from all the others (the paper's mixed
    experiments). With ``mix_for`` (a built-in intersection), the one target is instead a
    second store of that intersection (:func:`mix_name`, ``same_pool_as`` it: the same pool
    and splits, bit for bit, as the packaged family mixes) whose templates come from all
    the junctions: real junctions standing in for the paper's "other intersections".

    Aligned: with a layout to align to (``mix_for``, else ``align_to``), each scene is turned
    (``rotation_deg``, :func:`layout_rotation`) so that its legs lie along that built-in
    intersection's, and its cameras' pans and homographies mean what the intersection's do;
    without one, north up.

    Args:
        junctions: the junctions, e.g. the top K of :func:`rank`.
        extract: the extract's path.
        folder: where the merged ``datasets.yaml`` will live (``file:`` is relative to it).
        size_m: the scenes' window in metres.
        pool_size: each dataset's pool (the packaged intersections' 200,000 where ``mix_for``
            is given: ``same_pool_as`` requires the same).
        mix_for: a built-in intersection, e.g. ``intersection-1``.
        align_to: a built-in intersection the scenes are turned onto when ``mix_for`` is None
            (e.g. ``--like``'s).

    Returns:
        YAML text with top-level ``scenes``, ``datasets`` and (K ≥ 2, or ``mix_for``)
        ``mixed_dictionaries``.

    Raises:
        SceneError: ``mix_for`` or ``align_to`` is not a built-in intersection.
    """
    names = [f"osm-{j.node_id}" for j in junctions]
    file = os.path.relpath(Path(extract).resolve(), Path(folder).resolve())
    align = mix_for or align_to
    reference = layout_bearings(align) if align else None
    scenes = {}
    for name, j in zip(names, junctions, strict=True):
        osm: dict[str, Any] = {"file": file, "center": [round(j.lat, 7), round(j.lon, 7)], "size_m": list(size_m),
                               "pixels_per_metre": 10.0, "seed": 0}
        if reference is not None:
            osm["rotation_deg"] = round(layout_rotation(j.bearings, reference), 2)
        scenes[name] = {"osm": osm}
    datasets = {name: {"scene": name, "grid": "intersection", "pool_size": pool_size} for name in names}
    snippet: dict[str, Any] = {"scenes": scenes, "datasets": datasets}
    if mix_for is not None:
        target = mix_name(mix_for, len(names))
        datasets[target] = {"scene": mix_for, "grid": "intersection", "pool_size": pool_size, "same_pool_as": mix_for}
        snippet["mixed_dictionaries"] = {target: names}
    elif len(names) > 1:
        snippet["mixed_dictionaries"] = {name: [other for other in names if other != name] for name in names}
    header = (f"# {len(names)} road junctions of {Path(extract).name} (synthcal osm-junctions). Merge each block into\n"
              "# the same block of a datasets.yaml in this folder (osm file paths are relative to it).\n"
              "# Map data © OpenStreetMap contributors, ODbL.\n")
    if align:
        header += (f"# Aligned: each osm scene is turned by rotation_deg (clockwise) so that its legs lie along {align}'s\n"
                   f"# (the turn that minimises difference_deg), so its templates' poses are in {align}'s frame.\n")
    if mix_for is not None:
        header += (f"# Bench label mixed-{mix_name(mix_for, len(names))}: {mix_for}'s train/test sets, templates from "
                   "these junctions.\n")
    return header + yaml.safe_dump(snippet, sort_keys=False, default_flow_style=None, allow_unicode=True)
