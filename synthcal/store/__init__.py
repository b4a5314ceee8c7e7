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

from synthcal.store.errors import CorruptStore, StoreError, StoreLocked
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
from synthcal.store.lock import lock_path, store_lock
from synthcal.store.manifest import MANIFEST_FILE, read_manifest, resealing, write_manifest
from synthcal.store.splits import (
    SPLIT_NAMES,
    STORED_SPLITS,
    VALIDATION,
    MixedDictionary,
    SplitError,
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
