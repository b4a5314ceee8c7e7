"""Opening a store: the sealed manifest's check against the shard-size check it replaced and a bare Zarr open.

Generates (in a temporary folder, or once in ``--scratch``) an intersection-1 pool
at the ``smoke`` profile's 64 × 36 (8 samples per shard: many files for few bytes,
the manifest's worst case) with the splits of seeds 0–4, and times in the same run,
best of ``--repeat`` interleaved rounds, everything from the page cache:

* ``bare``: ``zarr.open_group`` and reading the attributes — no check at all;
* ``old``: a bare open plus one ``stat`` per shard file (what opening a
  ``synthcal-store/2`` store checked: sizes of the shard files, nothing else);
* ``open_store``: as shipped — the manifest read and its seal checked, every listed
  file ``stat``-ed, every ``zarr.json`` and split file read for its CRC32C, ``splits/``
  walked for unlisted files, then the Zarr open;
* ``synthcal info STORE`` in process (output discarded), as shipped and with
  ``open_store``'s check replaced by the old one.

Target: ``info`` ≤ 2× with the old check.

Run: .venv/bin/python benchmarks/store_open.py [--n 1024] [--repeat 20] [--scratch DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
from pathlib import Path
from unittest import mock

import zarr
from timing import best_of  # benchmarks/timing.py (scripts run from benchmarks/)

from synthcal.cli import main as cli
from synthcal.config import load_config
from synthcal.generate.pipeline import generate_dataset
from synthcal.generate.splits import draw_splits
from synthcal.store import format as store_format
from synthcal.store import open_store, read_manifest

ROOT = Path(__file__).resolve().parents[1]


def prepare(scratch: Path, n: int) -> Path:
    """The store, generated once into ``scratch``, with its splits."""
    spec = load_config(ROOT / "datasets.yaml").resolve("intersection-1", "smoke", pool_size=n)
    store = generate_dataset(spec, scratch, workers=1, progress=False)
    draw_splits(store, mixed=False)
    return store


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1024, help="pool size (default 1024: 128 shards per array)")
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--scratch", type=Path, default=None, help="keep the store here between runs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        store = prepare(args.scratch or Path(tmp), args.n)
        files = read_manifest(store).files
        shards = [store / name for name in files if "/c/" in name and not name.startswith("splits/")]

        def bare() -> None:
            dict(zarr.open_group(zarr.storage.LocalStore(store, read_only=True), mode="r", zarr_format=3).attrs)

        def old_check(path: Path, writer: bool) -> None:
            for shard in shards:
                shard.stat()

        def info() -> None:
            with contextlib.redirect_stdout(io.StringIO()):
                assert cli(["info", str(store)]) == 0

        def old() -> None:
            old_check(store, False)
            bare()

        def info_old() -> None:
            with mock.patch.object(store_format, "_check_sealed", old_check):
                info()

        calls = {"bare": bare, "old": old, "open_store": lambda: open_store(store), "info": info,
                 "info (old check)": info_old}
        # Interleaved rounds, best of each: a burst of load on the shared machine hits all alike.
        rounds = [{name: best_of(1, fn) for name, fn in calls.items()} for _ in range(args.repeat)]
        times = {name: min(r[name] for r in rounds) for name in calls}
    print(f"store: {args.n} samples, {len(files)} files ({len(shards)} shard files outside splits/)")
    for name, seconds in times.items():
        print(f"{name:18s} {1e3 * seconds:8.2f} ms")
    print(f"open_store / old   {times['open_store'] / times['old']:.2f}×   open_store / bare "
          f"{times['open_store'] / times['bare']:.2f}×")
    print(f"info / info (old check) {times['info'] / times['info (old check)']:.2f}×   (target ≤ 2)")


if __name__ == "__main__":
    main()
