"""``synthcal verify``: read a whole store back and report every damaged file.

Checks, in order: that it is a complete synthcal store; its manifest (every shard
file present, of the recorded size and CRC32C, and no file it does not list); then
every array (splits included): each shard's index checksum, each chunk's checksum,
and that every chunk decodes. Arrays of the store's own layout are read by
:mod:`synthcal.store.shards` shard by shard; any other array (``scene/``,
``splits/``) through zarr-python, which checks the ``crc32c`` codec itself.
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
    LegacyStoreWarning,
    check_manifest,
    open_store,
)
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


def _arrays(group: zarr.Group, prefix: str = "") -> list[tuple[str, zarr.Array]]:
    """Every array under a group, depth first, with its path."""
    out: list[tuple[str, zarr.Array]] = []
    for name, node in sorted(group.members(), key=lambda item: item[0]):
        key = f"{prefix}{name}"
        if isinstance(node, zarr.Array):
            out.append((key, node))
        else:
            out.extend(_arrays(node, key + "/"))
    return out


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


def verify_store(path: str | Path) -> Report:
    """Check a store completely (see the module docstring).

    Returns:
        a :class:`Report`; ``report.ok`` when nothing is wrong.
    """
    report = Report(Path(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LegacyStoreWarning)  # noted below instead
        try:
            group = open_store(path, allow_incomplete=True)
        except CorruptStore:  # a manifest mismatch: the full check below names each file
            group = zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r", zarr_format=3)
        except StoreError as exc:
            report.problems.append(str(exc))
            return report
    version = group.attrs.get("format_version")
    if not group.attrs.get("complete", False):
        report.problems.append(f"{path}: the store is incomplete (generation did not finish)")
    if version in LEGACY_FORMAT_VERSIONS:
        report.notes.append(f"{path}: format {version!r}: no chunk checksums and no manifest, so only shard "
                            f"indexes and decoding were checked; regenerate for {FORMAT_VERSION!r}")
    elif isinstance(recorded := group.attrs.get("manifest"), dict):
        report.problems.extend(p for p in check_manifest(report.store, recorded, checksums=True)
                               if p not in report.problems)
    for key, array in _arrays(group):
        report.problems.extend(p for p in _check_array(report.store, key, array) if p not in report.problems)
    return report
