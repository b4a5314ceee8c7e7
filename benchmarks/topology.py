"""Does the topological loss's hinge fire? ``class_reduction="sum"`` against ``"mean"``.

On the train split of a generated store (the first ``--max-train`` train maps, as the
quick profile trains on) and its dictionary, at full resolution (ground-truth
matching's definition), for each class reduction of the MSE (SPEC §7):

(a) the fraction of patches (4 × 4 grid) whose patch MSE exceeds β = 0.3 on
    ground-truth pairs (a train map against its ground-truth template, by
    ``L_Top-MSE`` and by MSE matching), and on all train × dictionary pairs;
(b) the fraction of train maps whose ground-truth template differs between
    ``L_Top-MSE`` and MSE matching;
(c) the fraction of pairs where ``L_Top-MSE`` equals MSE (no patch above β: the
    hinge adds nothing; the 4 × 4 patches are equal-sized at 256 × 144), on
    ground-truth pairs and (``--all-pairs``) on all pairs.

Run (about a minute per seed on 2 cores, after generating the quick pool):
    .venv/bin/synthcal generate intersection-1 --profile quick --out /tmp/h4data --workers 1 --splits
    .venv/bin/python benchmarks/topology.py /tmp/h4data/intersection-1.zarr --seeds 0 1 2 3 4
"""

from __future__ import annotations

import argparse
from itertools import pairwise
from pathlib import Path

import numpy as np
import torch

from synthcal.config import load_config
from synthcal.data import load_splits
from synthcal.models import match_ground_truth, one_hot_maps, pairwise_scores
from synthcal.models.losses import BETA, CLASS_REDUCTIONS, GRID, patch_bounds, patch_mse

ROOT = Path(__file__).resolve().parents[1]
_CHUNK = 250


def _gt_pairs(queries: torch.Tensor, templates: torch.Tensor, reduction: str) -> torch.Tensor:
    """(K, rows, cols) patch MSE of the pairs (queries[i], templates[i]); (K, H, W) class ids each."""
    return torch.cat([patch_mse(one_hot_maps(q), one_hot_maps(t), GRID, reduction)
                      for q, t in zip(queries.split(_CHUNK), templates.split(_CHUNK), strict=True)])


def _all_pairs(queries: torch.Tensor, templates: torch.Tensor, reduction: str) -> tuple[float, float]:
    """Over all (query, template) pairs: (share of patches over β, share of pairs with none over β).

    One patch at a time: its crops of every map, scored by MSE with the GEMM of
    :func:`synthcal.models.pairwise_scores` (a patch's MSE is the MSE of its crops).
    """
    rows, cols = patch_bounds(queries.shape[1], GRID[0]), patch_bounds(queries.shape[2], GRID[1])
    over = torch.zeros(len(queries), len(templates), dtype=torch.int32)
    for r0, r1 in pairwise(rows):
        for c0, c1 in pairwise(cols):
            scores = pairwise_scores(queries[:, r0:r1, c0:c1].contiguous(), templates[:, r0:r1, c0:c1].contiguous(),
                                     "mse", class_reduction=reduction)
            over += (scores > BETA).int()
    return float(over.double().mean()) / (GRID[0] * GRID[1]), float((over == 0).double().mean())


def measure(store: Path, seed: int, max_train: int | None, all_pairs: bool) -> dict[str, dict[str, float]]:
    """The figures of the module docstring for one split seed, per class reduction."""
    splits = load_splits(store, seed)
    queries = torch.from_numpy(np.asarray(splits["train"].semantics)[:max_train])
    templates = torch.from_numpy(np.asarray(splits["dictionary"].semantics))
    out: dict[str, dict[str, float]] = {}
    for reduction in CLASS_REDUCTIONS:
        top = match_ground_truth(queries, templates, "top_mse", class_reduction=reduction).index
        mse = match_ground_truth(queries, templates, "mse", class_reduction=reduction).index
        gt_top, gt_mse = _gt_pairs(queries, templates[top], reduction), _gt_pairs(queries, templates[mse], reduction)
        row = {
            "over_beta_gt_top": float((gt_top > BETA).double().mean()),
            "over_beta_gt_mse": float((gt_mse > BETA).double().mean()),
            "top_eq_mse_gt_top": float((gt_top <= BETA).flatten(1).all(1).double().mean()),
            "top_eq_mse_gt_mse": float((gt_mse <= BETA).flatten(1).all(1).double().mean()),
            "matches_differ": float((top != mse).double().mean()),
        }
        if all_pairs:
            row["over_beta_all"], row["top_eq_mse_all"] = _all_pairs(queries, templates, reduction)
        out[reduction] = row
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("store", type=Path)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--profile", default="quick", help="its training.max_train caps the train maps")
    parser.add_argument("--all-pairs", action="store_true", help="also every train × dictionary pair (slower)")
    args = parser.parse_args()
    max_train = load_config(ROOT / "datasets.yaml").training(args.profile).max_train
    rows = {r: [] for r in CLASS_REDUCTIONS}  # type: dict[str, list[dict[str, float]]]
    for seed in args.seeds:
        for reduction, row in measure(args.store, seed, max_train, args.all_pairs).items():
            rows[reduction].append(row)
            print(f"seed {seed} {reduction:4s} " + "  ".join(f"{k} {v:.4f}" for k, v in row.items()), flush=True)
    print(f"\n{args.store.name}, train maps {max_train or 'all'}, seeds {args.seeds}: mean (min–max) over seeds")
    for reduction, values in rows.items():
        for key in values[0]:
            column = np.array([v[key] for v in values])
            print(f"  {reduction:4s} {key:18s} {column.mean():7.2%}  ({column.min():.2%}–{column.max():.2%})")


if __name__ == "__main__":
    main()
