"""Cost of the pool dictionary: embedding a pool with the trained Siamese and searching it.

The quick profile's Siamese (width 16, 64-dimensional embeddings) at its working
resolution (128 × 72) embeds ``--pool`` class maps in batches of 256 (what
:func:`synthcal.training.embed_templates` does for a pool dictionary, once per
(dictionary, Siamese), then cached), and :func:`synthcal.models.nearest_embeddings`
searches them for ``--queries`` embedded test maps. The maps are random class ids
unless ``--store`` names a store (then its first ``--pool`` semantic maps, reduced
to 128 × 72 as the estimator does; reading them is timed separately). Untrained
weights: the cost does not depend on them.

Run: .venv/bin/python benchmarks/pool.py [--pool 4000] [--queries 500] [--threads 1] [--store S.zarr]
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np
import torch

from synthcal.models import SiameseNet, nearest_embeddings, one_hot_maps
from synthcal.training import embed_templates, reduce_class_maps
from synthcal.training.stages import TrainingData

WORK = (128, 72)


def _maps(store: str | None, count: int) -> tuple[torch.Tensor, float]:
    """(count, 72, 128) uint8 class ids and the seconds spent reading and reducing them."""
    started = time.perf_counter()
    if store is None:
        maps = torch.randint(0, 4, (count, WORK[1], WORK[0]), generator=torch.Generator().manual_seed(0))
        return maps.to(torch.uint8), 0.0
    from synthcal.data.pool import LazyRows
    from synthcal.store import open_store

    open_store(store)
    rows = LazyRows(store, "semantic", np.arange(count))
    maps = torch.cat([reduce_class_maps(block, WORK) for _, block in rows.batches(512)])
    return maps, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pool", type=int, default=4000)
    parser.add_argument("--queries", type=int, default=500)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--store", default=None)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    templates, read_seconds = _maps(args.store, args.pool)
    torch.manual_seed(0)
    siamese = SiameseNet(4, embedding_dim=64, width=16).eval()
    empty = torch.empty(0)
    data = TrainingData(images=None, semantics=empty, homographies=empty, match=empty, templates=templates,
                        template_homographies=empty, scene=empty, scene_frame=empty, work_size=WORK)
    started = time.perf_counter()
    embedding = embed_templates(siamese, data, torch.device("cpu"))
    embed_seconds = time.perf_counter() - started
    with torch.no_grad():
        queries = siamese(one_hot_maps(templates[: args.queries].long(), 4))
    started = time.perf_counter()
    for _ in range(5):
        nearest_embeddings(queries, embedding)
    search_seconds = (time.perf_counter() - started) / 5
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"pool {args.pool:,} maps at {WORK[0]} × {WORK[1]}, {args.threads} thread(s)"
          + (f", read + reduce {read_seconds:.1f} s" if args.store else ", random maps"))
    print(f"embedding: {embed_seconds:.2f} s ({1e3 * embed_seconds / args.pool:.2f} ms per template)")
    print(f"search of {args.queries} queries: {1e3 * search_seconds:.1f} ms "
          f"({1e3 * search_seconds / args.queries:.3f} ms per query)")
    print(f"embedding search + the query's own embedding per query: "
          f"{1e3 * (search_seconds / args.queries + embed_seconds / args.pool):.2f} ms; peak RSS {peak:.0f} MiB")


if __name__ == "__main__":
    main()
