"""``synthcal verify``: read a whole store back and report every damaged file.

Checks, in order: that it is a complete synthcal store; its manifest file
(:mod:`synthcal.store.manifest`: its seal, then every file of the store present,
of the recorded size and CRC32C, and no file it does not list — metadata, splits
and mixed dictionaries included); then every array found on disk (each
``zarr.json``), splits included: its metadata parses, each shard's index checksum,
each chunk's checksum, and that every chunk decodes. Arrays of the store's own
layout are read by :mod:`synthcal.store.shards` shard by shard; any other array
(``scene/``, ``splits/``) through zarr-python, which checks the ``crc32c`` codec
itself. Stores of format ``synthcal-store/2`` are held to their ``manifest``
attribute (shard files only), ``synthcal-store/1`` to nothing but their chunks.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr

from synthcal.store.errors import CorruptStore, StoreError
from synthcal.store.format import (
    FORMAT_VERSION,
    LEGACY_FORMAT_VERSIONS,
    LEGACY_LACKS,
    LegacyStoreWarning,
    check_manifest,
    open_group,
    open_store,
)
from synthcal.store.manifest import MANIFEST_FILE, check_files, read_manifest, store_files
from synthcal.store.shards import UnsupportedLayout, read_rows, shard_layout

__all__ = ["Report", "verify_store"]


@dataclass
class Report:
    """What :func:`verify_store` found.

    Attributes:
        store: the store checked.
        problems: one message per damaged file or unreadable array (empty: the store is whole).
        notes: remarks that are not damage (e.g. an older format without chunk checksums).
    """

    store: Path
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems


def _arrays(store: Path) -> tuple[list[tuple[str, zarr.Array]], list[str]]:
    """Every array of a store, found by its ``zarr.json`` on disk, with its path; and the metadata Zarr cannot read."""
    arrays, problems = [], []
    root = zarr.storage.LocalStore(store, read_only=True)
    for name in store_files(store):
        if not name.endswith("/zarr.json"):
            continue
        key = name.removesuffix("/zarr.json")
        try:
            node = zarr.open(root, path=key, mode="r", zarr_format=3)
        except Exception as exc:  # noqa: BLE001 (any metadata Zarr cannot read is damage to report)
            problems.append(f"{store / name}: not valid Zarr metadata ({type(exc).__name__}: "
                            f"{' '.join(str(exc).split())})")
            continue
        if isinstance(node, zarr.Array):
            arrays.append((key, node))
    return arrays, problems


def _check_array(store: Path, key: str, array: zarr.Array) -> list[str]:
    """Read one array back whole, shard by shard where the layout allows; the errors met."""
    try:
        layout = shard_layout(array)
    except UnsupportedLayout:
        try:
            array[...]
        except Exception as exc:  # noqa: BLE001 (any failure to read back is damage to report)
            return [f"{store / key}: cannot be read back ({type(exc).__name__}: {exc})"]
        return []
    problems = []
    for start in range(0, array.shape[0], layout.shard_size):
        rows = np.arange(start, min(start + layout.shard_size, array.shape[0]))
        try:
            read_rows(array, rows, threads=1)
        except Exception as exc:  # noqa: BLE001 (CorruptStore names the file; a decoder error may not)
            message = str(exc)
            path = str(layout.path(start // layout.shard_size))
            problems.append(message if path in message else f"{path}: {type(exc).__name__}: {message}")
    return problems


def _check_manifest_file(store: Path, report: Report) -> None:
    """The manifest file against every byte of the store (a store without one: nothing to do here)."""
    if not (store / MANIFEST_FILE).is_file():
        return
    try:
        recorded = read_manifest(store)
    except CorruptStore as exc:
        report.problems.append(str(exc))
        return
    if recorded.state == "writing":
        report.problems.append(f"{store / MANIFEST_FILE}: state 'writing': a split drawing or image rendering was "
                               f"stopped before it finished (`synthcal split {store}` finishes it)")
    report.problems.extend(check_files(store, recorded, full=True))


def verify_store(path: str | Path) -> Report:
    """Check a store completely (see the module docstring).

    Returns:
        a :class:`Report`; ``report.ok`` when nothing is wrong.
    """
    report = Report(Path(path))
    store = report.store
    opened: str | None = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LegacyStoreWarning)  # noted below instead
        try:
            open_store(store, allow_incomplete=True)
        except CorruptStore as exc:  # the full checks below name each file; this message only if they find nothing
            opened = str(exc)
        except StoreError as exc:
            report.problems.append(str(exc))
            return report
    _check_manifest_file(store, report)
    try:
        group = open_group(store)
    except CorruptStore as exc:
        report.problems.extend(p for p in [str(exc)] if p not in report.problems)
        return report
    version = group.attrs.get("format_version")
    if not group.attrs.get("complete", False):
        report.problems.append(f"{store}: the store is incomplete (generation did not finish)")
    if version in LEGACY_FORMAT_VERSIONS:
        report.notes.append(f"{store}: format {version!r} {LEGACY_LACKS[str(version)]}, so only what it records "
                            f"was checked; regenerate for {FORMAT_VERSION!r}")
    if isinstance(recorded := group.attrs.get("manifest"), dict):
        report.problems.extend(p for p in check_manifest(store, recorded, checksums=True)
                               if p not in report.problems)
    arrays, unreadable = _arrays(store)
    report.problems.extend(p for p in unreadable if p not in report.problems)
    for key, array in arrays:
        report.problems.extend(p for p in _check_array(store, key, array) if p not in report.problems)
    if opened is not None and not report.problems:
        report.problems.append(opened)
    return report
