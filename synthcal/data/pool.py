"""The pool dictionary: every pool sample outside a seed's train, test and validation sets, read lazily.

>>> import tempfile, synthcal
>>> tmp = tempfile.TemporaryDirectory()
>>> store = synthcal.generate_store("intersection-1", tmp.name, profile="smoke")   # 64 × 36 images
>>> d = load_pool_dictionary(store, seed=0)
>>> len(d), d.semantics.shape           # the paper profile's store: (46000, (46000, 144, 256))
(12, (12, 36, 64))
>>> [(start, maps.shape) for start, maps in d.semantics.batches(8)]
[(0, (8, 36, 64)), (8, (4, 36, 64))]
>>> tmp.cleanup()

The object is a :class:`synthcal.data.SplitDataset` (``split`` ``dictionary``,
``pool`` True) whose ``images``, ``semantics`` and ``homographies`` are
:class:`LazyRows`: array-likes with ``shape``, ``dtype``, ``len``, slicing and
integer-array indexing, ``numpy.asarray`` and :meth:`LazyRows.batches`, which read
the rows they are asked for from the store (shard by shard, read-only arrays) and
keep nothing. A 200,000-template dictionary thus costs its indices in memory until
someone reads it; ``numpy.asarray(d.images)`` would read every image, so estimators
stream (:meth:`LazyRows.batches`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from synthcal.data.loaders import SplitDataset, StoreScene, read_scene
from synthcal.store import array_at, open_store
from synthcal.store.images import check_rendered
from synthcal.store.shards import read_rows
from synthcal.store.splits import pool_dictionary_indices

__all__ = ["LazyRows", "load_pool_dictionary", "DEFAULT_BATCH"]

# Rows read per batch by :meth:`LazyRows.batches` and ``numpy.asarray``.
DEFAULT_BATCH = 1024


class LazyRows:
    """Rows ``indices`` of one store array, read on access (module docstring).

    Args:
        store: the store's path.
        name: the array (``image``, ``semantic``, ``homography``).
        indices: (K,) int64 pool indices, the rows in order.

    Attributes:
        shape: ``(K, *row shape)``; dtype: the array's dtype; ndim.
    """

    def __init__(self, store: Path, name: str, indices: np.ndarray) -> None:
        self.store = Path(store)
        self.name = name
        self.indices = np.asarray(indices, np.int64)
        array = self._array()
        self.shape: tuple[int, ...] = (len(self.indices), *array.shape[1:])
        self.dtype = np.dtype(array.dtype)

    def _array(self) -> zarr.Array:
        # Opened on each access rather than kept: the object pickles, and open_store's manifest
        # check was done by whoever made it (load_pool_dictionary).
        group = zarr.open_group(zarr.storage.LocalStore(self.store, read_only=True), mode="r", zarr_format=3)
        return array_at(group, self.name)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __len__(self) -> int:
        return self.shape[0]

    def _read(self, rows: np.ndarray) -> np.ndarray:
        array = self._array()
        if self.name == "image":  # an images: splits store: never zeros for an image not rendered
            check_rendered(zarr.open_group(zarr.storage.LocalStore(self.store, read_only=True), mode="r",
                                           zarr_format=3), self.indices[rows], self.store)
        out = read_rows(array, self.indices[rows])
        out.flags.writeable = False
        return out

    def __getitem__(self, key: Any) -> np.ndarray:
        """``rows[k]`` (one row), ``rows[a:b:s]``, ``rows[int array]``, ``rows[bool mask]``,
        or a tuple whose first item is one of those (the rest applies to what is read)."""
        rest: tuple[Any, ...] = ()
        if isinstance(key, tuple):
            key, rest = key[0], key[1:]
        if isinstance(key, (int, np.integer)):
            row = self._read(np.arange(len(self))[np.array([key])])[0]
            return row[rest] if rest else row
        selected = self._read(np.arange(len(self))[key])
        return selected[(slice(None), *rest)] if rest else selected

    def batches(self, size: int = DEFAULT_BATCH) -> Iterator[tuple[int, np.ndarray]]:
        """``(start, rows[start:start + size])`` over all rows, in order."""
        for start in range(0, len(self), size):
            yield start, self[start:start + size]

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray:
        out = np.empty(self.shape, self.dtype)
        for start, rows in self.batches():
            out[start:start + len(rows)] = rows
        return out if dtype is None else out.astype(dtype, copy=False)

    def __repr__(self) -> str:
        return f"LazyRows({self.store.name}/{self.name}, shape={self.shape}, dtype={self.dtype})"


def load_pool_dictionary(store: str | Path, seed: int, scene: StoreScene | None = None) -> SplitDataset:
    """A seed's pool dictionary (module docstring): lazy arrays, nothing read but the indices.

    Args:
        store: the dataset's store (with its own pool: a mixed dictionary has no pool
            dictionary; :func:`synthcal.eval.runs.expand_runs` refuses one).
        seed: the split seed whose train and test samples are left out.
        scene: the store's scene when already read.

    Raises:
        SplitError: an unknown seed; StoreError: the store cannot be read.
    """
    store = Path(store)
    group = open_store(store)  # the manifest check, once
    indices = pool_dictionary_indices(store, seed, group)
    arrays = {name: LazyRows(store, name, indices) for name in ("image", "semantic", "homography")}
    return SplitDataset(arrays, indices, store, "dictionary", seed, scene or read_scene(store, group), pool=True)
