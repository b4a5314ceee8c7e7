"""An OpenStreetMap scene: from an extract to a store.

Builds the scene from an OSM extract around a centre (``synthcal osm`` does the
same on the command line), writes its entry into a configuration (see
``user_scene.py``) and generates a smoke store over the paper's intersection grid.
Without ``--osm`` it uses the test suite's synthetic junction
(``tests/generate/osm_fixtures.py``: a primary road, two streets, a cycleway, a
park), written beside the output. Map data © OpenStreetMap contributors, ODbL.
Scenes are cached in ``$SYNTHCAL_CACHE/osm`` (default ``~/.cache/synthcal/osm``).

    python examples/osm_scene.py [OUT] [--osm FILE --center LAT,LON]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from user_scene import config_with

import synthcal

ROOT = Path(__file__).resolve().parents[1]


def synthetic_junction(out: Path) -> tuple[Path, tuple[float, float]]:
    """The test suite's junction as ``OUT/junction.osm`` and its centre (lat, lon)."""
    sys.path.insert(0, str(ROOT / "tests" / "scenes"))
    from osm_fixtures import CENTER, junction

    return junction(out / "junction.osm"), CENTER


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", type=Path, default=None, help="output folder (default: a temporary one)")
    parser.add_argument("--osm", type=Path, default=None, help=".osm, .osm.pbf or .osm.bz2 extract")
    parser.add_argument("--center", default=None, metavar="LAT,LON", help="scene centre (with --osm)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="synthcal-"))
    out.mkdir(parents=True, exist_ok=True)
    if args.osm is None:
        extract, center = synthetic_junction(out)
    else:
        extract, center = args.osm.resolve(), tuple(float(x) for x in args.center.split(","))
    # 130 × 190 m at 10 px/m, the frame the intersection grid was made for (SPEC §4).
    entry = {"osm": {"file": str(extract), "center": list(center), "size_m": [130, 190], "pixels_per_metre": 10}}
    config = config_with(out, {"junction": entry},
                         {"junction": {"scene": "junction", "grid": "intersection", "pool_size": 10000}})
    store = synthcal.generate_store("junction", out / "data", profile="smoke", config=config)
    group = synthcal.open_store(store)
    scene = group.attrs["scene"]
    semantic = np.asarray(group["scene/semantic"][:])
    shares = np.bincount(semantic.ravel(), minlength=4) / semantic.size
    print(f"{store}: scene {semantic.shape[1]} × {semantic.shape[0]} px, "
          + ", ".join(f"{name} {share:.0%}" for name, share in zip(scene["classes"], shares, strict=True))
          + f"; source sha256 {scene['source']['sha256'][:12]}…, {scene['source']['attribution']}")
