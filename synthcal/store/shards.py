"""Whole shards of the store's per-sample arrays, written and read without Zarr-python's per-chunk pipeline.

Zarr-python passes every inner chunk through its general asynchronous codec
pipeline, a fixed cost per chunk that dominates at one sample per chunk.
``benchmarks/zarr_baseline.py`` times both paths on the same arrays (256 × 144,
64 samples per shard, Blosc-LZ4; figures in ``benchmarks/README.md``): writing
whole shards of ``image`` and ``semantic``, zarr-python took 2–8× this module's
time (≈ 1.4 ms per sample against 0.2–0.8 ms on the shared 2-core machine under
load), and reading 500 sorted samples of ``image``, ``semantic`` and
``homography`` 50–130× (5–11 ms against ≈ 0.1 ms per sample).

Layout
------
Both directions work from one :class:`ShardLayout`, read and validated from the
array's Zarr v3 metadata by :func:`shard_layout`. Only the layout that
:mod:`synthcal.store.format` creates is accepted: a local store, regular chunk
grid, default ``/`` chunk keys, a single ``sharding_indexed`` codec with one
sample per inner chunk and shards split along the first axis only, inner codecs
``bytes``, then ``blosc``, ``zstd`` or nothing, then ``crc32c`` or nothing (stores
of format ``synthcal-store/1`` have no chunk checksum), index codecs ``bytes``
(little endian) + ``crc32c`` at the end of the file, a numeric dtype and a fill value
that is not NaN. Anything else raises :class:`UnsupportedLayout`: the writer
passes the error on, the reader falls back to Zarr's own orthogonal selection, so
results never depend on the path taken (the tests compare both).

Writing
-------
A shard file is, per the Zarr v3 sharding specification, the compressed chunks in
order (each followed by its CRC32C when the chain ends in ``crc32c``), then the
``(offset, nbytes)`` uint64 index and its CRC32C. Chunks equal to
the fill value are left out (Zarr's ``write_empty_chunks=False``), and a shard with
no chunk at all has no file. Tests check the output byte for byte against Zarr's
own encoder. Each file goes to a temporary name first and is then renamed
(:func:`synthcal.utils.atomic.atomic_write`), so a shard is whole or absent.

Reading
-------
Per shard, one ``pread`` of the index (checked with its CRC32C), one ``pread`` of
the wanted chunks' span (or one per chunk when the selection is sparse), each
chunk's CRC32C checked before it is decoded straight into the output; shards are
spread over a thread pool (the decoders release the GIL). A checksum that does not
match, an index pointing outside its file or a file shorter than its index raises
:class:`~synthcal.store.errors.CorruptStore` naming the file: damage is never
returned as data. A missing shard file reads as fill values, as in Zarr; a
complete store's manifest (:mod:`synthcal.store.format`) tells a shard that was
never written from one that was lost.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import google_crc32c
import numpy as np
from numcodecs import Blosc, Zstd
from numcodecs.abc import Codec

from synthcal.store.errors import CorruptStore
from synthcal.utils.atomic import atomic_write

if TYPE_CHECKING:  # writing needs no zarr: generate's workers import this module without it
    import zarr

__all__ = ["ShardLayout", "UnsupportedLayout", "shard_layout", "encode_shard", "write_shard", "write_samples",
           "read_rows", "read_threads"]

_EMPTY = 2**64 - 1  # offset and length of a chunk absent from its shard
_SHUFFLE = {"noshuffle": Blosc.NOSHUFFLE, "shuffle": Blosc.SHUFFLE, "bitshuffle": Blosc.BITSHUFFLE}


class UnsupportedLayout(ValueError):
    """An array whose layout this module does not handle; the message names the array and why."""


@dataclass(frozen=True)
class ShardLayout:
    """How one array's shards lie on disk (small and picklable: shipped to generation workers).

    Attributes:
        directory: the array's folder in a local store; shard ``s`` is ``c/<s>/0/…/0`` in it.
        shard_size: samples (inner chunks) per shard.
        sample_shape: the shape of one sample, the array's shape without its first axis.
        dtype: the stored bytes' dtype, byte order included (the ``bytes`` codec's endian).
        codec: the inner compressor, None for raw bytes.
        fill_value: the value of samples never written.
        checksum: each chunk ends in its CRC32C (the ``crc32c`` codec ends the inner chain).
    """

    directory: Path
    shard_size: int
    sample_shape: tuple[int, ...]
    dtype: np.dtype[Any]
    codec: Codec | None
    fill_value: int | float | complex
    checksum: bool = True

    @property
    def ndim(self) -> int:
        """The array's number of dimensions."""
        return 1 + len(self.sample_shape)

    def path(self, shard: int) -> Path:
        """The file of shard ``shard`` (the array is split along its first axis only)."""
        return Path(self.directory, "c", str(shard), *(["0"] * len(self.sample_shape)))


def _inner_codec(name: str, entry: dict[str, Any], where: str) -> Codec:
    """The numcodecs compressor of a Zarr v3 ``zstd`` or ``blosc`` codec entry."""
    options = entry.get("configuration", {})
    try:
        if name == "zstd":
            return Zstd(level=options["level"], checksum=options.get("checksum", False))
        return Blosc(cname=options["cname"], clevel=options["clevel"], shuffle=_SHUFFLE[options["shuffle"]],
                     blocksize=options.get("blocksize", 0), typesize=options["typesize"])
    except KeyError as exc:
        raise UnsupportedLayout(f"{where}: {name!r} codec configuration {options} lacks or misnames {exc}") from None


def _check_grid(meta: dict[str, Any], shape: tuple[int, ...], where: str) -> int:
    """Samples per shard, after checking one sample per chunk and shards along the first axis only."""
    encoding = meta["chunk_key_encoding"]
    if encoding.get("name") != "default" or encoding.get("configuration", {}).get("separator", "/") != "/":
        raise UnsupportedLayout(f"{where}: chunk key encoding {encoding} (supported: default with '/')")
    if meta["chunk_grid"]["name"] != "regular" or meta.get("storage_transformers"):
        raise UnsupportedLayout(f"{where}: chunk grid {meta['chunk_grid']['name']!r} or storage transformers "
                                f"{meta.get('storage_transformers')} (supported: regular, none)")
    codecs = meta["codecs"]
    if len(codecs) != 1 or codecs[0]["name"] != "sharding_indexed":
        raise UnsupportedLayout(f"{where}: codecs {[c['name'] for c in codecs]} (supported: sharding_indexed alone)")
    shard_shape = tuple(meta["chunk_grid"]["configuration"]["chunk_shape"])
    inner = tuple(codecs[0]["configuration"]["chunk_shape"])
    if not shape or inner != (1, *shape[1:]) or shard_shape[1:] != shape[1:]:
        raise UnsupportedLayout(f"{where}: shards {shard_shape} of chunks {inner} for shape {shape} "
                                f"(supported: chunks (1, {', '.join(map(str, shape[1:]))}), shards along axis 0)")
    return int(shard_shape[0])


def _check_codecs(config: dict[str, Any], where: str) -> tuple[str, Codec | None, bool]:
    """The ``bytes`` codec's endian, the inner compressor and whether chunks carry a CRC32C,
    after checking the index codecs."""
    inner, index = config["codecs"], config["index_codecs"]
    names = [c["name"] for c in inner]
    checksum = names[-1:] == ["crc32c"]
    if checksum:
        inner, names = inner[:-1], names[:-1]
    if names[:1] != ["bytes"] or len(names) > 2 or names[1:] not in ([], ["blosc"], ["zstd"]):
        shown = names + ["crc32c"] * checksum
        raise UnsupportedLayout(f"{where}: inner codecs {shown} (supported: bytes, then blosc, zstd or nothing, "
                                f"then crc32c or nothing)")
    index_names = [c["name"] for c in index]
    index_endian = index[0].get("configuration", {}).get("endian", "little") if index else None
    if index_names != ["bytes", "crc32c"] or index_endian != "little" or config["index_location"] != "end":
        raise UnsupportedLayout(f"{where}: shard index codecs {index_names} ({index_endian} endian) at the "
                                f"{config['index_location']} (supported: little-endian bytes + crc32c at the end)")
    endian = inner[0].get("configuration", {}).get("endian", "little")
    return endian, (_inner_codec(names[1], inner[1], where) if len(names) == 2 else None), checksum


def shard_layout(array: zarr.Array) -> ShardLayout:
    """The validated layout of a store array (module docstring, *Layout*).

    Raises:
        UnsupportedLayout: anything but the layout :func:`synthcal.store.create_store`
            makes; the message names the array and what differs (e.g. the codec).
    """
    from zarr.storage import LocalStore

    where = str(array.store_path)
    meta: dict[str, Any] = array.metadata.to_dict()  # JSON: checked key by key below
    store = array.store_path.store
    if not isinstance(store, LocalStore) or meta.get("zarr_format") != 3:
        raise UnsupportedLayout(f"{where}: {type(store).__name__}, zarr_format {meta.get('zarr_format')} "
                                f"(supported: a local Zarr v3 store)")
    shape = tuple(int(n) for n in array.shape)
    shard_size = _check_grid(meta, shape, where)
    endian, codec, checksum = _check_codecs(meta["codecs"][0]["configuration"], where)
    dtype = np.dtype(array.dtype)
    if dtype.kind not in "biufc":
        raise UnsupportedLayout(f"{where}: data type {meta['data_type']!r} (supported: booleans and numbers)")
    fill = array.fill_value.item() if isinstance(array.fill_value, np.generic) else array.fill_value
    if not isinstance(fill, int | float | complex) or (isinstance(fill, float | complex) and math.isnan(abs(fill))):
        raise UnsupportedLayout(f"{where}: fill value {fill!r} (supported: a number, not NaN)")
    return ShardLayout(
        directory=Path(store.root) / array.store_path.path,
        shard_size=shard_size,
        sample_shape=shape[1:],
        dtype=dtype.newbyteorder("<" if endian == "little" else ">"),
        codec=codec,
        fill_value=fill,
        checksum=checksum,
    )


# --- writing ---------------------------------------------------------------------------------


def encode_shard(layout: ShardLayout, samples: np.ndarray) -> bytes | None:
    """The bytes of one shard file.

    Args:
        layout: the array's layout.
        samples: (k, *sample_shape) the shard's samples, k ≤ ``shard_size`` (the last
            shard of an array may hold fewer).

    Returns:
        the file's bytes, or None when every sample equals the fill value (no file).
    """
    fill, codec = layout.fill_value, layout.codec
    rows = np.ascontiguousarray(samples, dtype=layout.dtype)  # the bytes codec's byte order
    flat = rows.reshape(len(rows), -1)
    # Which samples differ from the fill value, and the index, for the whole shard at
    # once: per-sample NumPy calls cost more than encoding the small per-sample arrays.
    present = np.flatnonzero(flat.any(axis=1) if fill == 0 else ~np.all(flat == fill, axis=1))
    frames, sizes = [], []
    for k in present.tolist():
        raw = np.ascontiguousarray(rows[k])  # an array even where a sample is a scalar (codecs take arrays)
        frame = raw.tobytes() if codec is None else codec.encode(raw)
        frames.append(frame)
        if layout.checksum:  # Zarr's crc32c codec: the CRC32C of the encoded chunk, 4 bytes little endian
            frames.append(_crc_bytes(frame))
        sizes.append(len(frame) + 4 * layout.checksum)
    if not frames:
        return None
    lengths = np.asarray(sizes, dtype="<u8")
    index = np.full((layout.shard_size, 2), _EMPTY, dtype="<u8")
    index[present, 0] = np.cumsum(lengths) - lengths
    index[present, 1] = lengths
    index_bytes = index.tobytes()
    return b"".join([*frames, index_bytes, _crc_bytes(index_bytes)])


def _crc_bytes(data: bytes) -> bytes:
    """CRC32C of ``data`` as 4 little-endian bytes."""
    return int(google_crc32c.value(data)).to_bytes(4, "little")


def write_shard(layout: ShardLayout, shard: int, samples: np.ndarray) -> None:
    """Write samples ``shard · S : shard · S + len(samples)`` of an array as one file, atomically.

    Raises:
        ValueError: samples of another shape or kind than the array's, or more than a shard.
    """
    if (samples.shape[1:] != layout.sample_shape or len(samples) > layout.shard_size
            or not np.can_cast(samples.dtype, layout.dtype, "equiv")):
        raise ValueError(f"{layout.directory}: shard {shard}: samples {samples.shape} {samples.dtype} do not fit "
                         f"shards of {layout.shard_size} × {layout.sample_shape} {layout.dtype}")
    path = layout.path(shard)
    data = encode_shard(layout, samples)
    if data is None:
        path.unlink(missing_ok=True)
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        tmp.write_bytes(data)


def write_samples(layouts: dict[str, ShardLayout], shard: int, image: np.ndarray, semantic: np.ndarray) -> None:
    """Write one shard's rendered samples, each array's shard file atomically."""
    write_shard(layouts["image"], shard, image)
    write_shard(layouts["semantic"], shard, semantic)


# --- reading ---------------------------------------------------------------------------------


def _read_shard(layout: ShardLayout, shard: int, rows: np.ndarray, positions: np.ndarray, out: np.ndarray) -> None:
    """Decode rows ``rows`` (ascending, within shard ``shard``) into ``out[positions]``.

    Raises:
        CorruptStore: a checksum that does not match or an index that does not fit the file.
    """
    path = layout.path(shard)
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:  # a shard never written holds only fill values
        out[positions] = layout.fill_value
        return
    try:
        index_size = 16 * layout.shard_size + 4
        file_size = os.fstat(fd).st_size
        if file_size < index_size:
            raise CorruptStore(f"{path}: {file_size} bytes, shorter than its shard index ({index_size} bytes): "
                               f"a truncated shard")
        index_bytes = os.pread(fd, index_size, file_size - index_size)
        if google_crc32c.value(index_bytes[:-4]) != int.from_bytes(index_bytes[-4:], "little"):
            raise CorruptStore(f"{path}: shard index checksum mismatch (the file is damaged)")
        index = np.frombuffer(index_bytes[:-4], "<u8").reshape(layout.shard_size, 2)[rows]
        present = index[:, 0] != _EMPTY
        out[positions[~present]] = layout.fill_value
        positions, index = positions[present], index[present]
        if not len(positions):
            return
        # One read for the whole span when it is mostly wanted bytes (few syscalls for
        # small chunks), one read per chunk for a sparse selection.
        start, stop = int(index[:, 0].min()), int((index[:, 0] + index[:, 1]).max())
        if stop > file_size - index_size:
            raise CorruptStore(f"{path}: the shard index points past the chunks (byte {stop} of "
                               f"{file_size - index_size}): the file is damaged")
        dense = stop - start <= 4 * int(index[:, 1].sum())
        # numpy views of the bytes read: google_crc32c and the decoders take them without a copy
        span = np.frombuffer(os.pread(fd, stop - start, start), np.uint8) if dense else None
        if layout.codec is None:
            if span is None:
                span = np.frombuffer(os.pread(fd, stop - start, start), np.uint8)
            _gather_raw(span, index, start, positions, out, layout, path)
            return
        _decode_chunks(fd, span, start, index, positions, out, layout, path)
    finally:
        os.close(fd)


def _chunk_error(path: Path, position: int, offset: int) -> CorruptStore:
    return CorruptStore(f"{path}: chunk checksum mismatch at byte {offset} (output row {position}): "
                        f"the file is damaged")


def _decode_chunks(fd: int, span: np.ndarray | None, start: int, index: np.ndarray, positions: np.ndarray,
                   out: np.ndarray, layout: ShardLayout, path: Path) -> None:
    """Compressed chunks: check each one's CRC32C, then decode it into its output row."""
    codec, native, tail = layout.codec, layout.dtype.isnative, 4 * layout.checksum
    assert codec is not None
    for position, (offset, length) in zip(positions, index.tolist(), strict=True):
        raw = span[offset - start: offset - start + length] if span is not None else \
            np.frombuffer(os.pread(fd, length, offset), np.uint8)
        if tail:
            if google_crc32c.value(raw[:-4]) != int.from_bytes(raw[-4:].tobytes(), "little"):
                raise _chunk_error(path, int(position), offset)
            raw = raw[:-4]
        if native:  # decode straight into the output row (a slice: a view even for 1-D arrays)
            codec.decode(raw, out=out[position:position + 1].reshape(-1).view(np.uint8))
        else:
            out[position] = np.frombuffer(codec.decode(raw), layout.dtype).reshape(out.shape[1:])


def _gather_raw(span: np.ndarray, index: np.ndarray, start: int, positions: np.ndarray, out: np.ndarray,
                layout: ShardLayout, path: Path) -> None:
    """Uncompressed chunks: one vectorised gather instead of a decode call per chunk."""
    length = int(index[0, 1])
    if np.any(index[:, 1] != length):
        raise CorruptStore(f"{path}: uncompressed chunks of different lengths in the shard index: the file is damaged")
    rows = span[(index[:, 0].astype(np.int64) - start)[:, None] + np.arange(length)]
    if layout.checksum:
        stored = rows[:, -4:].copy().view("<u4")[:, 0]
        for k, row in enumerate(rows):  # ≤ 76 bytes a row: the call, not the CRC, is the cost
            if google_crc32c.value(row[:-4]) != stored[k]:
                raise _chunk_error(path, int(positions[k]), int(index[k, 0]))
        rows = rows[:, :-4]
    out[positions] = np.ascontiguousarray(rows).view(layout.dtype).reshape(len(index), *out.shape[1:])


def read_threads() -> int:
    """:func:`read_rows`' default thread count: the CPUs this process may run on.

    Not ``os.cpu_count()``, the machine's count: a container, ``taskset`` or a batch
    scheduler may allow fewer, and more decoding threads than usable cores only add
    switching (``benchmarks/load.py`` times 1 against 2 threads).
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no affinity call (macOS, Windows)
        return os.cpu_count() or 1


def read_rows(array: zarr.Array, index: np.ndarray, threads: int | None = None) -> np.ndarray:
    """``array[index]`` along the first axis, any order, repeats allowed.

    Args:
        array: a store array of shape (N, ...).
        index: (K,) int indices in ``0..N-1``.
        threads: decoding threads (default: :func:`read_threads`; one for an uncompressed array).

    Returns:
        (K, ...) array of ``array``'s dtype, in ``index``'s order.

    Raises:
        IndexError: an index outside ``0..N-1``.
    """
    index = np.asarray(index, dtype=np.int64)
    if len(index) and (index.min() < 0 or index.max() >= array.shape[0]):
        raise IndexError(f"{array.path}: indices must lie in 0..{array.shape[0] - 1}")
    out = np.empty((len(index), *array.shape[1:]), np.dtype(array.dtype))
    order = np.argsort(index, kind="stable")  # sorted: each shard's chunks read front to back
    try:
        layout = shard_layout(array)
    except UnsupportedLayout:  # not the store's layout: Zarr reads it
        out[order] = array.get_orthogonal_selection((index[order],))
        return out
    shards = index // layout.shard_size
    bounds = np.flatnonzero(np.diff(shards[order])) + 1
    groups = np.split(order, bounds) if len(order) else []

    def read(positions: np.ndarray) -> None:  # one shard's share of the selection
        shard = int(shards[positions[0]])
        _read_shard(layout, shard, index[positions] - shard * layout.shard_size, positions, out)

    # Uncompressed rows are a Python loop of per-row CRC calls holding the GIL: a second thread only adds
    # switching (homography of a 4,500-sample split: 4.4 ms on one thread, 5.8–14 ms on two).
    workers = 1 if layout.codec is None else max(1, min(threads or read_threads(), len(groups)))
    if workers == 1:
        for positions in groups:
            read(positions)
    else:
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(read, groups))
    return out
