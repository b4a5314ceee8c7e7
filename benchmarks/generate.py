"""Throughput of `synthcal generate` against a bare cv2.warpPerspective loop.

Every figure is a ratio against a baseline measured in the same run, because the
machine is shared and noisy:

* per-sample time of the whole pipeline (sampling, rendering, cheirality masks,
  appearance, compression, atomic shard writes) on one worker ÷ the per-sample time
  of the bare warps over the same cameras (the RGB warp at the supersampled size with
  bilinear interpolation plus the semantic warp with nearest neighbour — the same
  warps, and nothing else); target ≤ 2. Shown twice: the marginal cost per sample
  (runs of N/4 and N samples differenced, so start-up — building the scene,
  spawning workers, writing the store skeleton — cancels out, as it does in a
  200,000-sample pool) and the plain wall time of the N-sample run;
* samples/s with 2 workers ÷ samples/s with 1, marginal; target ≥ 1.7 (needs
  2 idle cores);
* peak resident memory of a whole `synthcal generate` process at two pool sizes
  (should not grow with N), and of planning a 200,000-sample pool;
* store bytes per sample.

Run: .venv/bin/python benchmarks/generate.py [--n 2000] [--dataset intersection-3]
"""

from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from synthcal.config import load_config
from synthcal.generate.pipeline import generate_dataset, load_scene
from synthcal.generate.render import _supersampled
from synthcal.generate.store import open_store

ROOT = Path(__file__).resolve().parents[1]


def bare_warps(scene, homographies: np.ndarray, image_size: tuple[int, int], supersample: int) -> float:
    """Seconds for the warps alone, single-threaded like a worker."""
    cv2.setNumThreads(1)
    width, height = image_size
    fine = (width * supersample, height * supersample)
    started = time.perf_counter()
    for H in homographies:
        cv2.warpPerspective(scene.image, _supersampled(H, supersample), fine, flags=cv2.INTER_LINEAR)
        cv2.warpPerspective(scene.semantic, H, image_size, flags=cv2.INTER_NEAREST)
    return time.perf_counter() - started


def timed_generate(spec, out: Path, workers: int) -> float:
    shutil.rmtree(out, ignore_errors=True)
    started = time.perf_counter()
    generate_dataset(spec, out, workers=workers, progress=False)
    return time.perf_counter() - started


def peak_rss_mib(args: list[str]) -> float:
    """Peak resident memory (MiB) of a child process running ``args``."""
    code = (
        "import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL); "
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    )
    out = subprocess.run([sys.executable, "-c", code, *args], check=True, capture_output=True, text=True)
    return int(out.stdout.split()[-1]) / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2000)
    parser.add_argument("--dataset", default="intersection-3")
    args = parser.parse_args()

    config = load_config(ROOT / "datasets.yaml")
    spec = config.resolve(args.dataset, pool_size=args.n)
    scene = load_scene(spec)
    work = Path(tempfile.mkdtemp(prefix="synthcal-bench-"))
    try:
        quarter = spec.model_copy(update={"pool_size": args.n // 4})
        one = timed_generate(spec, work / "w1", workers=1)
        one_q = timed_generate(quarter, work / "w1q", workers=1)
        store = work / "w1" / f"{spec.name}.zarr"
        homographies = open_store(store)["homography"][:]
        baseline = bare_warps(scene, homographies, spec.image_size, spec.supersample)
        two = timed_generate(spec, work / "w2", workers=2)
        two_q = timed_generate(quarter, work / "w2q", workers=2)
        size = sum(f.stat().st_size for f in store.rglob("*") if f.is_file())
        scene_bytes = sum(f.stat().st_size for f in (store / "scene").rglob("*") if f.is_file())

        cli = [str(ROOT / ".venv/bin/synthcal"), "generate", args.dataset, "--quiet", "--config", str(ROOT / "datasets.yaml")]
        small, large = args.n // 4, args.n
        rss_small = peak_rss_mib([*cli, "--n", str(small), "--out", str(work / "m1")])
        rss_large = peak_rss_mib([*cli, "--n", str(large), "--out", str(work / "m2")])
        plan = (
            "from synthcal.config import load_config; from synthcal.generate.pipeline import *; "
            "from synthcal.generate.grid import sample_cameras; "
            f"s = load_config({str(ROOT / 'datasets.yaml')!r}).resolve({args.dataset!r}, pool_size=200000); "
            "sc = load_scene(s); c = sample_cameras(s.grid, s.pool_size, s.seed, sc.camera_position); "
            "plan_homographies(s, sc, c)"
        )
        rss_plan = peak_rss_mib([sys.executable, "-c", plan])
    finally:
        shutil.rmtree(work, ignore_errors=True)

    n = spec.pool_size
    marginal = n - quarter.pool_size
    one_m, two_m = (one - one_q) / marginal, (two - two_q) / marginal
    print(f"dataset {spec.name}, {n} samples at {spec.image_size[0]} × {spec.image_size[1]}, "
          f"supersample {spec.supersample}, shard {spec.shard_size}")
    print(f"bare warps (baseline)        {baseline / n * 1e3:6.2f} ms/sample")
    print(f"generate, 1 worker, marginal {one_m * 1e3:6.2f} ms/sample = {one_m / (baseline / n):.2f} × baseline "
          f"(target ≤ 2)")
    print(f"generate, 1 worker, wall     {one / n * 1e3:6.2f} ms/sample = {one / baseline:.2f} × baseline "
          f"(start-up included, N = {n})")
    print(f"generate, 2 workers, marginal{two_m * 1e3:6.2f} ms/sample = {one_m / two_m:.2f} × one worker "
          f"(target ≥ 1.7); wall {one / two:.2f} ×")
    print(f"peak RSS, whole CLI run     N={small}: {rss_small:.0f} MiB   N={large}: {rss_large:.0f} MiB   "
          f"ratio {rss_large / rss_small:.2f}")
    print(f"peak RSS, planning a 200,000-sample pool: {rss_plan:.0f} MiB")
    print(f"store size                  {(size - scene_bytes) / n / 1024:.1f} KiB/sample "
          f"(+ {scene_bytes / 2**20:.1f} MiB for the bird's-eye scene)")


if __name__ == "__main__":
    main()
