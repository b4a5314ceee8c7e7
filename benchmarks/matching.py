"""Speed of ground-truth matching and embedding search.

Every speed-up is a ratio against a baseline measured in the same run (the
machine is shared and noisy):

* ground-truth matching of Q × T maps at 256 × 144 (default 3,000 × 1,000), MSE
  and ``L_Top-MSE``, with :func:`synthcal.models.matching.match_ground_truth`
  against the brute-force pairwise loop (one call of the training loss per pair,
  on one-hot float32 maps) timed on a subset and extrapolated per pair; target ≥ 50×.
  Also shown: the same GEMM on one-hot float32 maps in full precision (what the
  class-id code and the reduced-precision exact GEMM buy);
* embedding search of 500 queries in 200,000 random embeddings of the Siamese's
  dimension with :func:`synthcal.models.siamese.nearest_embeddings`, per query,
  against a per-query brute-force loop on a subset.

Training throughput is measured by ``benchmarks/training.py``.

Run: .venv/bin/python benchmarks/matching.py [--quick]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import torch

from synthcal.models import (
    match_ground_truth,
    mse_loss,
    nearest_embeddings,
    one_hot_maps,
    top_mse_loss,
)
from synthcal.models.losses import ALPHA, BETA, CLASS_REDUCTION, GRID
from synthcal.models.matching import Encoded, encoded_scores

WIDTH, HEIGHT = 256, 144


def seconds(fn: Callable[[], object], repeat: int = 1) -> float:
    """Best wall time of ``repeat`` calls."""
    best = float("inf")
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - started)
    return best


def blocky_maps(n: int, generator: torch.Generator) -> torch.Tensor:
    """(n, 144, 256) uint8 class maps made of 16 × 16 blocks (content does not
    change the cost; blocks keep the scores spread out)."""
    coarse = torch.randint(0, 4, (n, HEIGHT // 16, WIDTH // 16), generator=generator, dtype=torch.uint8)
    return coarse.repeat_interleave(16, 1).repeat_interleave(16, 2)


def bench_matching(n_queries: int, n_templates: int, sub_queries: int, sub_templates: int) -> None:
    g = torch.Generator().manual_seed(0)
    queries, templates = blocky_maps(n_queries, g), blocky_maps(n_templates, g)
    pairs = n_queries * n_templates
    print(f"\n== ground-truth matching: {n_queries} x {n_templates} maps at {WIDTH}x{HEIGHT} ({pairs:,} pairs)")
    # Ablation: the same GEMMs on one-hot float32 maps in full precision, i.e. without
    # the class code and the exact reduced-precision GEMM (one chunk, encoding untimed).
    chunk = min(256, n_queries)
    onehot_t = Encoded(one_hot_maps(templates), GRID, 4)
    onehot_q = Encoded(one_hot_maps(queries[:chunk]), GRID, 4)
    for score, loss in (("mse", mse_loss), ("top_mse", top_mse_loss)):
        match_ground_truth(queries[:8], templates[:8], score)  # warm-up
        fast = seconds(lambda score=score: match_ground_truth(queries, templates, score))
        subset_q = one_hot_maps(queries[:sub_queries])
        subset_t = one_hot_maps(templates[:sub_templates])

        def brute(loss: Callable = loss, subset_q: torch.Tensor = subset_q,
                  subset_t: torch.Tensor = subset_t) -> torch.Tensor:
            return torch.tensor([[float(loss(q[None], t[None], reduction="none")) for t in subset_t]
                                 for q in subset_q]).argmin(1)

        brute_pair = seconds(brute, repeat=2) / (sub_queries * sub_templates)
        agree = torch.equal(brute(), match_ground_truth(queries[:sub_queries], templates[:sub_templates], score).index)
        onehot = seconds(lambda score=score: encoded_scores(onehot_q, onehot_t, score, GRID, (HEIGHT, WIDTH), ALPHA,
                                                            BETA, CLASS_REDUCTION))
        fast_pair = fast / pairs
        print(f"{score:8s} GEMM {fast:6.2f} s = {fast_pair * 1e6:5.3f} us/pair | brute-force loop "
              f"{brute_pair * 1e6:6.1f} us/pair (on {sub_queries}x{sub_templates}; all pairs: "
              f"{brute_pair * pairs / 60:5.1f} min) | speed-up {brute_pair / fast_pair:4.0f}x | "
              f"one-hot fp32 GEMM {onehot / (chunk * n_templates) * 1e6:5.3f} us/pair | argmin agrees: {agree}")


def bench_search(n_queries: int, n_dictionary: int, sub_queries: int, dim: int) -> None:
    g = torch.Generator().manual_seed(1)
    queries = torch.nn.functional.normalize(torch.randn(n_queries, dim, generator=g), dim=1)
    dictionary = torch.nn.functional.normalize(torch.randn(n_dictionary, dim, generator=g), dim=1)
    print(f"\n== embedding search: {n_queries} queries in {n_dictionary:,} embeddings of dimension {dim}")
    fast = seconds(lambda: nearest_embeddings(queries, dictionary), repeat=2) / n_queries

    def brute() -> torch.Tensor:
        return torch.stack([(dictionary - q).square().sum(1).argmin() for q in queries[:sub_queries]])

    brute_query = seconds(brute, repeat=2) / sub_queries
    agree = (brute() == nearest_embeddings(queries[:sub_queries], dictionary).index).float().mean()
    print(f"chunked GEMM {fast * 1e3:7.3f} ms/query | per-query loop {brute_query * 1e3:7.2f} ms/query "
          f"(on {sub_queries}) | speed-up {brute_query / fast:5.0f}x | argmin agrees on {float(agree):.0%}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    args = parser.parse_args()
    if args.quick:
        bench_matching(300, 100, 4, 5)
        bench_search(50, 20_000, 5, 128)
    else:
        bench_matching(3000, 1000, 20, 10)
        bench_search(500, 200_000, 20, 128)


if __name__ == "__main__":
    main()
