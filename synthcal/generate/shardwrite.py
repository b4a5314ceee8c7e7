"""Fast, atomic writes of whole shards of the store's per-sample arrays.

Zarr-python encodes each inner chunk through its general asynchronous codec
pipeline, which costs about as much as rendering the sample (≈ 0.7 ms per chunk at
256 × 144). This module writes the very same bytes following the Zarr v3 sharding
specification (``sharding_indexed``; inner codecs ``bytes`` + ``blosc`` or
``zstd``; index codecs ``bytes`` + ``crc32c`` at the end of the file): the
compressed chunks in order, then the ``(offset, nbytes)`` uint64 index and its CRC32C.
Chunks equal to the fill value 0 are left out (Zarr's ``write_empty_chunks=False``),
and a shard with no chunk at all has no file. Tests check the output byte for byte
against Zarr's own encoder, and :mod:`synthcal.generate.shardread` reads it back.

Each file goes to a temporary name first and is then renamed, so a shard is whole
or absent.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import google_crc32c
import numpy as np
import zarr
from numcodecs import Blosc, Zstd
from numcodecs.abc import Codec

__all__ = ["ShardLayout", "shard_layout", "shard_file", "inner_codec", "encode_shard", "write_shard"]

_EMPTY = 2**64 - 1


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
    or ``zstd`` inner codec, as :func:`synthcal.generate.store.create_store` makes."""
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
