"""Damage is an error, never data: chunk checksums, the manifest, `synthcal verify`, older stores."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import google_crc32c
import numpy as np
import pytest
import zarr

from synthcal.cli import main
from synthcal.data import load_split
from synthcal.generate.splits import draw_splits
from synthcal.store import (
    MANIFEST_ARRAYS,
    MANIFEST_FILE,
    CorruptStore,
    LegacyStoreWarning,
    open_store,
    read_manifest,
    read_samples,
    verify_store,
)

SHARD = Path("c/0/0/0/0")  # the first shard file of image (semantic: c/0/0/0, homography: c/0/0/0)


@pytest.fixture(scope="module")
def pristine(smoke_stores, tmp_path_factory) -> Path:
    """intersection-2 with the splits of seed 0 drawn (never written to afterwards)."""
    store = smoke_stores.copy(["intersection-2"], tmp_path_factory.mktemp("pristine"))["intersection-2"]
    draw_splits(store, seeds=[0], mixed=False)
    return store


@pytest.fixture
def store(pristine, tmp_path) -> Path:
    """A copy to damage."""
    return Path(shutil.copytree(pristine, tmp_path / pristine.name))


def shard_file(store: Path, array: str, shard: int = 0) -> Path:
    ndim = open_store(store)[array].ndim
    return store / array / "c" / str(shard) / Path(*["0"] * (ndim - 1))


def chunk_span(path: Path, shard_size: int, row: int) -> tuple[int, int]:
    """(offset, nbytes) of inner chunk ``row``, read from the shard index by hand (SPEC: index at the end)."""
    data = path.read_bytes()
    index = np.frombuffer(data[-(16 * shard_size + 4):-4], "<u8").reshape(shard_size, 2)
    return int(index[row, 0]), int(index[row, 1])


def flip(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x40
    path.write_bytes(bytes(data))


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_every_array_ends_in_a_crc32c(pristine):
    group = zarr.open_group(pristine, mode="r")
    for name in [*MANIFEST_ARRAYS, "splits/seed-0/train"]:
        codecs = group[name].metadata.to_dict()["codecs"]
        inner = codecs[0]["configuration"]["codecs"] if codecs[0]["name"] == "sharding_indexed" else codecs
        assert inner[-1] == {"name": "crc32c"}, name


def test_manifest_lists_every_file_with_its_size_and_crc32c(pristine):
    recorded = read_manifest(pristine)
    on_disk = sorted(p.relative_to(pristine).as_posix() for p in pristine.rglob("*") if p.is_file())
    assert recorded.state == "sealed" and sorted(recorded.files) == [n for n in on_disk if n != MANIFEST_FILE]
    assert {"zarr.json", "image/zarr.json", "splits/zarr.json", "splits/seed-0/test/c/0"} <= set(recorded.files)
    for name, item in recorded.files.items():
        data = (pristine / name).read_bytes()
        assert item == {"size": len(data), "crc32c": f"{google_crc32c.value(data):08x}"}, name
    assert "manifest" not in open_store(pristine).attrs  # the synthcal-store/2 attribute is gone


def test_a_whole_store_verifies(pristine, capsys):
    assert verify_store(pristine).ok
    status, out, _ = run_cli(capsys, "verify", str(pristine))
    assert status == 0 and out.strip() == f"OK {pristine}"


@pytest.mark.parametrize("array", ["image", "homography"])
def test_a_flipped_byte_in_a_chunk_raises_naming_the_file(store, array, capsys):
    path = shard_file(store, array)
    offset, length = chunk_span(path, open_store(store).attrs["shard_size"], 1)
    flip(path, offset + length // 2)  # inside sample 1's encoded bytes; the file keeps its size
    group = open_store(store)  # sizes still match the manifest: opening is fine
    np.testing.assert_array_equal(read_samples(group, np.array([0]))[array].shape[0], 1)  # sample 0 intact
    with pytest.raises(CorruptStore, match=rf"{path}: chunk checksum mismatch"):
        read_samples(group, np.array([1]))
    with pytest.raises(ValueError, match="checksum"):  # zarr-python checks the crc32c codec too
        zarr.open_group(store, mode="r")[array][1]
    status, out, _ = run_cli(capsys, "verify", str(store))
    assert status == 1 and f"  {path}: chunk checksum mismatch" in out


def test_a_flipped_byte_in_a_shard_index_raises_naming_the_file(store, capsys):
    path = shard_file(store, "image")
    flip(path, path.stat().st_size - 10)
    with pytest.raises(CorruptStore, match=rf"{path}: shard index checksum mismatch"):
        read_samples(open_store(store), np.array([3]))
    with pytest.raises(ValueError, match="checksum"):
        zarr.open_group(store, mode="r")["image"][3]
    status, out, _ = run_cli(capsys, "verify", str(store))
    assert status == 1 and str(path) in out


@pytest.mark.parametrize("damage", ["deleted", "truncated"])
def test_a_lost_or_truncated_shard_is_an_error_wherever_the_store_is_opened(store, damage, capsys):
    path = shard_file(store, "homography", 2)
    if damage == "deleted":
        path.unlink()
    else:
        path.write_bytes(path.read_bytes()[:-100])
    status, out, _ = run_cli(capsys, "verify", str(store))
    assert status == 1 and out.splitlines()[0] == f"DAMAGED {store}"
    assert any(line.startswith(f"  {path}: ") for line in out.splitlines()[1:])
    with pytest.raises(CorruptStore, match=str(path)):
        load_split(store, "train", seed=0)
    status, _, err = run_cli(capsys, "info", str(store))
    assert status == 2 and err.startswith("synthcal: error: ") and str(path) in err


def test_a_truncated_shard_is_named_by_the_reader_too(store):
    """Below the manifest check (a store opened before the damage): no bare OSError."""
    group = open_store(store)
    path = shard_file(store, "image", 1)
    path.write_bytes(path.read_bytes()[:50])
    with pytest.raises(CorruptStore, match=rf"{path}: 50 bytes, shorter than its shard index"):
        read_samples(group, np.array([9]))


def test_verify_reports_each_damaged_file_and_every_store(store, pristine, capsys):
    damaged = [shard_file(store, "image", 0), shard_file(store, "semantic", 3)]
    for path in damaged:
        offset, length = chunk_span(path, 8, 2)
        flip(path, offset + 3)
    status, out, _ = run_cli(capsys, "verify", str(pristine), str(store))
    lines = out.splitlines()
    assert status == 1 and lines[0] == f"OK {pristine}" and lines[1] == f"DAMAGED {store}"
    # each file named (twice: its whole-file checksum against the manifest, then the chunk's)
    assert {line.split(": ")[0].strip() for line in lines[2:]} == set(map(str, damaged))


def test_verify_of_no_store_fails(tmp_path, capsys):
    status, out, _ = run_cli(capsys, "verify", str(tmp_path / "nothing.zarr"))
    assert status == 1 and "no synthcal store here" in out


def legacy_store(path: Path) -> dict[str, np.ndarray]:
    """A store of format synthcal-store/1 as that version wrote it: no crc32c in the chains, no manifest."""
    from zarr.codecs import BloscCodec

    rng = np.random.default_rng(3)
    arrays = {"image": rng.integers(0, 256, (10, 4, 6, 3), dtype=np.uint8),
              "semantic": rng.integers(0, 4, (10, 4, 6), dtype=np.uint8),
              "homography": rng.normal(size=(10, 3, 3))}
    group = zarr.create_group(zarr.storage.LocalStore(path), zarr_format=3,
                              attributes={"format_version": "synthcal-store/1", "complete": True})
    for name, values in arrays.items():
        compressed = name != "homography"
        group.create_array(name, shape=values.shape, chunks=(1, *values.shape[1:]), shards=(4, *values.shape[1:]),
                           dtype=values.dtype, fill_value=0,
                           compressors=BloscCodec(cname="lz4", clevel=5, shuffle="shuffle") if compressed else None)[:] \
            = values
    return arrays


def test_older_stores_still_read_with_a_note(tmp_path, capsys):
    arrays = legacy_store(tmp_path / "old.zarr")
    with pytest.warns(LegacyStoreWarning, match="has no chunk checksums"):
        group = open_store(tmp_path / "old.zarr")
    index = np.array([7, 0, 5])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LegacyStoreWarning)
        for name, values in read_samples(group, index).items():
            np.testing.assert_array_equal(values, arrays[name][index])
    status, out, _ = run_cli(capsys, "verify", str(tmp_path / "old.zarr"))
    assert status == 0 and "no chunk checksums" in out and out.splitlines()[-1] == f"OK {tmp_path / 'old.zarr'}"
