"""Reading an OpenStreetMap extract around a centre, in the OSM scene's frame (SPEC §4).

The frame (normative): a transverse Mercator projection centred on ``center``
(WGS84) gives metres east ``E`` and north ``N``; bird's-eye pixel
``u = (W − 1)/2 + E·ppm``, ``v = (H − 1)/2 − N·ppm`` (north up), ``W, H = size_m · ppm``.

:func:`read_osm` reads ``.osm``, ``.osm.pbf`` or ``.osm.bz2`` with pyosmium in one
streaming pass (two when the file holds multipolygon relations: osmium's area
assembly reads the relations first). Only objects whose keys can matter reach
Python (osmium's ``KeyFilter`` runs in C++), and of those only the ones whose
bounding box meets the window (plus a margin for carriageway widths and tree
crowns) are kept, so a large extract costs little more than reading it.

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

__all__ = ["Frame", "Feature", "OsmData", "read_osm", "MARGIN_M"]

# Features whose bounding box comes within this many metres of the window are kept:
# wide enough for the widest carriageway (its centre line may lie outside) and crowns.
MARGIN_M = 40.0


@dataclass(frozen=True)
class Frame:
    """The OSM scene's frame: centre (WGS84 degrees), size in metres and scale.

    Attributes:
        lat, lon: the centre.
        width_m, height_m: the window (east–west, north–south), metres.
        ppm: pixels per metre.
    """

    lat: float
    lon: float
    width_m: float
    height_m: float
    ppm: float

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
        """``(E, N)`` metres of WGS84 ``(lon, lat)`` degrees."""
        east, north = self._transformer().transform(np.asarray(lon, float), np.asarray(lat, float))
        return np.asarray(east, float), np.asarray(north, float)

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
        lon, lat = self._transformer(inverse=True).transform(xs, ys)
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
    """

    features: list[Feature] = field(default_factory=list)
    header_box: tuple[float, float, float, float] | None = None
    data_box: tuple[float, float, float, float] | None = None

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


def _line_bounds(wkb_hex: str) -> tuple[float, float, float, float]:
    """Bounds of a little-endian WKB linestring given as hex (what osmium's WKBFactory writes)."""
    coords = np.frombuffer(bytes.fromhex(wkb_hex), "<f8", offset=9).reshape(-1, 2)
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
        line = ("highway" in tags and tags.get("area") != "yes") or tags.get("natural") == "tree_row"
        closed = w.is_closed()
        if not (line or closed):
            return  # an open way of area tags: only a multipolygon's member, which osmium assembles
        try:
            wkb = self.wkb.create_linestring(w)
        except Exception:  # too few nodes or nodes missing from the extract
            return
        bounds = _line_bounds(wkb)
        self.data.extend_data_box(*bounds)
        if not _meets(bounds, self.box):
            return
        if closed:
            self.closed_in_box.add(w.id)
        if line:
            self.raw.append(("line", dict(tags), shapely.from_wkb(wkb), w.id))

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
