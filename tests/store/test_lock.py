"""One writer per store: the flock beside it (`generate` holds it too: tests/generate/test_pipeline.py)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from synthcal.generate.splits import draw_splits
from synthcal.store import StoreError, StoreLocked, lock_path, store_lock


def test_split_drawing_waits_for_no_one_it_refuses(smoke_stores, tmp_path):
    store = smoke_stores.copy(["intersection-2"], tmp_path)["intersection-2"]
    with store_lock(store) as lock:
        assert lock == tmp_path / ".intersection-2.lock" and lock.read_text() == f"{os.getpid()}\n"
        with pytest.raises(StoreLocked, match=rf"{store}: another synthcal process \(PID {os.getpid()}\) is "
                                              rf"writing this store \(lock {lock}\)"):
            draw_splits(store, seeds=[0], mixed=False)
        assert not (store / "splits").exists(), "nothing written"
    assert lock.read_text() == "", "released: no holder named"
    assert draw_splits(store, seeds=[0], mixed=False).drawn == (0,)


def test_the_kernel_releases_the_lock_of_a_dead_holder(tmp_path):
    store = tmp_path / "a.zarr"
    code = ("import os, sys; from synthcal.store import store_lock\n"
            "with store_lock(sys.argv[1]): os._exit(0)  # dies holding it: no cleanup runs")
    subprocess.run([sys.executable, "-c", code, str(store)], check=True)
    assert lock_path(store).read_text().strip().isdigit(), "the dead holder's PID is still written"
    with store_lock(store):  # yet the lock is free
        pass


def test_an_unwritable_folder_is_named(tmp_path):
    with pytest.raises(StoreError, match=rf"{tmp_path}/missing/a.zarr: cannot create the lock file"):
        with store_lock(tmp_path / "missing" / "a.zarr"):
            pass
