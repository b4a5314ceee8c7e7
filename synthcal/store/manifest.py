"""The store's manifest: every file of a complete store with its size and CRC32C, in one sealed file.

File ``<store>/manifest.json`` (format ``synthcal-store/3``), written by
:func:`write_manifest`::

    {
     "files": {
      "camera/focal_px/c/0": {"crc32c": "59c4ac9e", "size": 228},
      ...
      "zarr.json": {"crc32c": "…", "size": 5301}
     },
     "layout": "synthcal-manifest/1",
     "seal": "8 hex digits",
     "state": "sealed"
    }

``files`` lists **every** file under the store folder but the manifest itself — each
shard file, the ``zarr.json`` of the root, of every group and array, the splits and
mixed dictionaries, whatever a later writer adds — so nothing is outside it by
construction. ``seal`` is the CRC32C of the file's own text with the seal's digits
zeroed: any changed, added or removed byte of the manifest itself is damage too.
No timestamps: the same store gives the same manifest, byte for byte.

Writers (generation at completion; split drawing and image rendering afterwards,
under the store's lock) go through :func:`resealing`: before their first write the
manifest's ``state`` becomes ``writing``, and when they finish (or fail: every file
is written atomically, so the files are whole either way) it is recomputed from the
files and ``sealed``. A writer killed in between leaves ``writing``: readers refuse
the store, naming the command that reseals it.

Checks (:func:`check_files`): opening a store stats every listed file (missing,
other size), compares the CRC32C of the small ones — every ``zarr.json`` and
everything under ``splits/`` — and looks for files under ``splits/`` that the
manifest does not list; ``synthcal verify`` compares every file's CRC32C and looks
for unlisted files everywhere.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import google_crc32c

from synthcal.store.errors import CorruptStore
from synthcal.utils.atomic import atomic_write, is_temporary

__all__ = ["MANIFEST_FILE", "MANIFEST_LAYOUT", "Manifest", "file_crc32c", "store_files", "write_manifest",
           "read_manifest", "check_files", "resealing"]

MANIFEST_FILE = "manifest.json"
MANIFEST_LAYOUT = "synthcal-manifest/1"
# Checked by CRC32C on every open (metadata and index arrays: small); the rest by size.
_SMALL_PREFIXES = ("splits/",)
_METADATA = "zarr.json"
# Scratch folders of a split drawer killed before it moved them into place (swept under the lock).
_SCRATCH = ".splits-tmp-"


@dataclass(frozen=True)
class Manifest:
    """A store's recorded files.

    Attributes:
        files: path inside the store (``/``-separated) → ``{"size": bytes, "crc32c": "8 hex"}``.
        state: ``sealed``, or ``writing`` while (or when) a writer changes the store.
    """

    files: dict[str, dict[str, Any]]
    state: str = "sealed"


def file_crc32c(path: Path) -> str:
    """CRC32C of a whole file, 8 hex digits."""
    checksum = google_crc32c.Checksum()
    with open(path, "rb") as file:
        while block := file.read(1 << 22):
            checksum.update(block)
    return checksum.hexdigest().decode()


def store_files(store: Path, under: str = "") -> list[str]:
    """Every file of a store (or of its folder ``under``), as sorted ``/``-separated paths.

    Leaves out the manifest and debris of killed writers (atomic writes' temporaries,
    a split drawer's scratch folders), which are not the store's content.
    """
    top = str(store)
    out = []
    for folder, dirs, names in os.walk(f"{top}/{under.strip('/')}" if under else top):
        dirs[:] = [d for d in dirs if not d.startswith(_SCRATCH)]
        base = folder[len(top) + 1:].replace(os.sep, "/")
        out += [f"{base}/{name}" if base else name for name in names if not is_temporary(name)]
    return sorted(name for name in out if name != MANIFEST_FILE)


_BLANK_SEAL = '"seal": "00000000"'


def _text(manifest: Manifest) -> str:
    """The manifest file's exact text: JSON, one file per line (a diff of two manifests reads well), sealed.

    The seal is the CRC32C of this very text with the seal's digits zeroed, so every
    byte of the file is under it (whitespace included) and no re-serialisation is
    needed to check it.
    """
    lines = ",\n".join(f"  {json.dumps(name)}: {json.dumps(entry, sort_keys=True)}"
                        for name, entry in sorted(manifest.files.items()))
    text = (f'{{\n "files": {{\n{lines}\n }},\n "layout": {json.dumps(MANIFEST_LAYOUT)},\n'
            f' {_BLANK_SEAL},\n "state": {json.dumps(manifest.state)}\n}}\n')
    return text.replace(_BLANK_SEAL, f'"seal": "{google_crc32c.value(text.encode()):08x}"')


def write_manifest(store: Path, state: str = "sealed", files: dict[str, dict[str, Any]] | None = None) -> None:
    """Write ``<store>/manifest.json`` atomically: ``files`` (default: computed now from the files on disk)."""
    if files is None:
        files = {name: {"crc32c": file_crc32c(store / name), "size": (store / name).stat().st_size}
                 for name in store_files(store)}
    with atomic_write(store / MANIFEST_FILE) as tmp:
        tmp.write_text(_text(Manifest(files, state)), encoding="utf-8")


def read_manifest(store: Path) -> Manifest:
    """The manifest of a store, after checking its seal.

    Raises:
        CorruptStore: missing, unreadable, not of this layout, or not the bytes its
            content and seal give; the message names the file.
    """
    path = store / MANIFEST_FILE
    try:
        text = path.read_bytes().decode()
        loaded = json.loads(text)
    except FileNotFoundError:
        raise CorruptStore(f"{path}: missing (a complete store of this format has one)") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CorruptStore(f"{path}: not readable JSON ({exc}): the manifest is damaged") from None
    if not isinstance(loaded, dict) or loaded.get("layout") != MANIFEST_LAYOUT:
        raise CorruptStore(f"{path}: not a {MANIFEST_LAYOUT} manifest: the manifest is damaged")
    files, state = loaded.get("files"), loaded.get("state")
    if not isinstance(files, dict) or state not in ("sealed", "writing") or not all(
            isinstance(e, dict) and isinstance(e.get("size"), int) and isinstance(e.get("crc32c"), str)
            for e in files.values()):
        raise CorruptStore(f"{path}: entries of the wrong kind: the manifest is damaged")
    seal = loaded.get("seal")
    # A file name's quotes are escaped in JSON, so this pattern is only ever the seal's own key.
    written = f'"seal": "{seal}"'
    if not isinstance(seal, str) or written not in text or \
            seal != f"{google_crc32c.value(text.replace(written, _BLANK_SEAL).encode()):08x}":
        raise CorruptStore(f"{path}: seal {seal!r} does not match its content: the manifest is damaged")
    return Manifest(files, state)


def _small(name: str) -> bool:
    return name.rsplit("/", 1)[-1] == _METADATA or name.startswith(_SMALL_PREFIXES)


def check_files(store: Path, manifest: Manifest, full: bool = False) -> list[str]:
    """What differs between a store's files and its manifest, one message per file (empty: all well).

    Args:
        store: the store.
        manifest: its manifest (:func:`read_manifest`).
        full: compare every file's CRC32C and look for unlisted files everywhere (``verify``);
            else the cheap check of the module docstring.
    """
    problems = []
    root = str(store)
    for name, expected in manifest.files.items():
        path = f"{root}/{name}"  # a plain string: pathlib's joins cost more than the stat on a large store
        try:
            size = os.stat(path).st_size
        except (FileNotFoundError, NotADirectoryError):
            problems.append(f"{path}: missing (the manifest records {expected['size']} bytes)")
            continue
        if size != expected["size"]:
            problems.append(f"{path}: {size} bytes, the manifest records {expected['size']}")
        elif (full or _small(name)) and (found := file_crc32c(Path(path))) != expected["crc32c"]:
            problems.append(f"{path}: checksum {found} differs from the manifest's {expected['crc32c']}")
    scanned = store_files(store) if full else [name for prefix in _SMALL_PREFIXES if (store / prefix).is_dir()
                                               for name in store_files(store, prefix)]
    problems += [f"{store / name}: a file the manifest does not list" for name in scanned
                 if name not in manifest.files]
    return problems


@contextmanager
def resealing(store: Path) -> Iterator[Callable[[], None]]:
    """A writer's block (the caller holds the store's lock): yields ``begin``, to call before the first write.

    ``begin`` marks the manifest ``writing``; when the block ends (however it ends)
    the manifest is recomputed from the files and sealed. A block that never calls
    ``begin`` rewrites nothing — unless an earlier writer was killed (``writing``
    found on entry), whose work this block's end seals. Stores without a manifest
    file (older formats) are left to their own record.
    """
    path = store / MANIFEST_FILE
    begun = path.is_file() and read_manifest(store).state == "writing"

    def begin() -> None:
        nonlocal begun
        if not begun and path.is_file():
            write_manifest(store, "writing", read_manifest(store).files)
            begun = True

    try:
        yield begin
    finally:
        if begun:
            write_manifest(store)
