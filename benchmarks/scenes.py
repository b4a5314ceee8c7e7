"""Time to build each built-in scene, against loading the same arrays from ``.npy``.

Every worker process builds its scene once (``build_scene`` caches it per process),
so a build's time is part of each worker's start-up. The baseline, measured in the
same run, is ``numpy.load`` of the finished image and semantic map from uncompressed
``.npy`` files: the ratio says what building procedurally costs over shipping the
arrays. The test suite used to assert a build under 2 s; speed is measured here now.

Run: .venv/bin/python benchmarks/scenes.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import tempfile
from functools import partial
from pathlib import Path

import numpy as np
from timing import best_of  # benchmarks/timing.py (scripts run from benchmarks/)

from synthcal.scenes import BUILTIN_SCENES, build_scene


def load_arrays(*paths: Path) -> list[np.ndarray]:
    """The baseline: the finished arrays read back from ``.npy``."""
    return [np.load(path) for path in paths]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{'scene':<16} {'size':>11} {'build':>9} {'np.load':>9} {'ratio':>7}")
    with tempfile.TemporaryDirectory(prefix="synthcal-scenes-") as scratch:
        for name in BUILTIN_SCENES:
            build = best_of(args.repeat, partial(build_scene.__wrapped__, name))  # bypassing the cache
            scene = build_scene(name)
            image, semantic = Path(scratch) / f"{name}-image.npy", Path(scratch) / f"{name}-semantic.npy"
            np.save(image, scene.image)
            np.save(semantic, scene.semantic)
            load = best_of(args.repeat, partial(load_arrays, image, semantic))
            h, w = scene.semantic.shape
            print(f"{name:<16} {w:>5} × {h:<5} {build * 1e3:>6.0f} ms {load * 1e3:>6.1f} ms {build / load:>6.0f}×")


if __name__ == "__main__":
    main()
