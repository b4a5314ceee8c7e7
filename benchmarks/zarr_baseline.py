"""synthcal's own shard writer and reader against zarr-python on the same arrays.

Generates (in a temporary folder) a soccer pool of ``--n`` samples at 256 × 144 with
64 samples per shard (the ``quick`` profile), holds its images and semantic maps in
memory, and times in the same run:

* writing: zarr-python assigning whole shards (``array[s·64 : (s+1)·64] = batch``,
  one shard per array write, into arrays made exactly as the store makes them)
  against :func:`synthcal.store.shards.write_shard`, ``image`` and ``semantic``;
  the two stores are then checked to hold the same bytes;
* reading: zarr-python's ``get_orthogonal_selection`` of ``--split`` sorted random
  indices against :func:`synthcal.store.shards.read_rows`, ``image``,
  ``semantic`` and ``homography``, both from the page cache;

best of ``--repeat``, per sample, and the ratio zarr-python ÷ synthcal.

Run: .venv/bin/python benchmarks/zarr_baseline.py [--n 2000] [--split 500] [--repeat 3]
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import numpy as np
import zarr
from timing import best_of  # benchmarks/timing.py (scripts run from benchmarks/)
from zarr.codecs import BloscCodec

from synthcal.config import load_config
from synthcal.generate.pipeline import generate_dataset
from synthcal.store import array_at, open_store
from synthcal.store.shards import read_rows, shard_layout, write_shard

ROOT = Path(__file__).resolve().parents[1]
ARRAYS = ("image", "semantic")




def empty_arrays(path: Path, data: dict[str, np.ndarray], shard_size: int) -> dict[str, zarr.Array]:
    """Arrays laid out as :func:`synthcal.store.create_store` lays out ``image`` and ``semantic``."""
    shutil.rmtree(path, ignore_errors=True)
    group = zarr.create_group(zarr.storage.LocalStore(path), zarr_format=3)
    return {name: group.create_array(name, shape=values.shape, chunks=(1, *values.shape[1:]),
                                     shards=(shard_size, *values.shape[1:]), dtype=values.dtype,
                                     compressors=BloscCodec(cname="lz4", clevel=5, shuffle="shuffle"), fill_value=0)
            for name, values in data.items()}


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def time_writes(scratch: Path, data: dict[str, np.ndarray], shard_size: int, repeat: int) -> tuple[float, float]:
    """Seconds to write every shard of ``data``: (zarr-python, synthcal), each best of ``repeat``."""
    count = len(data["image"])

    def with_zarr() -> None:
        arrays = empty_arrays(scratch / "zarr.zarr", data, shard_size)
        for start in range(0, count, shard_size):
            for name, values in data.items():
                arrays[name][start:start + shard_size] = values[start:start + shard_size]

    def with_synthcal() -> None:
        layouts = {name: shard_layout(a) for name, a in empty_arrays(scratch / "ours.zarr", data, shard_size).items()}
        for shard, start in enumerate(range(0, count, shard_size)):
            for name, values in data.items():
                write_shard(layouts[name], shard, values[start:start + shard_size])

    with_zarr()  # warm-up: imports, codec set-up, first touches
    with_synthcal()
    t_zarr, t_ours = best_of(repeat, with_zarr), best_of(repeat, with_synthcal)
    assert files(scratch / "zarr.zarr") == files(scratch / "ours.zarr"), "the two writers' bytes differ"
    return t_zarr, t_ours


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2000, help="pool size (default 2000)")
    parser.add_argument("--split", type=int, default=500, help="indices read (default 500)")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="synthcal-zarr-") as scratch:
        run(Path(scratch), args)


def run(scratch: Path, args: argparse.Namespace) -> None:
    spec = load_config(ROOT / "datasets.yaml").resolve("soccer", "quick", pool_size=args.n)
    store = generate_dataset(spec, scratch, workers=1, progress=False)
    group = open_store(store)
    everything = np.arange(spec.pool_size)
    data = {name: read_rows(array_at(group, name), everything) for name in ARRAYS}
    print(f"{spec.pool_size} samples at {spec.image_size}, {spec.shard_size} per shard, Blosc-LZ4")

    t_zarr, t_ours = time_writes(scratch, data, spec.shard_size, args.repeat)
    per = 1e3 / spec.pool_size
    print(f"write, image + semantic, whole shards   zarr-python {t_zarr * per:6.3f} ms/sample   "
          f"synthcal {t_ours * per:6.3f} ms/sample   ratio {t_zarr / t_ours:5.1f}   (bytes identical)")

    index = np.sort(np.random.default_rng(0).choice(spec.pool_size, args.split, replace=False))
    arrays = [array_at(group, name) for name in (*ARRAYS, "homography")]

    def zarr_read() -> list[np.ndarray]:
        return [np.asarray(a.get_orthogonal_selection((index,))) for a in arrays]

    def our_read() -> list[np.ndarray]:
        return [read_rows(a, index) for a in arrays]

    for theirs, ours in zip(zarr_read(), our_read(), strict=True):  # also warms the page cache
        np.testing.assert_array_equal(theirs, ours)
    t_zarr, t_ours = best_of(args.repeat, zarr_read), best_of(args.repeat, our_read)
    per = 1e3 / args.split
    print(f"read {args.split} sorted indices, image + semantic + homography   zarr-python {t_zarr * per:6.3f} ms/sample"
          f"   synthcal {t_ours * per:6.3f} ms/sample   ratio {t_zarr / t_ours:5.0f}")


if __name__ == "__main__":
    main()
