"""The sharded Zarr v3 store of one generated dataset (SPEC §5).

Layout (normative names)::

    image               (N, H, W, 3) uint8      chunk (1, H, W, 3), shard (S, H, W, 3)
    semantic            (N, H, W)    uint8      chunk (1, H, W),    shard (S, H, W)
    homography          (N, 3, 3)    float64    bird's-eye → image, depth sign kept
    camera/pan_deg …    (N,)         float64    pan_deg, tilt_deg, focal_px, x, y, z
    camera/grid_index   (N,)         int64
    scene/image         (Hs, Ws, 3)  uint8      the bird's-eye RGB
    scene/semantic      (Hs, Ws)     uint8      the bird's-eye class map
    splits/...                                  written by synthcal.generate.splits

Group attributes record the format version, the scene, the grid, ``N``, the seed,
the image size, ``focal_reference_width``, software versions and the hash of the
resolved configuration.

Atomicity: every file is written under a temporary name and renamed (by Zarr's
local store, or by :func:`synthcal.store.shards.write_shard` for the per-sample
arrays' shards), so a file is whole or absent. A store is built under ``NAME.zarr.partial``
and renamed to ``NAME.zarr`` only when every shard is in, so a store found under its
final name is always complete (its ``complete`` attribute says so too).
"""

from __future__ import annotations

import platform
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from zarr.codecs import BloscCodec

from synthcal.store.shards import ShardLayout, read_rows, shard_layout, write_shard

__all__ = [
    "FORMAT_VERSION",
    "CAMERA_FIELDS",
    "StoreError",
    "software_versions",
    "create_store",
    "image_layouts",
    "write_samples",
    "open_store",
    "read_samples",
    "array_at",
    "group_at",
    "attributes",
]

FORMAT_VERSION = "synthcal-store/1"
CAMERA_FIELDS = ("pan_deg", "tilt_deg", "focal_px", "x", "y", "z")
# LZ4 rather than Zstd: a third larger, but it both encodes and decodes several times
# faster, and reading a split must stay within a few times numpy.load of raw arrays.
_COMPRESSOR = BloscCodec(cname="lz4", clevel=5, shuffle="shuffle")


class StoreError(ValueError):
    """A store that is missing, incomplete or not a synthcal store."""


def software_versions() -> dict[str, str]:
    """Versions of the packages that shape the stored bytes."""
    versions = {"python": platform.python_version()}
    for package in ("synthcal", "numpy", "opencv-python-headless", "zarr"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "unknown"
    return versions


def _sample_array(
    group: zarr.Group, name: str, shape: tuple[int, ...], dtype: str, shard_size: int, compressed: bool = True
) -> zarr.Array:
    """An array with one sample per chunk and ``shard_size`` samples per shard."""
    return group.create_array(
        name,
        shape=shape,
        chunks=(1, *shape[1:]),
        shards=(shard_size, *shape[1:]),
        dtype=dtype,
        compressors=_COMPRESSOR if compressed else None,
        fill_value=0,
    )


def create_store(
    path: Path,
    attributes: dict[str, Any],
    image_size: tuple[int, int],
    shard_size: int,
    homography: np.ndarray,
    camera: dict[str, np.ndarray],
    scene_image: np.ndarray,
    scene_semantic: np.ndarray,
) -> zarr.Group:
    """Create a store with its per-sample metadata; images come shard by shard.

    Args:
        path: directory of the new group (must not exist).
        attributes: group attributes (provenance).
        image_size: ``(width, height)`` of the samples.
        shard_size: samples per shard.
        homography: (N, 3, 3) float64.
        camera: ``CAMERA_FIELDS`` as (N,) float64 and ``grid_index`` as (N,) int64.
        scene_image: (Hs, Ws, 3) uint8; scene_semantic: (Hs, Ws) uint8.

    Returns:
        the open group.
    """
    width, height = image_size
    count = len(homography)
    group = zarr.create_group(zarr.storage.LocalStore(path), zarr_format=3, attributes=attributes)
    _sample_array(group, "image", (count, height, width, 3), "uint8", shard_size)
    _sample_array(group, "semantic", (count, height, width), "uint8", shard_size)
    per_sample = {"homography": homography, **{f"camera/{name}": camera[name] for name in CAMERA_FIELDS},
                  "camera/grid_index": camera["grid_index"]}
    for name, values in per_sample.items():
        # 72 bytes or less per sample: compression saves nothing and costs a decode call per sample.
        layout = shard_layout(_sample_array(group, name, values.shape, values.dtype.str, shard_size, compressed=False))
        for shard, start in enumerate(range(0, count, shard_size)):
            write_shard(layout, shard, values[start:start + shard_size])
    for name, array in (("scene/image", scene_image), ("scene/semantic", scene_semantic)):
        group.create_array(name, shape=array.shape, chunks=array.shape, dtype="uint8",
                           compressors=_COMPRESSOR, fill_value=0)[:] = array
    return group


def array_at(group: zarr.Group, key: str) -> zarr.Array:
    """``group[key]``, which must be an array (Zarr types it as array or group)."""
    node = group[key]
    if not isinstance(node, zarr.Array):
        raise StoreError(f"{group.store_path}/{key}: a group where an array is expected")
    return node


def group_at(group: zarr.Group, key: str) -> zarr.Group:
    """``group[key]``, which must be a group."""
    node = group[key]
    if not isinstance(node, zarr.Group):
        raise StoreError(f"{group.store_path}/{key}: an array where a group is expected")
    return node


def attributes(node: zarr.Group | zarr.Array) -> dict[str, Any]:
    """A node's attributes as a plain dict (JSON values: each reader checks what it takes)."""
    return dict(node.attrs)


def image_layouts(path: Path) -> dict[str, ShardLayout]:
    """Shard layouts of the ``image`` and ``semantic`` arrays, for :func:`write_samples`."""
    group = zarr.open_group(zarr.storage.LocalStore(path), mode="r", zarr_format=3)
    return {name: shard_layout(array_at(group, name)) for name in ("image", "semantic")}


def write_samples(layouts: dict[str, ShardLayout], shard: int, image: np.ndarray, semantic: np.ndarray) -> None:
    """Write one shard's rendered samples, each array's shard file atomically."""
    write_shard(layouts["image"], shard, image)
    write_shard(layouts["semantic"], shard, semantic)


def open_store(path: str | Path, allow_incomplete: bool = False) -> zarr.Group:
    """Open a generated store for reading.

    Raises:
        StoreError: no such store, not a synthcal store, or (unless
            ``allow_incomplete``) a store whose generation has not finished.
    """
    path = Path(path)
    if not (path / "zarr.json").is_file():
        partial = path.with_name(path.name + ".partial")
        hint = f"; an unfinished run is at {partial}: rerun `synthcal generate` to resume it" if partial.exists() else ""
        raise StoreError(f"{path}: no synthcal store here{hint}")
    group = zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r", zarr_format=3)
    version = group.attrs.get("format_version")
    if version != FORMAT_VERSION:
        raise StoreError(f"{path}: format_version is {version!r}, expected {FORMAT_VERSION!r}")
    if not allow_incomplete and not group.attrs.get("complete", False):
        raise StoreError(f"{path}: the store is incomplete (generation did not finish)")
    return group


def read_samples(group: zarr.Group, index: np.ndarray) -> dict[str, np.ndarray]:
    """Samples at ``index`` (any order), read shard by shard.

    Returns:
        ``image`` (K, H, W, 3) uint8, ``semantic`` (K, H, W) uint8 and
        ``homography`` (K, 3, 3) float64, in the order of ``index``.
    """
    return {name: read_rows(array_at(group, name), index) for name in ("image", "semantic", "homography")}
