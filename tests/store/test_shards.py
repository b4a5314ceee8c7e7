"""The fast shard writer produces Zarr's own bytes."""

from pathlib import Path

import numpy as np
import pytest
import zarr
from zarr.codecs import BloscCodec, Crc32cCodec, ZstdCodec

from synthcal.store.shards import read_rows, shard_layout, write_shard


def make_array(root: Path, name: str, shape, dtype, shard_size: int, compressor=None) -> zarr.Array:
    group = zarr.open_group(zarr.storage.LocalStore(root), mode="a", zarr_format=3)
    return group.create_array(name, shape=shape, chunks=(1, *shape[1:]), shards=(shard_size, *shape[1:]),
                              dtype=dtype, compressors=compressor, fill_value=0)


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


LZ4 = BloscCodec(cname="lz4", clevel=5, shuffle="shuffle")


@pytest.mark.parametrize("compressor", [
    ZstdCodec(level=3), LZ4, None,
    # the store's chains (synthcal-store/2): each chunk followed by its CRC32C
    (ZstdCodec(level=3), Crc32cCodec()), (LZ4, Crc32cCodec()), (Crc32cCodec(),),
], ids=["zstd", "blosc-lz4", "uncompressed", "zstd+crc32c", "blosc-lz4+crc32c", "crc32c"])
def test_same_bytes_as_zarr(tmp_path, compressor):
    rng = np.random.default_rng(0)
    cases = {
        "image": rng.integers(0, 256, (11, 6, 5, 3), dtype=np.uint8),
        "semantic": rng.integers(0, 4, (11, 6, 5), dtype=np.uint8),
        "homography": rng.normal(size=(11, 3, 3)),
        "grid_index": rng.integers(0, 10**6, 11).astype(np.int64),
    }
    cases["image"][2] = 0  # an all-fill chunk is left out of its shard
    cases["semantic"][4:8] = 0  # a whole shard of fill values has no file
    for name, values in cases.items():
        ours = make_array(tmp_path / "ours", name, values.shape, values.dtype, 4, compressor)
        theirs = make_array(tmp_path / "zarr", name, values.shape, values.dtype, 4, compressor)
        theirs[:] = values
        for shard, start in enumerate(range(0, len(values), 4)):  # the last shard holds 3 samples
            write_shard(shard_layout(ours), shard, values[start:start + 4])
        np.testing.assert_array_equal(ours[:], values)
        index = np.array([9, 0, 4, 10, 3])
        np.testing.assert_array_equal(read_rows(ours, index), values[index])  # the fast reader agrees
    assert files(tmp_path / "ours") == files(tmp_path / "zarr")
    assert not (tmp_path / "ours" / "semantic" / "c" / "1").exists()


def test_rewrite_replaces_the_file_whole(tmp_path):
    values = np.arange(8 * 4, dtype=np.uint8).reshape(8, 4) + 1
    array = make_array(tmp_path, "a", values.shape, values.dtype, 4, ZstdCodec(level=3))
    write_shard(shard_layout(array), 1, values[4:])
    write_shard(shard_layout(array), 1, values[4:] * 2)
    np.testing.assert_array_equal(array[4:], values[4:] * 2)
    assert [p.name for p in (tmp_path / "a" / "c" / "1").iterdir()] == ["0"]  # no temporary left behind


def test_fill_value_chunks_are_left_out_as_zarr_does(tmp_path):
    values = np.full((6, 4, 2), 7, dtype=np.uint8)
    values[1] = np.arange(8, dtype=np.uint8).reshape(4, 2)  # the only chunk unlike the fill value 7
    group = {}
    for name in ("ours", "zarr"):
        root = zarr.open_group(zarr.storage.LocalStore(tmp_path / name), mode="a", zarr_format=3)
        group[name] = root.create_array("a", shape=values.shape, chunks=(1, 4, 2), shards=(3, 4, 2), dtype="uint8",
                                        compressors=BloscCodec(cname="lz4"), fill_value=7)
    group["zarr"][:] = values
    for shard in range(2):
        write_shard(shard_layout(group["ours"]), shard, values[3 * shard:3 * shard + 3])
    assert files(tmp_path / "ours") == files(tmp_path / "zarr")
    assert not (tmp_path / "ours" / "a" / "c" / "1").exists()


def test_unsupported_layouts_are_refused_naming_array_and_codec(tmp_path):
    from zarr.codecs import GzipCodec

    from synthcal.store.shards import UnsupportedLayout

    gzip = make_array(tmp_path, "gz", (4, 3), "uint8", 2, GzipCodec())
    with pytest.raises(UnsupportedLayout, match=r"gz: inner codecs \['bytes', 'gzip'\]"):
        shard_layout(gzip)
    before_checksum = make_array(tmp_path, "crc-first", (4, 3), "uint8", 2, (Crc32cCodec(), GzipCodec()))
    with pytest.raises(UnsupportedLayout, match=r"crc-first: inner codecs \['bytes', 'crc32c', 'gzip'\]"):
        shard_layout(before_checksum)
    layout = shard_layout(make_array(tmp_path, "ok", (4, 3), "uint8", 2))
    with pytest.raises(ValueError, match=r"ok: shard 0: samples \(2, 4\) uint8 do not fit"):
        write_shard(layout, 0, np.ones((2, 4), np.uint8))
