"""What the views of a mix's estimates look like (reproduction.md, "The paper's mixes for intersections 4 and 5").

For seeds 0-4 of each model, from each run's ``metrics.csv`` homographies (bird's-eye pixel -> image pixel, SPEC
§2): the share of estimates whose bottom-centre pixel sees no ground *as returned* (the whole view behind the camera,
which the cheirality-masked renderer of the STN's loss draws empty); then, each such estimate flipped as the SPEC's
sign rule (and so the scorer) does, over a lattice of every 4th pixel of the 256 x 144 image: the share of pixels that
see the ground (depth > 0), the share that see the target intersection's scene, and, over the first 100 test images, the
median share of a view in its most common class (0 where a pixel sees no ground of the scene). The store's own
cameras are the reference.

Run in the sweep folder (``data/``, ``results/``): ``python mixed5_views.py [mixed-N]`` (default ``mixed-5``;
``mixed-N``'s test cameras are intersection-N's).
"""

import glob
import os
import sys

import numpy as np
import pandas as pd
import zarr

from synthcal.generate.camera import orient_homography

WIDTH, HEIGHT = 256, 144
COLUMNS = [f"h{i}{j}" for i in range(3) for j in range(3)]
MODELS = ("retrieved", "template", "sha2020_step-by-step_top-mse", "proposed_step-by-step_top-mse",
          "sha2020_step-by-step_mse", "proposed_step-by-step_mse", "sha2020_step-by-step_dice",
          "proposed_step-by-step_dice", "sha2020_step-by-step_top-dice", "proposed_step-by-step_top-dice",
          *(f"{model}_end-to-end_{loss}" for loss in ("top-mse", "mse", "dice", "top-dice")
            for model in ("sha2020", "proposed")))

MIX = sys.argv[1] if len(sys.argv) > 1 else "mixed-5"
if not MIX.removeprefix("mixed-").isdigit() or not MIX.startswith("mixed-"):
    sys.exit(f"mixed5_views.py: error: the mix is mixed-N (the target intersection's number), got {MIX!r}")
STORE = f"data/intersection-{MIX.removeprefix('mixed-')}.zarr"
if not os.path.isdir(STORE):
    sys.exit(f"mixed5_views.py: error: no store {STORE} for {MIX} here: run it in the sweep folder")
store = zarr.open_group(STORE, mode="r")
semantic = np.asarray(store["scene"]["semantic"][:])
us, vs = np.meshgrid(np.arange(0, WIDTH, 4), np.arange(0, HEIGHT, 4))
pixels = np.stack([us.ravel(), vs.ravel(), np.ones(us.size)])


def view(h: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Share seeing ground, share seeing the scene, and each lattice pixel's class, for an oriented (3, 3) ``h``."""
    ground = np.linalg.solve(h, pixels)
    ahead = ground[2] > 0
    depth = np.where(ahead, ground[2], 1.0)
    u = np.where(ahead, np.round(ground[0] / depth), -1).astype(np.int64)
    v = np.where(ahead, np.round(ground[1] / depth), -1).astype(np.int64)
    inside = ahead & (u >= 0) & (v >= 0) & (u < semantic.shape[1]) & (v < semantic.shape[0])
    classes = np.where(inside, semantic[np.clip(v, 0, semantic.shape[0] - 1), np.clip(u, 0, semantic.shape[1] - 1)], 0)
    return float(ahead.mean()), float(inside.mean()), classes


def summary(homographies: np.ndarray) -> str:
    homographies = homographies[np.isfinite(homographies).all(axis=1)].reshape(-1, 3, 3)
    oriented = orient_homography(homographies, (WIDTH, HEIGHT))  # the SPEC's sign rule, as the scorer applies it
    behind = np.mean((oriented != homographies).any(axis=(1, 2)))  # flipped: the view as returned saw no ground
    views = [view(h) for h in oriented]
    top = [np.bincount(classes, minlength=4).max() / classes.size for _, _, classes in views[:100]]
    return (f"behind {behind:.3f}  ground {np.mean([v[0] for v in views]):.3f}  scene {np.mean([v[1] for v in views]):.3f}  "
            f"top class {np.median(top):.3f}")


truth = np.asarray(store["homography"][:500]).reshape(-1, 9)
print(f"{'the store (first 500 cameras)':32s}    {summary(truth)}")
for model in MODELS:
    for seed in range(5):
        folders = glob.glob(f"results/runs/{MIX}_{model}_*_s{seed}_*/metrics.csv")
        if not folders:  # not run (yet)
            continue
        folder = folders[0].removesuffix("/metrics.csv")
        print(f"{model:32s} s{seed} {summary(pd.read_csv(f'{folder}/metrics.csv')[COLUMNS].to_numpy(float))}")
