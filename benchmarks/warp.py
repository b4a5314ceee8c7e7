"""The differentiable bilinear warp: synthcal's own against kornia's ``warp_perspective``.

Every variant warps the same one-hot bird's-eye map (4 × 1,900 × 1,300 float32,
the size ``benchmarks/training.py`` trains on) into B views of 256 × 144 through
random cameras above the scene (float64 homographies), and multiplies by
synthcal's cheirality mask:

* ``synthcal``: :func:`synthcal.models.warp.warp_semantic` (``"bilinear"``) as the
  models call it: sampling positions computed in float64, only the final grid cast
  to float32 — the baseline of every ratio;
* ``synthcal, H float32``: the same with float32 homographies, so positions in
  float32;
* ``kornia``: ``kornia.geometry.transform.warp_perspective(scene.expand(B, ...),
  H.float(), (h, w), align_corners=True, padding_mode="zeros")``. kornia builds its
  grid in the promotion of the image's and the matrix's dtypes and hands it to
  ``grid_sample``, which wants the image's dtype: on a float32 map the homographies
  must be cast to float32, so the positions are float32;
* ``kornia, float64``: float64 positions, which kornia only gives by sampling a
  float64 copy of the scene.

Printed per batch size: forward (no grad) and forward + backward (gradient with
respect to H) times, medians over ``--repeat`` rounds in which the variants take
turns, and each ÷ ``synthcal``; then each variant's error against synthcal's warp
of a float64 copy of the scene (values: max and mean absolute; dH: relative L2),
and kornia against synthcal both in float64 (the conventions check).

Run: .venv/bin/python benchmarks/warp.py [--repeat 7] [--batch 8 64]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np
import torch
from torch import Tensor

from synthcal.generate.camera import homography
from synthcal.models import cheirality_mask, one_hot_maps, warp_semantic

try:
    from kornia.geometry.transform import warp_perspective
except ImportError as exc:  # kornia is not a dependency of synthcal (docs/decisions.md)
    raise SystemExit("benchmarks/warp.py needs kornia: .venv/bin/pip install kornia") from exc

WIDTH, HEIGHT = 256, 144
SIZE = (WIDTH, HEIGHT)


def scene_map() -> Tensor:
    """(4, 1900, 1300) float32 one-hot map of 20-px blocks of random classes."""
    g = torch.Generator().manual_seed(2)
    ids = torch.randint(0, 4, (1900 // 20, 1300 // 20), generator=g)
    return one_hot_maps(ids.repeat_interleave(20, 0).repeat_interleave(20, 1))


def cameras(n: int, seed: int = 0) -> Tensor:
    """(n, 3, 3) float64 bird's-eye → image homographies of cameras above the scene, looking down."""
    rng = np.random.default_rng(seed)
    centres = np.stack([rng.uniform(100, 1200, n), rng.uniform(100, 1800, n), rng.uniform(30, 120, n)], 1)
    return torch.from_numpy(homography(rng.uniform(-180, 180, n), rng.uniform(-40, -8, n),
                                       rng.uniform(150, 400, n), centres, SIZE))


def synthcal_warp(scene: Tensor, H: Tensor) -> Tensor:
    """What synthcal does: positions in H's dtype (float64), sampling in the scene's."""
    return warp_semantic(scene, H, SIZE, "bilinear")


def synthcal_float32(scene: Tensor, H: Tensor) -> Tensor:
    """synthcal's warp given float32 homographies: positions in float32, like kornia's."""
    return warp_semantic(scene, H.float(), SIZE, "bilinear").to(scene.dtype)


def kornia_warp(scene: Tensor, H: Tensor) -> Tensor:
    """kornia on the scene's dtype (H cast to it) + synthcal's cheirality mask."""
    out = warp_perspective(scene.expand(len(H), -1, -1, -1), H.to(scene.dtype), (HEIGHT, WIDTH),
                           mode="bilinear", padding_mode="zeros", align_corners=True)
    return out * cheirality_mask(H, SIZE)[:, None].to(out.dtype)


def kornia_float64(scene: Tensor, H: Tensor) -> Tensor:
    """kornia with float64 positions, which it only builds by sampling a float64 copy of the scene."""
    return kornia_warp(scene.double(), H).to(scene.dtype)


Warp = Callable[[Tensor, Tensor], Tensor]
WARPS: dict[str, Warp] = {
    "synthcal": synthcal_warp,
    "synthcal, H float32": synthcal_float32,
    "kornia": kornia_warp,
    "kornia, float64": kornia_float64,
}


def forward(warp: Warp, scene: Tensor, H: Tensor) -> None:
    with torch.no_grad():
        warp(scene, H)


def gradient(warp: Warp, scene: Tensor, H: Tensor) -> Tensor:
    """d(sum of squares of the views) / dH, (B, 3, 3)."""
    H = H.clone().requires_grad_(True)
    warp(scene, H).square().sum().backward()
    assert H.grad is not None
    return H.grad


def timings(scene: Tensor, H: Tensor, repeat: int) -> None:
    """Median times over ``repeat`` rounds, each round running every warp once in turn."""
    for label, run in (("forward", forward), ("forward+backward", gradient)):
        times: dict[str, list[float]] = {name: [] for name in WARPS}
        for warp in WARPS.values():  # warm-up
            run(warp, scene, H)
        for _ in range(repeat):
            for name, warp in WARPS.items():
                started = time.perf_counter()
                run(warp, scene, H)
                times[name].append(time.perf_counter() - started)
        baseline = statistics.median(times["synthcal"])
        print(f"  {label}:")
        for name, t in times.items():
            median = statistics.median(t)
            print(f"    {name:20s} {median * 1e3:8.2f} ms (range {min(t) * 1e3:.1f}–{max(t) * 1e3:.1f})  "
                  f"÷ synthcal {median / baseline:5.2f}")


def accuracy(scene: Tensor, H: Tensor) -> None:
    """Each warp on the float32 scene against synthcal's on a float64 copy (values and dH)."""
    reference = synthcal_warp(scene.double(), H)
    reference_grad = gradient(synthcal_warp, scene.double(), H)
    print("  against synthcal's warp of a float64 scene (values: max, mean abs; dH: relative L2):")
    for name, warp in WARPS.items():
        error = (warp(scene, H).double() - reference).abs()
        grad = gradient(warp, scene, H).double()
        print(f"    {name:20s} max {error.max():.2e}  mean {error.mean():.2e}  "
              f"dH {(grad - reference_grad).norm() / reference_grad.norm():.2e}")
    error = (kornia_warp(scene.double(), H) - reference).abs().max()
    grad = gradient(kornia_warp, scene.double(), H)
    print(f"  conventions, both on the float64 scene: kornia − synthcal max {error:.2e}, "
          f"dH relative L2 {(grad - reference_grad).norm() / reference_grad.norm():.2e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="timed rounds (medians are printed)")
    parser.add_argument("--batch", type=int, nargs="+", default=[8, 64], help="views per call")
    args = parser.parse_args()
    scene = scene_map()
    print(f"scene {tuple(scene.shape)} float32, views {WIDTH}x{HEIGHT}, homographies float64, "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    for batch in args.batch:
        H = cameras(batch)
        print(f"\n== batch {batch}, {float(cheirality_mask(H, SIZE).double().mean()):.0%} of pixels see the ground")
        timings(scene, H, args.repeat)
        accuracy(scene, H)


if __name__ == "__main__":
    main()
