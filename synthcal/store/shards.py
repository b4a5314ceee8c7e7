"""Whole shards of the store's per-sample arrays, written and read without Zarr's per-chunk pipeline.

Writing
-------
Fast, atomic writes of whole shards of the store's per-sample arrays.

Zarr-python encodes each inner chunk through its general asynchronous codec
pipeline, which costs about as much as rendering the sample (≈ 0.7 ms per chunk at
256 × 144). This module writes the very same bytes following the Zarr v3 sharding
specification (``sharding_indexed``; inner codecs ``bytes`` + ``blosc`` or
``zstd``; index codecs ``bytes`` + ``crc32c`` at the end of the file): the
compressed chunks in order, then the ``(offset, nbytes)`` uint64 index and its CRC32C.
Chunks equal to the fill value 0 are left out (Zarr's ``write_empty_chunks=False``),
and a shard with no chunk at all has no file. Tests check the output byte for byte
against Zarr's own encoder, and :mod:`synthcal.store.shards` reads it back.

Each file goes to a temporary name first and is then renamed, so a shard is whole
or absent.

Reading
-------
Fast reads of whole samples from a store's sharded arrays.

Zarr-python decodes each inner chunk through its general asynchronous codec
pipeline, which costs about a millisecond per chunk: a 4,500-sample split (one
chunk per sample and array) took ~20 s through ``get_orthogonal_selection``. This
module reads the same bytes following the Zarr v3 sharding specification
(``sharding_indexed`` codec, index at the end of each shard file): per shard, one
``pread`` of the index (checked with its CRC32C), one ``pread`` of the wanted
chunks' span (or one per chunk when the selection is sparse), decoding straight
into the output, shards spread over a thread pool (the decoders release the GIL).

Only the layout that :mod:`synthcal.store` writes is taken this way —
local files, regular grid, default ``/`` chunk keys, one sample per inner chunk,
inner codecs ``bytes`` + ``blosc``, ``zstd`` or nothing, index codecs ``bytes`` + ``crc32c`` at the end.
Anything else falls back to Zarr's own orthogonal selection, so results never
depend on the path taken (the tests compare both).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import google_crc32c
import numpy as np
import zarr
from numcodecs import Blosc, Zstd
from numcodecs.abc import Codec

__all__ = ["ShardLayout", "shard_layout", "shard_file", "inner_codec", "encode_shard", "write_shard",
           "read_rows", "fast_path"]

_EMPTY = 2**64 - 1  # offset and length of a chunk absent from its shard


def shard_file(array_dir: Path, shard: int, ndim: int) -> Path:
    """Path of shard ``shard`` of an array split along its first axis only."""
    return Path(array_dir, "c", str(shard), *(["0"] * (ndim - 1)))


_SHUFFLE = {"noshuffle": Blosc.NOSHUFFLE, "shuffle": Blosc.SHUFFLE, "bitshuffle": Blosc.BITSHUFFLE}


def inner_codec(config: dict | None) -> Codec | None:
    """The numcodecs compressor of a Zarr v3 ``zstd`` or ``blosc`` codec entry (None: none)."""
    if config is None:
        return None
    name, options = config["name"], config.get("configuration", {})
    if name == "zstd":
        return Zstd(level=options["level"], checksum=options.get("checksum", False))
    if name == "blosc":
        return Blosc(cname=options["cname"], clevel=options["clevel"], shuffle=_SHUFFLE[options["shuffle"]],
                     blocksize=options.get("blocksize", 0), typesize=options["typesize"])
    raise ValueError(f"no fast shard writer for the {name!r} codec")


def encode_shard(samples: np.ndarray, shard_size: int, codec: Codec | None) -> bytes | None:
    """The bytes of one shard file.

    Args:
        samples: (k, ...) the shard's samples, k ≤ ``shard_size`` (the last shard
            of an array may hold fewer).
        shard_size: inner chunks per shard.
        codec: the array's inner compressor (:func:`inner_codec`; None: raw bytes).

    Returns:
        the file's bytes, or None when every sample is all zeros (no file).
    """
    index = np.full((shard_size, 2), _EMPTY, dtype="<u8")
    frames, offset = [], 0
    for k, sample in enumerate(samples):
        if not sample.any():
            continue
        raw = np.ascontiguousarray(sample, dtype=sample.dtype.newbyteorder("<"))  # the bytes codec: little endian
        frame = raw.tobytes() if codec is None else codec.encode(raw)
        index[k] = (offset, len(frame))
        frames.append(frame)
        offset += len(frame)
    if not frames:
        return None
    index_bytes = index.tobytes()
    checksum = np.uint32(google_crc32c.value(index_bytes)).astype("<u4").tobytes()
    return b"".join([*frames, index_bytes, checksum])


@dataclass(frozen=True)
class ShardLayout:
    """Where and how one array's shards are written (small and picklable).

    Attributes:
        directory: the array's folder in a local store.
        shard_size: samples per shard.
        ndim: the array's number of dimensions.
        codec: the inner compressor (:func:`inner_codec`).
    """

    directory: Path
    shard_size: int
    ndim: int
    codec: Codec | None


def shard_layout(array: zarr.Array) -> ShardLayout:
    """The layout of a local, sharded array with one sample per chunk and a ``blosc``
    or ``zstd`` inner codec, as :func:`synthcal.store.create_store` makes."""
    meta = array.metadata.to_dict()
    _, *compressor = meta["codecs"][0]["configuration"]["codecs"]  # "bytes", then the compressor if any
    return ShardLayout(
        directory=Path(array.store_path.store.root) / array.store_path.path,
        shard_size=meta["chunk_grid"]["configuration"]["chunk_shape"][0],
        ndim=array.ndim,
        codec=inner_codec(compressor[0] if compressor else None),
    )


def write_shard(layout: ShardLayout, shard: int, samples: np.ndarray) -> None:
    """Write samples ``shard · S : shard · S + len(samples)`` of an array as one file."""
    path = shard_file(layout.directory, shard, layout.ndim)
    data = encode_shard(samples, layout.shard_size, layout.codec)
    if data is None:
        path.unlink(missing_ok=True)
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
    tmp.write_bytes(data)
    os.replace(tmp, path)


# --- reading --------------------------------------------------------------------------------
# Compressors whose frames describe themselves, so the decoder needs no settings.
_DECODERS = {"zstd": Zstd, "blosc": Blosc}
_RAW = "raw"  # no compressor: the chunk's bytes as they are (the small per-sample arrays)


def fast_path(array: zarr.Array) -> tuple[Path, int, str, str] | None:
    """``(array directory, samples per shard, dtype with byte order, compressor)``
    when the array has the store's layout, else None (use Zarr)."""
    meta = array.metadata.to_dict()
    store = array.store_path.store
    if not isinstance(store, zarr.storage.LocalStore) or meta.get("zarr_format") != 3:
        return None
    encoding = meta["chunk_key_encoding"]
    if encoding.get("name") != "default" or encoding.get("configuration", {}).get("separator", "/") != "/":
        return None
    if meta["chunk_grid"]["name"] != "regular" or len(meta["codecs"]) != 1:
        return None
    sharding = meta["codecs"][0]
    if sharding["name"] != "sharding_indexed":
        return None
    config = sharding["configuration"]
    shard_shape = meta["chunk_grid"]["configuration"]["chunk_shape"]
    inner = config["chunk_shape"]
    if inner[0] != 1 or list(inner[1:]) != list(array.shape[1:]) or list(shard_shape[1:]) != list(array.shape[1:]):
        return None
    codecs = [c["name"] for c in config["codecs"]]
    index_codecs = [c["name"] for c in config["index_codecs"]]
    if codecs == ["bytes"]:
        codecs.append(_RAW)
    if len(codecs) != 2 or codecs[0] != "bytes" or codecs[1] not in (*_DECODERS, _RAW):
        return None
    if index_codecs != ["bytes", "crc32c"] or config["index_location"] != "end":
        return None
    endian = config["codecs"][0].get("configuration", {}).get("endian", "little")
    index_endian = config["index_codecs"][0].get("configuration", {}).get("endian", "little")
    if index_endian != "little":
        return None
    dtype = np.dtype(array.dtype).newbyteorder("<" if endian == "little" else ">")
    return Path(store.root) / array.store_path.path, int(shard_shape[0]), dtype.str, codecs[1]


def _read_shard(
    path: Path, per_shard: int, rows: np.ndarray, positions: np.ndarray, out: np.ndarray, dtype: str,
    compressor: str, fill: object,
) -> None:
    """Decode rows ``rows`` (ascending, within this shard) into ``out[positions]``."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:  # a shard never written holds only fill values
        out[positions] = fill
        return
    try:
        size = os.fstat(fd).st_size
        index_bytes = os.pread(fd, 16 * per_shard + 4, size - 16 * per_shard - 4)
        if google_crc32c.value(index_bytes[:-4]) != int.from_bytes(index_bytes[-4:], "little"):
            raise OSError(f"{path}: shard index checksum mismatch (corrupt shard)")
        index = np.frombuffer(index_bytes[:-4], "<u8").reshape(per_shard, 2)[rows]
        present = index[:, 0] != _EMPTY
        out[positions[~present]] = fill
        rows, positions, index = rows[present], positions[present], index[present]
        if not len(rows):
            return
        # One read for the whole span when it is mostly wanted bytes (few syscalls for
        # small chunks), one read per chunk for a sparse selection.
        start, stop = int(index[:, 0].min()), int((index[:, 0] + index[:, 1]).max())
        span = memoryview(os.pread(fd, stop - start, start)) if stop - start <= 4 * int(index[:, 1].sum()) else None
        if compressor == _RAW:
            _gather_raw(span if span is not None else memoryview(os.pread(fd, stop - start, start)),
                        index, start, positions, out, dtype)
            return
        codec = _DECODERS[compressor]()
        native = np.dtype(dtype).isnative
        for position, (offset, length) in zip(positions, index.tolist()):
            raw = span[offset - start: offset - start + length] if span is not None else os.pread(fd, length, offset)
            if native:  # decode straight into the output row
                codec.decode(raw, out=out[position:position + 1].reshape(-1).view(np.uint8))  # a slice: a view even for 1-D arrays
            else:
                out[position] = np.frombuffer(codec.decode(raw), dtype).reshape(out.shape[1:])
    finally:
        os.close(fd)


def _gather_raw(span: memoryview, index: np.ndarray, start: int, positions: np.ndarray, out: np.ndarray,
                dtype: str) -> None:
    """Uncompressed chunks: one vectorised gather instead of a decode call per chunk."""
    length = int(index[0, 1])
    rows = np.frombuffer(span, np.uint8)[(index[:, 0].astype(np.int64) - start)[:, None] + np.arange(length)]
    out[positions] = rows.view(dtype).reshape(len(index), *out.shape[1:])


def read_rows(array: zarr.Array, index: np.ndarray, threads: int | None = None) -> np.ndarray:
    """``array[index]`` along the first axis, any order, repeats allowed.

    Args:
        array: a store array of shape (N, ...).
        index: (K,) int indices in ``0..N-1``.
        threads: decoding threads (default: the CPU count).

    Returns:
        (K, ...) array of ``array``'s dtype, in ``index``'s order.

    Raises:
        IndexError: an index outside ``0..N-1``.
    """
    index = np.asarray(index, dtype=np.int64)
    if len(index) and (index.min() < 0 or index.max() >= array.shape[0]):
        raise IndexError(f"{array.path}: indices must lie in 0..{array.shape[0] - 1}")
    layout = fast_path(array)
    if layout is None:
        order = np.argsort(index, kind="stable")
        out = np.empty((len(index), *array.shape[1:]), array.dtype)
        out[order] = array.get_orthogonal_selection((index[order],))
        return out
    folder, per_shard, dtype, compressor = layout
    out = np.empty((len(index), *array.shape[1:]), array.dtype)
    shards = index // per_shard
    order = np.argsort(index, kind="stable")  # sorted: each shard's chunks read front to back
    bounds = np.flatnonzero(np.diff(shards[order])) + 1
    zeros = "/".join("0" for _ in array.shape[1:])
    jobs = []
    for group in np.split(order, bounds) if len(order) else []:
        shard = int(shards[group[0]])
        path = folder / "c" / f"{shard}/{zeros}" if zeros else folder / "c" / str(shard)
        jobs.append((path, per_shard, index[group] - shard * per_shard, group, out, dtype, compressor,
                     array.fill_value))
    workers = max(1, min(threads or os.cpu_count() or 1, len(jobs)))
    if workers == 1:
        for job in jobs:
            _read_shard(*job)
    else:
        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(lambda job: _read_shard(*job), jobs))
    return out
