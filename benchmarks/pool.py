"""Cost of the pool dictionary: embedding a pool with the trained Siamese and searching it.

The quick profile's Siamese (width 16, 64-dimensional embeddings) at its working
resolution (128 × 72) embeds ``--pool`` class maps in batches of 256 (what
:func:`synthcal.training.embed_templates` does for a pool dictionary, once per
(dictionary, Siamese), then cached), and :func:`synthcal.models.nearest_embeddings`
searches them for ``--queries`` embedded test maps. The maps are random class ids
unless ``--store`` names a store (then its first ``--pool`` semantic maps, read
shard by shard and reduced to 128 × 72 into one preallocated array as the estimator
does; reading them is timed separately, per template against ``load_split`` of the
store's seed-0 train split per sample in the same run, target ≤ 3, with the peak
RSS after it and the bound for 200,000 templates). Untrained weights: the cost does
not depend on them.

The baseline, measured in the same run, is the paper's split dictionary: the first
``--split`` (default 1,000) of the same maps, embedded and searched the same way;
the pool's costs are printed as ratios against it (the machine is shared and noisy).

Run: .venv/bin/python benchmarks/pool.py [--pool 4000] [--split 1000] [--queries 500] [--threads 1] [--store S.zarr]
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np
import torch

from synthcal.data import LazyRows, load_split
from synthcal.models import SiameseNet, nearest_embeddings, one_hot_maps
from synthcal.store import open_store
from synthcal.store.splits import SplitError, read_split_indices
from synthcal.training import embed_templates, reduce_class_map_batches
from synthcal.training.examples import TrainingData

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import best_of  # noqa: E402

WORK = (128, 72)
READ_BATCH = 512  # maps read per batch: the paper estimator's _TEMPLATE_BATCH


def _maps(store: str | None, count: int) -> tuple[torch.Tensor, float]:
    """(count, 72, 128) uint8 class ids and the seconds spent reading and reducing them."""
    started = time.perf_counter()
    if store is None:
        maps = torch.randint(0, 4, (count, WORK[1], WORK[0]), generator=torch.Generator().manual_seed(0))
        return maps.to(torch.uint8), 0.0
    open_store(store)
    rows = LazyRows(Path(store), "semantic", np.arange(count))
    # As the paper estimator prepares a pool dictionary: shard by shard into one preallocated array.
    maps = reduce_class_map_batches(rows.batches(READ_BATCH), count, WORK)
    return maps, time.perf_counter() - started


def _load_split_per_sample(store: str) -> float | None:
    """Seconds per sample of ``load_split(store, "train", 0)`` (best of 3; warmed), or None without splits."""
    try:
        load_split(store, "train", 0)
    except SplitError:
        return None
    return best_of(3, lambda: load_split(store, "train", 0)) / len(read_split_indices(store, "train", 0))


def _rss_bound(store: str, templates: int) -> float:
    """Bytes that preparing ``templates`` maps holds at most: the reduced maps, plus one batch read at full
    size and its packed codes (what :func:`reduce_class_map_batches` keeps; indices aside)."""
    height, width = open_store(store)["semantic"].shape[1:]
    return templates * WORK[0] * WORK[1] + READ_BATCH * (height * width + 2 * WORK[0] * WORK[1])


def _costs(siamese: SiameseNet, templates: torch.Tensor, queries: torch.Tensor) -> tuple[float, float]:
    """Seconds to embed (T, h, w) ``templates`` (best of 2) and to search them for (Q, D) ``queries`` (best of 5)."""
    empty = torch.empty(0)
    data = TrainingData(images=None, semantics=empty, homographies=empty, match=empty, templates=templates,
                        template_homographies=empty, scene=empty, scene_frame=empty, work_size=WORK)
    embedding = embed_templates(siamese, data, torch.device("cpu"))  # also the warm-up of the timed calls
    embed_seconds = best_of(2, lambda: embed_templates(siamese, data, torch.device("cpu")))
    search_seconds = best_of(5, lambda: nearest_embeddings(queries, embedding))
    return embed_seconds, search_seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pool", type=int, default=4000)
    parser.add_argument("--split", type=int, default=1000, help="the baseline: the split dictionary's size")
    parser.add_argument("--queries", type=int, default=500)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--store", default=None)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    templates, read_seconds = _maps(args.store, args.pool)
    read_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if args.store:
        baseline = _load_split_per_sample(args.store)
        ratio = "" if baseline is None else (f" = {read_seconds / args.pool / baseline:.2f} × load_split's "
                                             f"{1e3 * baseline:.3f} ms/sample (target ≤ 3)")
        print(f"read + reduce {args.pool:,} maps: {read_seconds:.2f} s, {1e3 * read_seconds / args.pool:.3f} "
              f"ms/template{ratio}; peak RSS so far {read_rss:.0f} MiB; bound for 200,000 templates "
              f"{_rss_bound(args.store, 200_000) / 2**30:.2f} GiB above the interpreter's")
    torch.manual_seed(0)
    siamese = SiameseNet(4, embedding_dim=64, width=16).eval()
    with torch.no_grad():
        queries = siamese(one_hot_maps(templates[: args.queries].long(), 4))
        split = _costs(siamese, templates[: args.split], queries)
        pool = _costs(siamese, templates, queries)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{WORK[0]} × {WORK[1]} maps, {args.threads} thread(s), {args.queries} queries, "
          + (f"read + reduce {read_seconds:.1f} s for the pool" if args.store else "random maps")
          + f"; peak RSS {peak:.0f} MiB")
    print(f"{'dictionary':>18} {'embedding':>11} {'per template':>13} {'search':>9} {'per query':>10}")
    for name, size, (embed, search) in (("split", args.split, split), ("pool", args.pool, pool)):
        print(f"{name + f' {size:,}':>18} {embed:>9.2f} s {1e3 * embed / size:>10.3f} ms "
              f"{1e3 * search:>6.1f} ms {1e3 * search / args.queries:>7.3f} ms")
    print(f"pool / split: embedding ×{pool[0] / split[0]:.1f} (sizes ×{args.pool / args.split:.1f}), "
          f"search ×{pool[1] / split[1]:.1f}")


if __name__ == "__main__":
    main()
