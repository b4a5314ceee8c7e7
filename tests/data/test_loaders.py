"""Splits as PyTorch datasets: contents, types, pickling, DataLoader workers."""

import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

from synthcal.data import SplitDataset, load_split, load_splits, read_scene
from synthcal.generate.splits import draw_splits
from synthcal.store import open_store, read_samples
from synthcal.store.splits import SplitError, read_split_indices

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def stores(smoke_stores, tmp_path_factory) -> dict[str, Path]:
    """intersection-4 (a mixed-dictionary target) and its four sources, smoke size."""
    names = [f"intersection-{k}" for k in range(1, 6)]
    paths = smoke_stores.copy(names, tmp_path_factory.mktemp("data"))
    draw_splits(paths["intersection-4"], seeds=[0, 1])
    return paths


def test_split_holds_the_store_arrays(stores):
    store = stores["intersection-4"]
    train = load_split(store, "train", 1)
    index = read_split_indices(store, "train", 1)
    direct = read_samples(open_store(store), index)
    np.testing.assert_array_equal(train.indices, index)
    np.testing.assert_array_equal(train.images, direct["image"])
    np.testing.assert_array_equal(train.semantics, direct["semantic"])
    np.testing.assert_array_equal(train.homographies, direct["homography"])
    assert train.store == store and train.split == "train" and train.seed == 1 and not train.mixed
    assert train.images.dtype == np.uint8 and train.semantics.dtype == np.uint8


def test_items_types_and_shapes(stores):
    test = load_split(stores["intersection-4"], "test", 0)
    image, semantic, homography = test[3]
    assert image.shape == (3, 36, 64) and image.dtype == torch.float32
    assert 0.0 <= float(image.min()) and float(image.max()) <= 1.0
    np.testing.assert_allclose(image.permute(1, 2, 0).numpy() * 255, test.images[3], atol=1e-3)
    assert semantic.shape == (36, 64) and semantic.dtype == torch.int64
    assert homography.shape == (3, 3) and homography.dtype == torch.float64
    assert len(test) == 8


def test_scene_comes_from_the_store(stores):
    store = stores["intersection-4"]
    scene = load_split(store, "test", 0).scene
    group = open_store(store)
    np.testing.assert_array_equal(scene.image, group["scene/image"][:])
    np.testing.assert_array_equal(scene.semantic, group["scene/semantic"][:])
    assert scene.name == "intersection-4" and scene.classes[1] == "road" and scene.palette.shape == (4, 3)


def test_mixed_dictionary_dataset(stores):
    store = stores["intersection-4"]
    splits = load_splits(store, 0, mixed=True)
    own = load_split(store, "dictionary", 0)
    mixed = splits["dictionary"]
    assert not own.mixed and mixed.mixed and len(mixed) == len(own) == 12
    assert mixed.sources == ("intersection-1", "intersection-2", "intersection-3", "intersection-5")
    assert mixed.source_stores[0] == stores["intersection-1"]
    for k, name in enumerate(mixed.sources):
        mask = mixed.source == k
        direct = read_samples(open_store(stores[name]), mixed.indices[mask])
        np.testing.assert_array_equal(mixed.homographies[mask], direct["homography"])
        np.testing.assert_array_equal(mixed.images[mask], direct["image"])
    assert mixed.scene.name == "intersection-4"  # the target's scene …
    assert mixed.source_scenes["intersection-2"].name == "intersection-2"  # … the templates' frames are theirs


def test_pickles_and_works_with_two_workers(stores):
    train = load_split(stores["intersection-4"], "train", 0)
    clone = pickle.loads(pickle.dumps(train))
    assert isinstance(clone, SplitDataset) and np.array_equal(clone.images, train.images)
    loader = DataLoader(train, batch_size=5, num_workers=2, shuffle=False)
    images = torch.cat([batch[0] for batch in loader])
    homographies = torch.cat([batch[2] for batch in loader])
    assert images.shape == (24, 3, 36, 64)
    np.testing.assert_array_equal(homographies.numpy(), train.homographies)


def test_bad_requests(stores):
    store = stores["intersection-4"]
    with pytest.raises(SplitError, match=r"intersection-4.zarr: unknown split 'val'; known: train, test, dictionary"):
        load_split(store, "val", 0)
    with pytest.raises(SplitError, match=r"splits/seed-3: no splits drawn for seed 3; seeds available: 0, 1"):
        load_split(store, "train", 3)
    with pytest.raises(SplitError, match="only the dictionary can be mixed"):
        load_split(store, "train", 0, mixed=True)
    with pytest.raises(SplitError, match=r"intersection-2.zarr: splits/seed-0: no splits drawn"):
        load_split(stores["intersection-2"], "test", 0)


def test_read_scene_missing_store(tmp_path):
    from synthcal.store import StoreError

    with pytest.raises(StoreError, match="no synthcal store here"):
        read_scene(tmp_path / "nothing.zarr")


def test_shard_reader_agrees_with_zarr(stores):
    from synthcal.store.shards import read_rows, shard_layout

    group = open_store(stores["intersection-2"])
    index = np.random.default_rng(0).integers(0, 48, 40)  # unsorted, with repeats
    for name in ("image", "semantic", "homography"):
        shard_layout(group[name])  # the store's layout: the shard reader takes it
        np.testing.assert_array_equal(read_rows(group[name], index), group[name].get_orthogonal_selection((index,)))
    assert read_rows(group["image"], np.zeros(0, np.int64)).shape == (0, 36, 64, 3)
    with pytest.raises(IndexError, match="0..47"):
        read_rows(group["image"], np.array([48]))


def test_shard_reader_fill_values_and_other_layouts(tmp_path):
    import zarr
    from zarr.codecs import BloscCodec, ZstdCodec

    from synthcal.store.shards import UnsupportedLayout, read_rows, shard_layout

    group = zarr.create_group(zarr.storage.LocalStore(tmp_path / "x.zarr"), zarr_format=3)
    sharded = group.create_array("a", shape=(20, 4, 2), chunks=(1, 4, 2), shards=(8, 4, 2), dtype="float64",
                                 compressors=ZstdCodec(level=3), fill_value=-1.0)
    sharded[:8] = np.arange(64, dtype=np.float64).reshape(8, 4, 2)
    sharded[9] = 5.0  # shard 1 holds one chunk; shard 2 was never written
    plain = group.create_array("b", shape=(20, 4, 2), chunks=(5, 4, 2), dtype="float64", fill_value=0.0)
    plain[:] = np.arange(160, dtype=np.float64).reshape(20, 4, 2)
    lz4 = group.create_array("c", shape=(20, 4, 2), chunks=(1, 4, 2), shards=(8, 4, 2), dtype="uint8",
                             compressors=BloscCodec(cname="lz4"), fill_value=7)
    lz4[:12] = np.arange(96, dtype=np.uint8).reshape(12, 4, 2)
    assert shard_layout(sharded).fill_value == -1.0 and shard_layout(lz4).fill_value == 7
    with pytest.raises(UnsupportedLayout, match=r"x.zarr/b: codecs .*sharding_indexed"):  # unsharded: Zarr reads it
        shard_layout(plain)
    index = np.array([19, 3, 9, 10, 0, 3])
    for array in (sharded, plain, lz4):
        np.testing.assert_array_equal(read_rows(array, index), array.get_orthogonal_selection((index,)))
