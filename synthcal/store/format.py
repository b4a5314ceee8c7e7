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
    image_rendered      (N,)         uint8      only with ``images: splits``: 1 where the image is stored

Group attributes record the format version, the scene, the grid, ``N``, the seed,
the image size, ``focal_reference_width``, software versions and the hash of the
resolved configuration.

Integrity: every array's inner codec chain ends in Zarr v3's ``crc32c`` codec, so
each chunk carries its CRC32C (checked by :mod:`synthcal.store.shards`' reader and
by zarr-python alike), and each shard's index carries its own. A complete store has
a sealed manifest file, ``manifest.json`` (:mod:`synthcal.store.manifest`): every
file of the store — shard files, every ``zarr.json``, splits and mixed dictionaries,
whatever is added later — with its size and CRC32C, the manifest itself under a
checksum of its content. :func:`open_store` checks it before Zarr parses anything:
every listed file present with its size, the metadata documents and everything
under ``splits/`` by CRC32C, no unlisted file under ``splits/``; a mismatch is a
:class:`CorruptStore` naming the file. :mod:`synthcal.store.verify` checks every
byte. Older formats still read, with a :class:`LegacyStoreWarning`:
``synthcal-store/2`` (its ``manifest`` attribute lists only the shard files of
:data:`MANIFEST_ARRAYS`, checked as before) and ``synthcal-store/1`` (no chunk
checksums, no manifest).

Images only where used (``images: splits``, :mod:`synthcal.store.images`): the
``image`` array then holds chunks only for the samples some drawn split uses; the
``images`` attribute (``mode``, ``rendered``, ``state``) and the small per-sample
array ``image_rendered`` say which, and reading another sample's image raises
:class:`~synthcal.store.images.ImagesNotRendered`. Drawing splits that render more
images rewrites those shard files, then reseals the manifest. A store without the ``images`` attribute holds
every image (``images: all``, the default, byte-identical to stores made before).

Atomicity: every file is written under a temporary name and renamed (by Zarr's
local store, or by :func:`synthcal.store.shards.write_shard` for the per-sample
arrays' shards), so a file is whole or absent. A store is built under ``NAME.zarr.partial``
and renamed to ``NAME.zarr`` only when every shard is in, so a store found under its
final name is always complete (its ``complete`` attribute says so too).
"""

from __future__ import annotations

import platform
import warnings
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from zarr.codecs import BloscCodec, Crc32cCodec, ZstdCodec

from synthcal.store.errors import CorruptStore, StoreError
from synthcal.store.images import PRESENCE_ARRAY, check_rendered, images_rendering
from synthcal.store.manifest import MANIFEST_FILE, check_files, file_crc32c, read_manifest
from synthcal.store.shards import ShardLayout, read_rows, shard_layout, write_samples, write_shard

__all__ = [
    "FORMAT_VERSION",
    "LEGACY_FORMAT_VERSIONS",
    "LEGACY_LACKS",
    "CAMERA_FIELDS",
    "MANIFEST_ARRAYS",
    "CHECKSUMMED",
    "CHECKSUMMED_INDEX",
    "file_crc32c",
    "open_group",
    "StoreError",
    "CorruptStore",
    "LegacyStoreWarning",
    "manifest",
    "check_manifest",
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

FORMAT_VERSION = "synthcal-store/3"
# Older formats still read: /2's manifest attribute covers only shard files, /1 has none and no chunk checksums.
LEGACY_FORMAT_VERSIONS = ("synthcal-store/1", "synthcal-store/2")
# What each older format lacks, for the warning on opening it and verify's note.
LEGACY_LACKS = {"synthcal-store/1": "has no chunk checksums and no manifest",
                "synthcal-store/2": "has a manifest of its shard files only (metadata and splits unchecked)"}
CAMERA_FIELDS = ("pan_deg", "tilt_deg", "focal_px", "x", "y", "z")
# The arrays of a complete store that a synthcal-store/2 manifest attribute lists.
MANIFEST_ARRAYS = ("image", "semantic", "homography", *(f"camera/{name}" for name in CAMERA_FIELDS),
                   "camera/grid_index", "scene/image", "scene/semantic")
# LZ4 rather than Zstd: a third larger, but it both encodes and decodes several times
# faster, and reading a split must stay within a few times numpy.load of raw arrays.
_COMPRESSOR = BloscCodec(cname="lz4", clevel=5, shuffle="shuffle")
# Every array's inner chain ends in a CRC32C of the encoded chunk (``compressors`` of
# ``create_array``: the bytes-to-bytes codecs after the ``bytes`` serializer).
_CHECKSUM = Crc32cCodec()
CHECKSUMMED = (_COMPRESSOR, _CHECKSUM)
# Small int64 index arrays (splits): Zarr's default compressor, then the checksum.
CHECKSUMMED_INDEX = (ZstdCodec(level=0), _CHECKSUM)


class LegacyStoreWarning(UserWarning):
    """A store of an older format: it reads, but damage to some of its files may go unnoticed."""


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
        compressors=CHECKSUMMED if compressed else (_CHECKSUM,),
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
    images_splits: bool = False,
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
        images_splits: also create ``image_rendered`` (all 0) for an ``images: splits`` store.

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
                           compressors=CHECKSUMMED, fill_value=0)[:] = array
    if images_splits:
        group.create_array(PRESENCE_ARRAY, shape=(count,), chunks=(max(count, 1),), dtype="uint8",
                           compressors=CHECKSUMMED_INDEX, fill_value=0)
    return group


def _node(group: zarr.Group, key: str) -> zarr.Array | zarr.Group:
    """``group[key]``; a node that is missing or whose metadata Zarr cannot parse is damage, named."""
    try:
        return group[key]
    except KeyError:
        raise CorruptStore(f"{group.store_path}/{key}: missing (its zarr.json is gone)") from None
    except (ValueError, TypeError) as exc:  # JSONDecodeError, zarr's MetadataValidationError
        reason = " ".join(str(exc).split())
        raise CorruptStore(f"{group.store_path}/{key}/zarr.json: not valid Zarr metadata ({reason})") from None


def array_at(group: zarr.Group, key: str) -> zarr.Array:
    """``group[key]``, which must be an array (Zarr types it as array or group).

    Raises:
        StoreError: a group there; CorruptStore: nothing there, or damaged metadata.
    """
    node = _node(group, key)
    if not isinstance(node, zarr.Array):
        raise StoreError(f"{group.store_path}/{key}: a group where an array is expected")
    return node


def group_at(group: zarr.Group, key: str) -> zarr.Group:
    """``group[key]``, which must be a group (errors as :func:`array_at`'s)."""
    node = _node(group, key)
    if not isinstance(node, zarr.Group):
        raise StoreError(f"{group.store_path}/{key}: an array where a group is expected")
    return node


def attributes(node: zarr.Group | zarr.Array) -> dict[str, Any]:
    """A node's attributes as a plain dict (JSON values: each reader checks what it takes)."""
    return dict(node.attrs)


def image_layouts(path: Path) -> dict[str, ShardLayout]:
    """Shard layouts of the ``image`` and ``semantic`` arrays, for :func:`write_samples`."""
    group = open_group(path)
    return {name: shard_layout(array_at(group, name)) for name in ("image", "semantic")}


def _chunk_files(folder: Path) -> list[Path]:
    """The chunk (shard) files of an array folder, in a fixed order."""
    root = folder / "c"
    return sorted((p for p in root.rglob("*") if p.is_file()), key=lambda p: p.relative_to(root).parts) \
        if root.is_dir() else []


def manifest(path: Path, names: tuple[str, ...] = MANIFEST_ARRAYS) -> dict[str, Any]:
    """A ``synthcal-store/2`` ``manifest`` attribute, of :data:`MANIFEST_ARRAYS` (or the arrays ``names``).

    Kept to update the attribute of such a store when images are rendered into it;
    stores of the current format record :mod:`synthcal.store.manifest`'s file instead.

    Returns:
        ``{array: {"shards": n, "files": {"c/0/0/0/0": {"size": bytes, "crc32c": "8 hex"}}}}``;
        ``shards`` counts the shard grid's cells (a cell holding only fill values has no file).
    """
    group = open_group(path)
    out: dict[str, Any] = {}
    for name in names:
        array = array_at(group, name)
        folder = path / name
        files = {p.relative_to(folder).as_posix(): {"size": p.stat().st_size, "crc32c": file_crc32c(p)}
                 for p in _chunk_files(folder)}
        out[name] = {"shards": int(np.prod([-(-n // s) for n, s in zip(array.shape, array.shards or array.chunks,
                                                                            strict=True)])),
                     "files": files}
    return out


def check_manifest(path: Path, recorded: dict[str, Any], checksums: bool = False) -> list[str]:
    """What differs between a ``synthcal-store/2`` store's files and its ``manifest`` attribute (empty: all well).

    Args:
        path: the store.
        recorded: its ``manifest`` attribute.
        checksums: also read every file and compare its CRC32C (else sizes only: cheap).
    """
    problems = []
    for name in MANIFEST_ARRAYS:
        entry = recorded.get(name)
        if not isinstance(entry, dict) or not isinstance(entry.get("files"), dict):
            problems.append(f"{path / name}: missing from the store's manifest")
            continue
        if not (path / name / "zarr.json").is_file():
            problems.append(f"{path / name / 'zarr.json'}: missing (the array's metadata)")
        for key, expected in entry["files"].items():
            file = path / name / key
            try:
                size = file.stat().st_size
            except FileNotFoundError:
                problems.append(f"{file}: shard file missing (the manifest records {expected['size']} bytes)")
                continue
            if size != expected["size"]:
                problems.append(f"{file}: {size} bytes, the manifest records {expected['size']}")
            elif checksums and file_crc32c(file) != expected["crc32c"]:
                problems.append(f"{file}: file checksum {file_crc32c(file)} differs from the manifest's "
                                f"{expected['crc32c']}")
        if checksums:
            for extra in sorted({p.relative_to(path / name).as_posix() for p in _chunk_files(path / name)}
                                - set(entry["files"])):
                problems.append(f"{path / name / extra}: a file the manifest does not list")
    return problems


def open_group(path: Path, mode: str = "r") -> zarr.Group:
    """The Zarr group of a local store; metadata that Zarr cannot parse is an error naming the store.

    Raises:
        CorruptStore: the root ``zarr.json`` is not valid group metadata (e.g. truncated).
    """
    try:
        return zarr.open_group(zarr.storage.LocalStore(path, read_only=mode == "r"), mode=mode,  # type: ignore[arg-type]
                               zarr_format=3)
    except (ValueError, KeyError, TypeError) as exc:  # JSONDecodeError, zarr's MetadataValidationError, a lost key
        reason = " ".join(str(exc).split())
        raise CorruptStore(f"{path / 'zarr.json'}: not valid Zarr group metadata ({type(exc).__name__}: "
                           f"{reason})") from None


def _raise_problems(path: Path, problems: list[str]) -> None:
    """One line for what the cheap check found (the first few files; ``verify`` lists them all)."""
    if problems:
        more = f"; and {len(problems) - 3} more" if len(problems) > 3 else ""
        raise CorruptStore("; ".join(problems[:3]) + more + f" (run `synthcal verify {path}`)")


def _check_sealed(path: Path, writer: bool) -> None:
    """The cheap check of a store's manifest file (:func:`synthcal.store.manifest.check_files`)."""
    recorded = read_manifest(path)
    if recorded.state == "writing":
        if writer:  # a killed writer's: this one reseals it
            return
        raise CorruptStore(f"{path}: a writer (split drawing or image rendering) is at work or was stopped before "
                           f"it finished, so its files are not sealed; once none runs, `synthcal split {path}` "
                           f"finishes the job")
    _raise_problems(path, check_files(path, recorded))


def open_store(path: str | Path, allow_incomplete: bool = False, writer: bool = False) -> zarr.Group:
    """Open a generated store for reading.

    A complete store is first checked against its manifest file, before Zarr parses
    anything (module docstring, *Integrity*): one ``stat`` per file, a CRC32C of the
    metadata documents and splits; :mod:`synthcal.store.verify` checks every byte.

    Args:
        path: the store.
        allow_incomplete: open a store whose generation has not finished.
        writer: the caller holds the store's lock and reseals it afterwards
            (:func:`synthcal.store.manifest.resealing`): a manifest left ``writing`` by
            a killed writer is accepted.

    Raises:
        StoreError: no such store, not a synthcal store, or (unless
            ``allow_incomplete``) a store whose generation has not finished.
        CorruptStore: a file missing, of another size or checksum than the manifest
            records or not listed in it, a damaged or missing manifest, metadata Zarr
            cannot parse; names the file.

    Warns:
        LegacyStoreWarning: a store of an older format (:data:`LEGACY_FORMAT_VERSIONS`).
    """
    path = Path(path)
    sealed = (path / MANIFEST_FILE).is_file()
    if not sealed and not (path / "zarr.json").is_file():
        partial = path.with_name(path.name + ".partial")
        hint = f"; an unfinished run is at {partial}: rerun `synthcal generate` to resume it" if partial.exists() else ""
        raise StoreError(f"{path}: no synthcal store here{hint}")
    if sealed:
        _check_sealed(path, writer)
    group = open_group(path)
    version = group.attrs.get("format_version")
    if version in LEGACY_FORMAT_VERSIONS:
        warnings.warn(f"{path}: format_version {version!r} {LEGACY_LACKS[str(version)]}: damage may go "
                      f"unnoticed; regenerate it to get format {FORMAT_VERSION!r}", LegacyStoreWarning, stacklevel=2)
    elif version != FORMAT_VERSION:
        raise StoreError(f"{path}: format_version is {version!r}, expected {FORMAT_VERSION!r}")
    complete = bool(group.attrs.get("complete", False))
    if not allow_incomplete and not complete:
        raise StoreError(f"{path}: the store is incomplete (generation did not finish)")
    if complete and version == FORMAT_VERSION and not sealed:
        raise CorruptStore(f"{path / MANIFEST_FILE}: missing (a complete store of format {FORMAT_VERSION} has one)")
    if complete and version == "synthcal-store/2":
        recorded = group.attrs.get("manifest")
        if not isinstance(recorded, dict):
            raise CorruptStore(f"{path}/zarr.json: a complete store without its 'manifest' attribute")
        problems = check_manifest(path, recorded)
        if images_rendering(group.attrs):  # images being added (or a renderer killed): it rewrites their entry
            problems = [p for p in problems if not p.startswith(f"{path / 'image'}/")]
        _raise_problems(path, problems)
    return group


def read_samples(group: zarr.Group, index: np.ndarray) -> dict[str, np.ndarray]:
    """Samples at ``index`` (any order), read shard by shard.

    Returns:
        ``image`` (K, H, W, 3) uint8, ``semantic`` (K, H, W) uint8 and
        ``homography`` (K, 3, 3) float64, in the order of ``index``.

    Raises:
        ImagesNotRendered: an ``images: splits`` store without some of these images.
    """
    check_rendered(group, index)
    return {name: read_rows(array_at(group, name), index) for name in ("image", "semantic", "homography")}
