"""OSM XML fixtures for the OSM scene tests, written from metres in the scene frame.

Everything is placed in metres east ``E`` and north ``N`` of the centre and moved
to WGS84 through the frame's transverse Mercator (SPEC §4), so a test can ask
"what class is at (E, N)?" and find the pixel with the frame's formula alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pyproj import Transformer

CENTER = (52.0, 5.0)  # lat, lon


def _proj(center: Sequence[float]) -> str:
    lat, lon = center
    return f"+proj=tmerc +lat_0={lat!r} +lon_0={lon!r} +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m +no_defs"


def to_lonlat(east: float, north: float, center: Sequence[float] = CENTER) -> tuple[float, float]:
    """WGS84 (lon, lat) of frame metres."""
    lon, lat = Transformer.from_crs(_proj(center), "EPSG:4326", always_xy=True).transform(east, north)
    return float(lon), float(lat)


def pixel(east: float, north: float, size_px: tuple[int, int], ppm: float) -> tuple[int, int]:
    """Nearest pixel (row, column) of frame metres: u = (W − 1)/2 + E·ppm, v = (H − 1)/2 − N·ppm."""
    width, height = size_px
    u = (width - 1) / 2 + east * ppm
    v = (height - 1) / 2 - north * ppm
    return int(round(v)), int(round(u))


def metres_of(lon: float, lat: float, center: Sequence[float] = CENTER) -> tuple[float, float]:
    """Frame metres of WGS84 (lon, lat), through an independent transformer."""
    east, north = Transformer.from_crs("EPSG:4326", _proj(center), always_xy=True).transform(lon, lat)
    return float(east), float(north)


def ahead(origin: tuple[float, float], bearing: float, distance: float) -> tuple[float, float]:
    """Frame metres ``distance`` from ``origin`` at ``bearing`` (degrees clockwise from north)."""
    return origin[0] + distance * math.sin(math.radians(bearing)), origin[1] + distance * math.cos(math.radians(bearing))


class OsmXml:
    """A tiny OSM XML writer: nodes at frame metres, ways over them."""

    def __init__(self, center: Sequence[float] = CENTER) -> None:
        self.center = center
        self.nodes: list[str] = []
        self.ways: list[str] = []
        self.ids: dict[tuple[float, float], int] = {}
        self.next_id = 1

    def node(self, east: float, north: float, tags: dict[str, str] | None = None, absent: bool = False) -> int:
        """A node's id; ``absent``: the id only, the node left out of the file (outside the extract)."""
        key = (round(east, 3), round(north, 3))
        if key in self.ids and not tags:
            return self.ids[key]
        lon, lat = to_lonlat(east, north, self.center)
        node_id = self.next_id
        self.next_id += 1
        if absent:
            return node_id
        body = "".join(f'<tag k="{k}" v="{v}"/>' for k, v in (tags or {}).items())
        self.nodes.append(f'<node id="{node_id}" version="1" lat="{lat:.9f}" lon="{lon:.9f}">{body}</node>')
        self.ids[key] = node_id
        return node_id

    def way(self, points: Sequence[tuple[float, float]], tags: dict[str, str], closed: bool = False,
            absent: Sequence[int] = ()) -> None:
        """A way over nodes at ``points``; those at positions ``absent`` are referred to but not written."""
        refs = [self.node(e, n, absent=i in absent) for i, (e, n) in enumerate(points)]
        if closed:
            refs.append(refs[0])
        body = "".join(f'<nd ref="{r}"/>' for r in refs) + "".join(f'<tag k="{k}" v="{v}"/>' for k, v in tags.items())
        self.ways.append(f'<way id="{len(self.ways) + 1}" version="1">{body}</way>')

    def write(self, path: Path, bounds_m: float = 300.0) -> Path:
        (w, s), (e, n) = to_lonlat(-bounds_m, -bounds_m, self.center), to_lonlat(bounds_m, bounds_m, self.center)
        text = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="synthcal-tests">',
                f'<bounds minlat="{s:.7f}" minlon="{w:.7f}" maxlat="{n:.7f}" maxlon="{e:.7f}"/>',
                *self.nodes, *self.ways, "</osm>"]
        path.write_text("\n".join(text))
        return path


def junction(path: Path, primary: dict[str, str] | None = None) -> Path:
    """The test junction (metres from the centre):

    * a two-lane primary road west–east along N = 0 (two ways meeting at the centre),
      with a crossing node at E = −20;
    * a residential street from the centre north (``cycleway:right=track``: the track
      lies east of it) and a plain one south;
    * a separate ``highway=cycleway`` along N = −15 (crossing the southern street);
    * a park (E −40..−8, N 10..35) with a tree, and a building (E 10..25, N 10..25).
    """
    osm = OsmXml()
    tags = {"highway": "primary", "lanes": "2", **(primary or {})}
    crossing = (-20.0, 0.0)
    osm.node(*crossing, {"highway": "crossing", "crossing": "zebra"})
    osm.way([(-150.0, 0.0), crossing, (0.0, 0.0)], tags)
    osm.way([(0.0, 0.0), (150.0, 0.0)], tags)
    osm.way([(0.0, 0.0), (0.0, 150.0)], {"highway": "residential", "cycleway:right": "track"})
    osm.way([(0.0, 0.0), (0.0, -150.0)], {"highway": "residential"})
    osm.way([(-150.0, -15.0), (150.0, -15.0)], {"highway": "cycleway"})
    osm.way([(-40.0, 10.0), (-8.0, 10.0), (-8.0, 35.0), (-40.0, 35.0)], {"leisure": "park"}, closed=True)
    osm.way([(10.0, 10.0), (25.0, 10.0), (25.0, 25.0), (10.0, 25.0)], {"building": "yes"}, closed=True)
    osm.node(-25.0, 22.0, {"natural": "tree"})
    return osm.write(path)


def columns_of_class(semantic: np.ndarray, row: int, cls: int) -> int:
    """How many pixels of ``cls`` a row holds."""
    return int((semantic[row] == cls).sum())
