"""Reading an OpenStreetMap extract around a centre, in the OSM scene's frame (SPEC §4).

The frame (normative): a transverse Mercator projection centred on ``center``
(WGS84) gives metres east ``E`` and north ``N``; bird's-eye pixel
``u = (W − 1)/2 + E·ppm``, ``v = (H − 1)/2 − N·ppm`` (north up), ``W, H = size_m · ppm``.
A frame may be *turned* by ``rotation_deg`` ``r`` about the centre (default 0, the
normative north-up frame): ``(E, N)`` are then the projected metres turned clockwise
(as seen from above) by ``r``, ``E' = E cos r + N sin r``, ``N' = −E sin r + N cos r``,
so a line at bearing ``b`` (clockwise from north) runs at screen bearing ``b + r``
(clockwise from up: the image-angle sense, +u toward +v). Geometry is turned before it
is rasterised, never resampled as an image.

:func:`read_osm` reads ``.osm``, ``.osm.pbf`` or ``.osm.bz2`` with pyosmium in one
streaming pass (two when the file holds multipolygon relations: osmium's area
assembly reads the relations first). Only objects whose keys can matter reach
Python (osmium's ``KeyFilter`` runs in C++), and of those only the ones whose
bounding box meets the window (plus a margin for carriageway widths and tree
crowns) are kept, so a large extract costs little more than reading it. A way
whose nodes are partly missing from the extract (cut by the extract's box) is
kept as its runs of located nodes (:func:`located_runs`); the missing nodes are
counted (:class:`OsmData`).

Geometry is returned in metres ``(E, N)`` of the frame (shapely 2), not pixels:
left and right of a way are then the usual mathematical sides.

Example
-------
>>> frame = Frame(52.0, 5.0, 130.0, 190.0, 10.0)
>>> frame.width, frame.height
(1300, 1900)
>>> [round(float(c), 3) for c in frame.pixels(0.0, 0.0)]
[649.5, 949.5]
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from ..base import SceneError

__all__ = ["Frame", "Feature", "OsmData", "read_osm", "located_runs", "MARGIN_M"]

# Features whose bounding box comes within this many metres of the window are kept:
# wide enough for the widest carriageway (its centre line may lie outside) and crowns.
MARGIN_M = 40.0


def _turn(east: np.ndarray, north: np.ndarray, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Points turned clockwise (seen from above, north up) by ``angle_deg`` about the origin."""
    if angle_deg == 0.0:
        return east, north  # the north-up frame's numbers, bit for bit
    a = math.radians(angle_deg)
    cos, sin = math.cos(a), math.sin(a)
    return east * cos + north * sin, north * cos - east * sin


@dataclass(frozen=True)
class Frame:
    """The OSM scene's frame: centre (WGS84 degrees), size in metres and scale.

    Attributes:
        lat, lon: the centre.
        width_m, height_m: the window (east–west, north–south), metres.
        ppm: pixels per metre.
        rotation_deg: the turn ``r`` of the frame (module docstring): a bearing ``b`` is drawn at ``b + r``.
    """

    lat: float
    lon: float
    width_m: float
    height_m: float
    ppm: float
    rotation_deg: float = 0.0

    @property
    def width(self) -> int:
        """W = round(width_m · ppm) pixels."""
        return int(round(self.width_m * self.ppm))

    @property
    def height(self) -> int:
        """H = round(height_m · ppm) pixels."""
        return int(round(self.height_m * self.ppm))

    @property
    def proj_string(self) -> str:
        """The transverse Mercator centred on the centre (pyproj/PROJ syntax)."""
        return (f"+proj=tmerc +lat_0={self.lat!r} +lon_0={self.lon!r} +k=1 +x_0=0 +y_0=0 "
                "+ellps=WGS84 +units=m +no_defs")

    def _transformer(self, inverse: bool = False) -> Any:
        from pyproj import Transformer

        src, dst = "EPSG:4326", self.proj_string
        return Transformer.from_crs(dst, src, always_xy=True) if inverse else \
            Transformer.from_crs(src, dst, always_xy=True)

    def metres(self, lon: np.ndarray | float, lat: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """``(E, N)`` metres of WGS84 ``(lon, lat)`` degrees, in the turned frame."""
        east, north = self._transformer().transform(np.asarray(lon, float), np.asarray(lat, float))
        return _turn(np.asarray(east, float), np.asarray(north, float), self.rotation_deg)

    def pixels(self, east: np.ndarray | float, north: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Bird's-eye ``(u, v)`` of frame metres ``(E, N)``."""
        u = (self.width - 1) / 2 + np.asarray(east, float) * self.ppm
        v = (self.height - 1) / 2 - np.asarray(north, float) * self.ppm
        return u, v

    def to_pixels(self, geometry: Any) -> Any:
        """A shapely geometry (or array of them) from metres to pixels."""
        def move(xy: np.ndarray) -> np.ndarray:
            u, v = self.pixels(xy[:, 0], xy[:, 1])
            return np.stack([u, v], -1)
        return shapely.transform(geometry, move)

    def window(self, margin_m: float = 0.0) -> shapely.Polygon:
        """The scene rectangle in metres (pixel edges ±0.5 px), grown by ``margin_m``."""
        half_w = self.width / 2 / self.ppm + margin_m
        half_h = self.height / 2 / self.ppm + margin_m
        return shapely.box(-half_w, -half_h, half_w, half_h)

    def lonlat_box(self, margin_m: float) -> tuple[float, float, float, float]:
        """``(west, south, east, north)`` degrees enclosing the window grown by ``margin_m``."""
        x0, y0, x1, y1 = self.window(margin_m).bounds
        xs = np.array([x0, x1, x1, x0, 0.0, 0.0, x0, x1])
        ys = np.array([y0, y0, y1, y1, y0, y1, 0.0, 0.0])
        lon, lat = self._transformer(inverse=True).transform(*_turn(xs, ys, -self.rotation_deg))
        pad = 1e-6  # degrees (≈ 0.1 m): the corners' rounding
        return float(np.min(lon)) - pad, float(np.min(lat)) - pad, float(np.max(lon)) + pad, float(np.max(lat)) + pad


@dataclass(frozen=True)
class Feature:
    """One OSM object in the window.

    Attributes:
        kind: ``"line"`` (a way), ``"area"`` (a closed way or multipolygon) or ``"point"`` (a node).
        tags: its tags.
        geometry: shapely geometry in frame metres ``(E, N)``.
        osm_id: the object's id (areas: osmium's area id).
    """

    kind: str
    tags: dict[str, str]
    geometry: Any
    osm_id: int


@dataclass
class OsmData:
    """What :func:`read_osm` found.

    Attributes:
        features: the features meeting the window, in file order (nodes, ways, areas as osmium gives them).
        header_box: ``(west, south, east, north)`` of the file's header, or None.
        data_box: ``(west, south, east, north)`` of every relevant object read (anywhere), or None.
        missing_nodes: nodes without a location in the extract, of the ways that reach the window
            (their located runs are kept: :func:`located_runs`).
        cut_ways: how many of those ways miss nodes.
    """

    features: list[Feature] = field(default_factory=list)
    header_box: tuple[float, float, float, float] | None = None
    data_box: tuple[float, float, float, float] | None = None
    missing_nodes: int = 0
    cut_ways: int = 0

    def extend_data_box(self, west: float, south: float, east: float, north: float) -> None:
        if self.data_box is None:
            self.data_box = (west, south, east, north)
        else:
            a = self.data_box
            self.data_box = (min(a[0], west), min(a[1], south), max(a[2], east), max(a[3], north))


def _header_box(path: Path) -> tuple[float, float, float, float] | None:
    import osmium

    with osmium.io.Reader(str(path), osmium.osm.NOTHING) as reader:
        box = reader.header().box()
    if not box.valid():
        return None
    bl, tr = box.bottom_left, box.top_right
    return (bl.lon, bl.lat, tr.lon, tr.lat)


def located_runs(nodes: Iterable[Any]) -> tuple[list[list[tuple[float, float]]], int]:
    """A way's runs of consecutive located nodes, and how many of its nodes have no location.

    An extract cut by a box keeps the ways that cross its edge but not their nodes
    outside it; joining the located nodes across such a gap would draw a straight
    road that is not there, so the way is cut at every gap instead.

    Args:
        nodes: the way's node references (osmium ``NodeRef``: ``location.valid()``,
            ``location.lon``, ``location.lat``).

    Returns:
        ``(runs, missing)``: runs of ≥ 2 ``(lon, lat)`` points (a located node
        alone between gaps is dropped), and the number of nodes without a location.

    >>> from types import SimpleNamespace as NS
    >>> def ref(lon): return NS(location=NS(valid=lambda: lon is not None, lon=lon, lat=0.0))
    >>> located_runs([ref(None), ref(1.0), ref(2.0), ref(None), ref(3.0), ref(4.0), ref(5.0), ref(None)])
    ([[(1.0, 0.0), (2.0, 0.0)], [(3.0, 0.0), (4.0, 0.0), (5.0, 0.0)]], 3)
    """
    runs: list[list[tuple[float, float]]] = []
    run: list[tuple[float, float]] = []
    missing = 0
    for node in nodes:
        location = node.location
        if location.valid():
            run.append((location.lon, location.lat))
            continue
        missing += 1
        if len(run) >= 2:
            runs.append(run)
        run = []
    if len(run) >= 2:
        runs.append(run)
    return runs, missing


def _runs_bounds(runs: Sequence[Sequence[tuple[float, float]]]) -> tuple[float, float, float, float]:
    coords = np.array([point for run in runs for point in run])
    low, high = coords.min(0), coords.max(0)
    return float(low[0]), float(low[1]), float(high[0]), float(high[1])


def _meets(bounds: Sequence[float], box: Sequence[float]) -> bool:
    return bounds[0] <= box[2] and bounds[2] >= box[0] and bounds[1] <= box[3] and bounds[3] >= box[1]


def is_line_way(tags: dict[str, str]) -> bool:
    """Whether a way is read as a line (roads, paths, tree rows) rather than through its area twin."""
    return ("highway" in tags and tags.get("area") != "yes") or tags.get("natural") == "tree_row"


class _Collector:
    """Turns the objects osmium hands over into features inside the box."""

    def __init__(self, box: tuple[float, float, float, float], data: OsmData) -> None:
        import osmium

        self.box, self.data = box, data
        self.wkb = osmium.geom.WKBFactory()
        self.raw: list[tuple[str, dict[str, str], Any, int]] = []
        self.closed_in_box: set[int] = set()  # closed ways meeting the box: their areas are wanted

    def node(self, n: Any) -> None:
        lon, lat = n.location.lon, n.location.lat
        self.data.extend_data_box(lon, lat, lon, lat)
        if _meets((lon, lat, lon, lat), self.box):
            self.raw.append(("point", dict(n.tags), shapely.Point(lon, lat), n.id))

    def way(self, w: Any) -> None:
        tags = w.tags
        line = is_line_way(tags)
        closed = w.is_closed()
        if not (line or closed):
            return  # an open way of area tags: only a multipolygon's member, which osmium assembles
        runs, missing = located_runs(w.nodes)
        if not runs:
            return  # fewer than two located nodes in a row: nothing to draw
        bounds = _runs_bounds(runs)
        self.data.extend_data_box(*bounds)
        if not _meets(bounds, self.box):
            return
        if missing:
            self.data.missing_nodes += missing
            self.data.cut_ways += 1
        if closed:
            self.closed_in_box.add(w.id)
        if line:
            self.raw.extend(("line", dict(tags), shapely.LineString(run), w.id) for run in runs)

    def area(self, a: Any) -> None:
        if a.from_way() and a.orig_id() not in self.closed_in_box:
            return  # its way lies outside the box (osmium hands over a way before its area)
        try:
            geometry = shapely.from_wkb(self.wkb.create_multipolygon(a))
        except Exception:  # broken multipolygon: osmium could not close its rings
            return
        bounds = geometry.bounds
        self.data.extend_data_box(*bounds)
        if not _meets(bounds, self.box):
            return
        tags = dict(a.tags)
        if a.from_way() and is_line_way(tags):
            return  # a closed road or tree row: read as its line
        self.raw.append(("area", tags, geometry, a.id))


def read_osm(path: str | Path, frame: Frame, keys: Iterable[str], margin_m: float = MARGIN_M) -> OsmData:
    """Read the features of an extract that come within ``margin_m`` of the window.

    Args:
        path: ``.osm``, ``.osm.pbf`` or ``.osm.bz2`` file.
        frame: the scene's frame.
        keys: tag keys that make an object relevant (others never reach Python).
        margin_m: features this close to the window are kept.

    Returns:
        The features (geometry in frame metres), the header's box and the data's box.

    Raises:
        SceneError: the file cannot be read as OSM data (message names the file).
    """
    import osmium

    path = Path(path)
    keys = sorted(set(keys))
    data = OsmData()
    collector = _Collector(frame.lonlat_box(margin_m), data)
    try:
        data.header_box = _header_box(path)
        processor = (osmium.FileProcessor(str(path)).with_locations("flex_mem")
                     .with_areas(osmium.filter.KeyFilter(*keys)).with_filter(osmium.filter.KeyFilter(*keys)))
        obj: Any
        for obj in processor:
            if obj.is_node():
                collector.node(obj)
            elif obj.is_way():
                collector.way(obj)
            elif obj.is_area():
                collector.area(obj)
    except (RuntimeError, ValueError, OSError) as exc:
        raise SceneError(f"{path}: cannot read the file as OpenStreetMap data (.osm, .osm.pbf or .osm.bz2): "
                         f"{str(exc).strip() or type(exc).__name__}") from None
    _project(collector.raw, frame, data)
    return data


def _project(raw: list[tuple[str, dict[str, str], Any, int]], frame: Frame, data: OsmData) -> None:
    """Move the collected lon/lat geometries into frame metres, in one vectorised call."""
    if not raw:
        return

    def move(xy: np.ndarray) -> np.ndarray:
        east, north = frame.metres(xy[:, 0], xy[:, 1])
        return np.stack([east, north], -1)

    geometries = shapely.transform(np.array([r[2] for r in raw], dtype=object), move)
    window = frame.window(MARGIN_M)
    for (kind, tags, _, osm_id), geometry in zip(raw, geometries, strict=True):
        if geometry.is_empty or not geometry.intersects(window):
            continue
        data.features.append(Feature(kind, tags, geometry, int(osm_id)))


def centre_inside(box: tuple[float, float, float, float] | None, lat: float, lon: float) -> bool:
    """Whether ``(lat, lon)`` lies in a ``(west, south, east, north)`` box (True when there is none)."""
    if box is None:
        return True
    west, south, east, north = box
    return south <= lat <= north and west <= lon <= east and not math.isnan(lat + lon)
