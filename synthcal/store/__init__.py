"""The store: the format of a dataset's Zarr v3 store (SPEC §5), its shards and its splits.

* :mod:`synthcal.store.format` — creating, opening and reading a store;
* :mod:`synthcal.store.shards` — whole shard files written and read byte for byte
  as Zarr's sharding codec lays them out;
* :mod:`synthcal.store.images` — which RGB images a store holds (``images: all | splits``);
* :mod:`synthcal.store.lock` — one writer per store (an exclusive ``flock``);
* :mod:`synthcal.store.manifest` — the sealed list of every file of a store, its size and CRC32C;
* :mod:`synthcal.store.verify` — reading a whole store back, checksums and all;
* :mod:`synthcal.store.splits` — reading the per-seed splits a store holds (drawing
  them is generation's job, :mod:`synthcal.generate.splits`).

Imports only :mod:`synthcal.config` and :mod:`synthcal.utils` of synthcal.
"""

import importlib
from typing import TYPE_CHECKING, Any

from synthcal.store.errors import CorruptStore, StoreError, StoreLocked
from synthcal.store.lock import lock_path, store_lock
from synthcal.store.manifest import MANIFEST_FILE, read_manifest, resealing, write_manifest

# The modules below import zarr (≈ 0.1–0.4 s): their names are imported on first use
# (PEP 562), so a generate worker, which imports only synthcal.store.shards to write
# its shards, never loads zarr. The TYPE_CHECKING block shows mypy the same names.
_ZARR_MODULES = ("format", "images", "splits", "verify")

if TYPE_CHECKING:
    from synthcal.store.format import (
        CAMERA_FIELDS,
        CHECKSUMMED,
        CHECKSUMMED_INDEX,
        FORMAT_VERSION,
        MANIFEST_ARRAYS,
        LegacyStoreWarning,
        array_at,
        attributes,
        create_store,
        group_at,
        image_layouts,
        manifest,
        open_group,
        open_store,
        read_samples,
        software_versions,
        write_samples,
    )
    from synthcal.store.images import ImagesNotRendered, check_rendered, image_mode, rendered_mask
    from synthcal.store.splits import (
        SPLIT_NAMES,
        STORED_SPLITS,
        VALIDATION,
        MixedDictionary,
        SplitError,
        dictionary_is_mixed,
        drawn_seeds,
        read_mixed_dictionary,
        read_mixed_samples,
        read_split_indices,
        resolve_mixed_dictionary,
        source_store_path,
        store_spec,
    )
    from synthcal.store.verify import Report, verify_store

__all__ = [
    "CAMERA_FIELDS",
    "CHECKSUMMED",
    "CHECKSUMMED_INDEX",
    "FORMAT_VERSION",
    "StoreError",
    "StoreLocked",
    "CorruptStore",
    "LegacyStoreWarning",
    "MANIFEST_ARRAYS",
    "lock_path",
    "store_lock",
    "manifest",
    "MANIFEST_FILE",
    "read_manifest",
    "resealing",
    "write_manifest",
    "array_at",
    "attributes",
    "create_store",
    "group_at",
    "open_group",
    "image_layouts",
    "open_store",
    "read_samples",
    "software_versions",
    "write_samples",
    "SPLIT_NAMES",
    "STORED_SPLITS",
    "VALIDATION",
    "MixedDictionary",
    "SplitError",
    "dictionary_is_mixed",
    "drawn_seeds",
    "read_mixed_dictionary",
    "read_mixed_samples",
    "read_split_indices",
    "resolve_mixed_dictionary",
    "source_store_path",
    "store_spec",
    "verify_store",
    "ImagesNotRendered",
    "check_rendered",
    "image_mode",
    "rendered_mask",
    "Report",
]


def __getattr__(name: str) -> Any:
    """A public name of a zarr-backed module (or that module itself), imported on first use."""
    if name in _ZARR_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    if name in __all__:
        for module in map(importlib.import_module, (f"{__name__}.{m}" for m in _ZARR_MODULES)):
            if hasattr(module, name):
                globals()[name] = getattr(module, name)
                return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
