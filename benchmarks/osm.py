"""Building an OpenStreetMap scene from a large and a small extract, against reading the file with pyosmium.

A synthetic city is written once with pyosmium (``benchmarks/_work/city-B.osm.pbf``):
a ``B × B`` grid of 100 m blocks, streets every 100 m (nodes every 20 m; every fifth
street a two-lane primary with cycle tracks), six buildings per block and a park in
every seventh block. ``--blocks 360`` gives a 135 MB ``.osm.pbf`` (≥ 50 MB); the small
extract is the same city with 40 × 40 blocks.

For each file, each in a fresh process (time and peak resident memory of that process):

* ``scene``: :func:`build_osm_scene` of a 130 × 190 m window at 10 px/m at the
  centre (no cache), the reading and the painting (imports before the clock);
* ``scene-read``: its reading alone (:func:`read_osm`);
* ``read (C++)``: pyosmium decoding every object with nothing handed to Python
  (a ``KeyFilter`` that no object passes) — the floor of any reader;
* ``read (Python)``: ``for obj in osmium.FileProcessor(path): pass`` — reading the
  file once with pyosmium, doing nothing with each object.

Run: cd benchmarks && ../.venv/bin/python osm.py [--blocks 360] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

WORK = Path(__file__).parent / "_work"
CENTER = (52.0, 5.0)


def _lonlat(east: float, north: float) -> tuple[float, float]:
    """Small-area equirectangular metres → degrees around CENTER (good enough for a synthetic city)."""
    lat = CENTER[0] + north / 111_320.0
    lon = CENTER[1] + east / (111_320.0 * math.cos(math.radians(CENTER[0])))
    return lon, lat


def write_city(path: Path, blocks: int) -> None:
    """A ``blocks × blocks`` grid city centred on CENTER, written with pyosmium."""
    import osmium
    from osmium.osm.mutable import Node, Way

    half = blocks * 100 / 2
    tmp = path.with_suffix(".tmp.pbf")
    tmp.unlink(missing_ok=True)
    writer = osmium.SimpleWriter(str(tmp))
    next_id = [1]

    def node(east: float, north: float) -> int:
        node_id = next_id[0]
        next_id[0] += 1
        writer.add_node(Node(id=node_id, location=_lonlat(east, north), version=1))
        return node_id

    grid = {(i, j): node(i * 100 - half, j * 100 - half) for i in range(blocks + 1) for j in range(blocks + 1)}
    way_id = 1
    streets = []
    for i in range(blocks + 1):
        for j in range(blocks):
            for horizontal in (False, True):
                a, b = ((j, i), (j + 1, i)) if horizontal else ((i, j), (i, j + 1))
                inner = [node(grid_x * 100 - half + (b[0] - a[0]) * 20 * k, grid_y * 100 - half + (b[1] - a[1]) * 20 * k)
                         for k, (grid_x, grid_y) in ((k, a) for k in range(1, 5))]
                tags = {"highway": "primary", "lanes": "2", "cycleway": "track"} if i % 5 == 0 else \
                    {"highway": "residential", "name": f"Street {i}"}
                streets.append((way_id, [grid[a], *inner, grid[b]], tags))
                way_id += 1
    for wid, refs, tags in streets:
        writer.add_way(Way(id=wid, nodes=refs, tags=tags, version=1))
    for i in range(blocks):
        for j in range(blocks):
            x0, y0 = i * 100 - half, j * 100 - half
            if (i * blocks + j) % 7 == 0:
                ring = [node(x0 + 12, y0 + 12), node(x0 + 88, y0 + 12), node(x0 + 88, y0 + 88), node(x0 + 12, y0 + 88)]
                writer.add_way(Way(id=way_id, nodes=[*ring, ring[0]], tags={"leisure": "park"}, version=1))
                way_id += 1
                continue
            for k in range(6):
                bx, by = x0 + 14 + (k % 3) * 25, y0 + 14 + (k // 3) * 40
                ring = [node(bx, by), node(bx + 20, by), node(bx + 20, by + 30), node(bx, by + 30)]
                writer.add_way(Way(id=way_id, nodes=[*ring, ring[0]], tags={"building": "yes",
                                                                            "building:levels": "4"}, version=1))
                way_id += 1
    writer.close()
    tmp.replace(path)


def child(kind: str, path: str) -> None:
    """One measurement in this (fresh) process; prints seconds and peak RSS as JSON."""
    import osmium

    from synthcal.scenes.osm import build_osm_scene
    from synthcal.scenes.osm.classes import class_rules, relevant_keys
    from synthcal.scenes.osm.read import Frame, read_osm

    started = time.perf_counter()
    if kind == "scene":
        build_osm_scene(path, CENTER, cache=False)
    elif kind == "scene-read":
        read_osm(path, Frame(*CENTER, 130.0, 190.0, 10.0), relevant_keys(class_rules()))
    elif kind == "read-cpp":
        for _ in osmium.FileProcessor(path).with_filter(osmium.filter.KeyFilter("no-object-has-this-key")):
            pass
    else:
        for _ in osmium.FileProcessor(path):
            pass
    seconds = time.perf_counter() - started
    print(json.dumps({"seconds": seconds, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def measure(kind: str, path: Path, repeat: int) -> tuple[float, float]:
    """Best time and its peak memory over ``repeat`` fresh processes."""
    runs = []
    for _ in range(repeat):
        out = subprocess.run([sys.executable, __file__, "--child", kind, str(path)], check=True, capture_output=True,
                             text=True).stdout
        result = json.loads(out.strip().splitlines()[-1])
        runs.append((result["seconds"], result["peak_mb"]))
    return min(runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=360, help="blocks per side of the large city (default 360)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--child", nargs=2, metavar=("KIND", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return
    WORK.mkdir(exist_ok=True)
    kinds = ("scene", "scene-read", "read-cpp", "read-python")
    print(f"{'file':<20} {'MB':>5} " + " ".join(f"{k:>16}" for k in kinds) + "   scene / read (Python), (C++)")
    for blocks in (40, args.blocks):
        path = WORK / f"city-{blocks}.osm.pbf"
        if not path.exists():
            write_city(path, blocks)
        scene, reading, cpp, python = (measure(kind, path, args.repeat) for kind in kinds)
        cells = " ".join(f"{f'{s:6.2f} s {m:5.0f} MB':>16}" for s, m in (scene, reading, cpp, python))
        print(f"{path.name:<20} {path.stat().st_size / 1e6:5.1f} {cells}   {scene[0] / python[0]:5.2f}×, "
              f"{scene[0] / cpp[0]:5.1f}×")


if __name__ == "__main__":
    main()
