"""The pool dictionary: which samples, lazy reads, and searches equal to brute force."""

import pickle
from pathlib import Path

import numpy as np
import pytest
import torch

from synthcal.data import LazyRows, load_pool_dictionary, load_split
from synthcal.estimators import TemplateEstimator
from synthcal.estimators.paper import PaperEstimator
from synthcal.generate.splits import draw_splits
from synthcal.models import one_hot_maps
from synthcal.store import attributes, open_store, read_samples
from synthcal.store.splits import SplitError, read_split_indices

SMOKE_TRAINING = {"batch_size": 8, "siamese_width": 4, "embedding_dim": 8, "siamese_epochs": 1, "stn_width": 4,
                  "stn_epochs": 1, "unet_width": 4, "unet_depth": 2, "unet_epochs": 1, "work_size": [32, 18]}


@pytest.fixture(scope="module")
def store(smoke_stores, tmp_path_factory) -> Path:
    """intersection-2 at smoke size (48 samples), seeds 0 and 1 drawn (24 train, 8 test, 4 validation each)."""
    path = smoke_stores.copy(["intersection-2"], tmp_path_factory.mktemp("pool"))["intersection-2"]
    draw_splits(path, seeds=[0, 1])
    return path


def test_the_pool_dictionary_is_every_sample_outside_train_test_and_validation(store):
    size = int(attributes(open_store(store))["N"])
    for seed in (0, 1):
        pool = load_pool_dictionary(store, seed)
        held = [read_split_indices(store, split, seed) for split in ("train", "test", "validation")]
        expected = sorted(set(range(size)) - set(np.concatenate(held).tolist()))
        assert pool.indices.tolist() == expected  # exactly the complement, ascending
        assert len(pool) == size - sum(map(len, held)) == 12
        assert pool.pool and not pool.mixed and pool.split == "dictionary" and pool.seed == seed
    # The stored dictionary split is a subset of the pool dictionary (it avoids train and test too).
    assert set(read_split_indices(store, "dictionary", 0)) <= set(load_pool_dictionary(store, 0).indices)
    with pytest.raises(SplitError, match="seed-7"):
        load_pool_dictionary(store, 7)


@pytest.mark.filterwarnings("ignore:The given NumPy array is not writable")
def test_lazy_rows_read_what_the_store_holds_and_nothing_before(store):
    pool = load_pool_dictionary(store, 0)
    assert isinstance(pool.images, LazyRows) and isinstance(pool.semantics, LazyRows)
    direct = read_samples(open_store(store), pool.indices)
    assert pool.images.shape == direct["image"].shape and pool.images.dtype == np.uint8
    np.testing.assert_array_equal(np.asarray(pool.images), direct["image"])
    np.testing.assert_array_equal(pool.semantics[3:9:2], direct["semantic"][3:9:2])
    np.testing.assert_array_equal(pool.homographies[np.array([5, 0, 5])], direct["homography"][[5, 0, 5]])
    np.testing.assert_array_equal(pool.semantics[-1], direct["semantic"][-1])
    np.testing.assert_array_equal(pool.images[2, 1:3], direct["image"][2, 1:3])
    batches = list(pool.semantics.batches(5))
    assert [start for start, _ in batches] == [0, 5, 10]
    np.testing.assert_array_equal(np.concatenate([rows for _, rows in batches]), direct["semantic"])
    assert not pool.images[0:2].flags.writeable  # read-only, as every array the harness hands out
    again = pickle.loads(pickle.dumps(pool))  # holds no open store: pickles for DataLoader workers
    np.testing.assert_array_equal(again.semantics[4], direct["semantic"][4])
    image, semantic, H = pool[4]
    assert image.shape == (3, 36, 64) and torch.equal(semantic, torch.from_numpy(direct["semantic"][4]).long())


def _brute_force_mse(queries: np.ndarray, templates: np.ndarray) -> np.ndarray:
    """(Q,) template of lowest one-hot MSE, by explicit differences (independent of the GEMM)."""
    q = (queries[:, None, ..., None] == np.arange(4)).astype(np.int64)
    t = (templates[None, ..., None] == np.arange(4)).astype(np.int64)
    return ((q - t) ** 2).sum(axis=(2, 3, 4)).argmin(axis=1)


def test_template_search_over_the_pool_equals_brute_force(store):
    pool = load_pool_dictionary(store, 0)
    test = load_split(store, "test", 0)
    estimator = TemplateEstimator(stride=1)
    estimator.fit(load_split(store, "train", 0), pool, pool.scene)
    found = estimator.match_semantic(test.semantics)
    np.testing.assert_array_equal(found, _brute_force_mse(test.semantics, np.asarray(pool.semantics)))
    np.testing.assert_array_equal(estimator.predict_semantic(test.semantics),
                                  np.asarray(pool.homographies)[found])
    # Blocks of 3 templates give the same answer as one block.
    from synthcal.estimators.classic import match_strided, one_hot

    assert match_strided(one_hot(test.semantics), estimator.templates, template_chunk=3).tolist() == found.tolist()


def test_the_siamese_search_over_the_pool_equals_brute_force(store, tmp_path):
    pool = load_pool_dictionary(store, 0)
    train, test = load_split(store, "train", 0), load_split(store, "test", 0)
    estimator = PaperEstimator(segmentation="ground-truth", settings=SMOKE_TRAINING, device="cpu",
                               cache_dir=tmp_path / "cache")
    estimator.fit(train, pool, pool.scene)
    fitted = estimator._check_fitted()
    siamese, work = fitted["siamese"], tuple(SMOKE_TRAINING["work_size"])
    # Brute force: embed every pool map and every test map independently, nearest by explicit distances.
    from synthcal.training import reduce_class_maps

    with torch.no_grad():
        templates = siamese(one_hot_maps(reduce_class_maps(np.asarray(pool.semantics), work), 4))
        queries = siamese(one_hot_maps(reduce_class_maps(test.semantics, work), 4))
    torch.testing.assert_close(fitted["embedding"], templates)  # embedded once, cached, the same
    expected = ((queries[:, None] - templates[None]) ** 2).sum(-1).argmin(1)
    from synthcal.models import nearest_embeddings

    assert nearest_embeddings(queries, fitted["embedding"]).index.tolist() == expected.tolist()
    assert (tmp_path / "cache" / "embedding").is_dir()  # beside the other stages
    assert np.isfinite(estimator.predict_semantic(test.semantics)).all()


@pytest.mark.parametrize("full, work", [
    ((144, 256), (128, 72)),  # the quick work size: 2 × 2 footprints (the table)
    ((36, 64), (16, 18)),  # 4 × 2: 8 pixels, 16-bit codes (the table)
    ((36, 64), (64, 12)),  # 1 × 3 (the table)
    ((36, 64), (16, 9)),  # 4 × 4: 16 pixels, one-hot area interpolation
    ((36, 64), (40, 20)),  # not integer factors: one-hot area interpolation
])
def test_reduced_class_maps_are_the_argmax_of_the_area_averaged_one_hot_maps(full, work):
    """The definition (resolution.py): area-average each class's one-hot map, take the argmax (the lowest
    class among equals); computed here with torch directly, and for whole footprints by counting."""
    import torch.nn.functional as F

    from synthcal.training import reduce_class_maps

    rng = np.random.default_rng(5)
    maps = rng.choice(4, size=(30, *full), p=[0.4, 0.3, 0.2, 0.1]).astype(np.uint8)  # ties and majorities
    maps[:5] = maps[:5, :1]  # rows of one class: vertical runs
    one_hot = F.one_hot(torch.from_numpy(maps).long(), 4).permute(0, 3, 1, 2).float()
    expected = F.interpolate(one_hot, size=work[::-1], mode="area").argmax(1).to(torch.uint8)
    reduced = reduce_class_maps(maps, work)
    assert reduced.dtype == torch.uint8 and torch.equal(reduced, expected)
    fy, fx = full[0] / work[1], full[1] / work[0]
    if fy.is_integer() and fx.is_integer():
        blocks = maps.reshape(len(maps), work[1], int(fy), work[0], int(fx))
        counts = np.stack([(blocks == c).sum(axis=(2, 4)) for c in range(4)], axis=-1)
        assert np.array_equal(reduced.numpy(), counts.argmax(-1))  # np.argmax: the first of equal counts


def test_the_pool_reduced_batch_by_batch_equals_the_whole_array_reduced(store):
    """What the paper estimator does with a pool dictionary (shard by shard, into one array)."""
    from synthcal.training import reduce_class_map_batches, reduce_class_maps

    pool, work = load_pool_dictionary(store, 0), tuple(SMOKE_TRAINING["work_size"])
    whole = reduce_class_maps(np.asarray(pool.semantics), work)
    streamed = reduce_class_map_batches(pool.semantics.batches(5), len(pool), work)
    assert len(pool) > 5 and streamed.shape == (len(pool), work[1], work[0]) and torch.equal(streamed, whole)
    with pytest.raises(ValueError, match="4 maps given, 5 expected"):
        reduce_class_map_batches([(0, np.asarray(pool.semantics[:4]))], 5, work)
