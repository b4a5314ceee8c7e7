"""Per-seed splits and mixed dictionaries inside smoke stores (SPEC §6)."""

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from synthcal.cli import main, parse_seeds
from synthcal.config import SplitSizes, load_config
from synthcal.generate.pipeline import generate_dataset
from synthcal.generate.splits import SplitsResized, draw_indices, draw_mixed, draw_splits
from synthcal.store import open_store, read_manifest, read_samples, write_manifest
from synthcal.store.manifest import check_files
from synthcal.store.splits import (
    SPLIT_NAMES,
    SplitError,
    drawn_seeds,
    read_mixed_dictionary,
    read_split_indices,
    resolve_mixed_dictionary,
)

ROOT = Path(__file__).resolve().parents[2]
INTERSECTIONS = [f"intersection-{k}" for k in range(1, 6)]
SEEDS = (0, 1, 2, 3, 4)


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "datasets.yaml")


@pytest.fixture(scope="module")
def stores(smoke_stores, tmp_path_factory) -> dict[str, Path]:
    """The five intersections at smoke size, with their splits drawn."""
    paths = smoke_stores.copy(INTERSECTIONS, tmp_path_factory.mktemp("splits"))
    for path in paths.values():
        draw_splits(path)
    return paths


def test_sizes_and_disjointness_for_every_seed(config, stores):
    spec = config.resolve("intersection-1", "smoke")
    store = stores["intersection-1"]
    assert drawn_seeds(open_store(store)) == SEEDS
    for seed in SEEDS:
        sets = {name: read_split_indices(store, name, seed) for name in SPLIT_NAMES}
        for name, index in sets.items():
            assert index.dtype == np.int64 and len(index) == getattr(spec.splits, name)
            assert np.all(np.diff(index) > 0) and index.min() >= 0 and index.max() < spec.pool_size
        together = np.concatenate(list(sets.values()))
        assert len(np.unique(together)) == len(together), f"seed {seed}: sets overlap"


def test_same_seed_same_indices_different_seeds_differ(stores):
    store = stores["intersection-2"]
    train = {seed: read_split_indices(store, "train", seed) for seed in SEEDS}
    assert all(not np.array_equal(train[a], train[b]) for a in SEEDS for b in SEEDS if a < b)
    again = draw_splits(store)
    assert again.drawn == () and again.unchanged == SEEDS
    for seed in SEEDS:
        np.testing.assert_array_equal(read_split_indices(store, "train", seed), train[seed])
    sizes = SplitSizes(train=24, test=8, dictionary=12)
    np.testing.assert_array_equal(draw_indices(48, sizes, 0, 3)["train"], train[3])


def test_split_stream_is_independent_of_the_pool_seed_stream():
    sizes = SplitSizes(train=10, test=5, dictionary=5)
    a, b = draw_indices(1000, sizes, pool_seed=0, split_seed=0), draw_indices(1000, sizes, pool_seed=1, split_seed=0)
    assert not np.array_equal(a["train"], b["train"])
    pool_stream = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(0,))).choice(1000, 20, replace=False)
    assert not np.array_equal(np.sort(pool_stream[:10]), a["train"])


def test_redraw_with_other_sizes_replaces_atomically(stores, tmp_path):
    store = tmp_path / "intersection-3.zarr"
    shutil.copytree(stores["intersection-3"], store)
    with pytest.warns(SplitsResized, match=r"seed 1: replacing its splits \(train 24, test 8, dictionary 12, validation 4\)"):
        result = draw_splits(store, seeds=[1], sizes=SplitSizes(train=30, test=6, dictionary=6))
    assert result.drawn == (1,)
    assert len(read_split_indices(store, "train", 1)) == 30
    assert len(read_split_indices(store, "train", 0)) == 24  # other seeds untouched
    assert not list(store.glob(".splits-tmp-*")), "no scratch directory left behind"


def test_mixed_templates_come_from_other_scenes_and_resolve(stores):
    store = stores["intersection-1"]
    for seed in (0, 4):
        mixed = read_mixed_dictionary(store, seed)
        assert mixed.sources == ("intersection-2", "intersection-3", "intersection-4", "intersection-5")
        assert "intersection-1" not in mixed.sources
        assert len(mixed.index) == 12 and np.bincount(mixed.source).tolist() == [3, 3, 3, 3]
        arrays = resolve_mixed_dictionary(store, seed)
        for k, source in enumerate(mixed.sources):
            mask = mixed.source == k
            direct = read_samples(open_store(stores[source]), mixed.index[mask])
            for name in ("image", "semantic", "homography"):
                np.testing.assert_array_equal(arrays[name][mask], direct[name])
    group = open_store(store)
    attrs = group["splits/seed-0/mixed_dictionary"].attrs
    assert attrs["stores"][0] == "../intersection-2.zarr" and "source" in attrs["homography_frame"]


def test_draw_mixed_shares_and_limits():
    source, index = draw_mixed([10, 10, 3], 7, pool_seed=0, split_seed=0)
    assert np.bincount(source).tolist() == [3, 2, 2]
    with pytest.raises(ValueError, match="exceeds its pool of N = 3"):
        draw_mixed([10, 10, 3], 12, 0, 0)


def test_too_many_samples_is_a_clear_error(stores):
    store = stores["intersection-2"]
    with pytest.raises(SplitError) as error:
        draw_splits(store, sizes=SplitSizes(train=40, test=8, dictionary=12))
    message = str(error.value)
    assert str(store) in message and "40/8/12" in message and "N = 48" in message


def test_mixed_share_larger_than_a_source_pool(config, stores, tmp_path):
    shutil.copytree(stores["intersection-1"], tmp_path / "intersection-1.zarr")
    generate_dataset(config.resolve("intersection-2", "smoke", pool_size=10), tmp_path, progress=False)
    with pytest.raises(SplitError, match=r"intersection-1.zarr: mixed dictionary of 12 templates from 1 source.*"
                                         r"intersection-2 N = 10.*share 12 .* exceeds its pool of N = 10"):
        draw_splits(tmp_path / "intersection-1.zarr", sources=["intersection-2"], seeds=[0])


def test_unknown_seed_and_split(stores):
    store = stores["intersection-2"]
    with pytest.raises(SplitError, match=r"splits/seed-9.*seeds available: 0, 1, 2, 3, 4"):
        read_split_indices(store, "train", 9)
    with pytest.raises(SplitError, match=r"intersection-2.zarr: unknown split 'holdout'"):
        read_split_indices(store, "holdout", 0)
    with pytest.raises(SplitError, match="intersection-2.zarr.*no mixed dictionary"):
        read_mixed_dictionary(store, 0)
    with pytest.raises(SplitError, match=r"seeds must be integers ≥ 0 \(value \[-1\]\)"):
        draw_splits(store, seeds=[-1])


def test_missing_source_store(stores, tmp_path):
    alone = tmp_path / "intersection-4.zarr"
    shutil.copytree(stores["intersection-4"], alone)
    with pytest.raises(SplitError, match=r"intersection-4.zarr: mixed-dictionary source 'intersection-1'.*"
                                         r"intersection-1.zarr: no synthcal store"):
        draw_splits(alone, mixed=True)
    # The default draws the own splits and says why the mixed dictionary is missing.
    with pytest.warns(SplitsResized, match="mixed dictionary 12\\) with train 24, test 8, dictionary 12, validation 4;"):
        result = draw_splits(alone, seeds=[0])
    assert "intersection-1.zarr" in result.note
    own = {name: read_split_indices(alone, name, 0) for name in SPLIT_NAMES}
    # The sources beside it later: drawing again adds the mixed dictionary and keeps the own sets, so
    # nothing earlier is invalidated and nothing warns.
    sources = [tmp_path / f"{name}.zarr" for name in INTERSECTIONS if name != "intersection-4"]
    for link in sources:
        link.symlink_to(stores[link.stem])
    with warnings.catch_warnings():
        warnings.simplefilter("error", SplitsResized)
        draw_splits(alone, seeds=[0])
    for name in SPLIT_NAMES:
        np.testing.assert_array_equal(read_split_indices(alone, name, 0), own[name])
    assert len(read_mixed_dictionary(alone, 0).index) == 12
    for link in sources:
        link.unlink()
    # A copy made with its mixed dictionary cannot resolve it without the sources.
    with pytest.raises(SplitError, match="mixed-dictionary source 'intersection-1'"):
        resolve_mixed_dictionary(alone, 1)


def test_regenerated_source_is_detected(stores, tmp_path):
    import zarr

    for name in INTERSECTIONS:
        shutil.copytree(stores[name], tmp_path / f"{name}.zarr")
    source = zarr.open_group(zarr.storage.LocalStore(tmp_path / "intersection-2.zarr"), mode="r+")
    source.attrs["config_hash"] = "0" * 64
    write_manifest(tmp_path / "intersection-2.zarr")  # regenerated: a sealed store of another pool
    with pytest.raises(SplitError, match="regenerated since the split was drawn"):
        resolve_mixed_dictionary(tmp_path / "intersection-5.zarr", 0)


def test_parse_seeds():
    assert parse_seeds("0-4") == SEEDS and parse_seeds("3") == (3,) and parse_seeds("0,2,5-6") == (0, 2, 5, 6)
    for bad in ("a", "4-1", "-1", ""):
        with pytest.raises(SplitError, match="--seeds"):
            parse_seeds(bad)


def test_cli_split_and_generate_splits(stores, tmp_path, capsys):
    store = tmp_path / "intersection-3.zarr"
    shutil.copytree(stores["intersection-3"], store)
    assert main(["split", str(store), "--seeds", "5-6", "--train", "20"]) == 0
    assert "seeds 5, 6" in capsys.readouterr().out
    assert len(read_split_indices(store, "train", 6)) == 20
    assert main(["split", str(store), "--train", "100"]) == 2
    assert "N = 48" in capsys.readouterr().err
    assert main(["info", str(store)]) == 0
    assert "split seed 6 train 20, test 8, dictionary 12" in capsys.readouterr().out
    out = tmp_path / "gen"
    assert main(["generate", "intersection-2", "--profile", "smoke", "--out", str(out), "--splits", "--quiet",
                 "--config", str(ROOT / "datasets.yaml")]) == 0
    assert drawn_seeds(open_store(out / "intersection-2.zarr")) == SEEDS


def test_validation_is_disjoint_and_leaves_the_other_draws_as_they_were():
    """The validation set avoids the other three, and adding it changes none of them."""
    pool, seed = 200, 3
    without = draw_indices(pool, SplitSizes(train=100, test=30, dictionary=40), pool_seed=7, split_seed=seed)
    sets = draw_indices(pool, SplitSizes(train=100, test=30, dictionary=40, validation=20), pool_seed=7,
                        split_seed=seed)
    assert list(sets) == [*SPLIT_NAMES, "validation"] and "validation" not in without
    for name in SPLIT_NAMES:
        np.testing.assert_array_equal(sets[name], without[name])
    assert len(sets["validation"]) == 20
    assert len(np.unique(np.concatenate(list(sets.values())))) == 190  # four disjoint sets
    other = draw_indices(pool, SplitSizes(train=100, test=30, dictionary=40, validation=20), pool_seed=7,
                         split_seed=seed + 1)
    assert not np.array_equal(other["validation"], sets["validation"])
    with pytest.raises(ValueError, match=r"validation 31 samples asked for, but only 30 of N = 200 are left"):
        draw_indices(pool, SplitSizes(train=100, test=30, dictionary=40, validation=31), pool_seed=7, split_seed=0)


def test_drawing_again_adds_validation_to_a_store_drawn_without_it(smoke_stores, tmp_path):
    store = smoke_stores.copy(["intersection-1"], tmp_path)["intersection-1"]
    draw_splits(store, seeds=[0], sizes=SplitSizes(train=24, test=8, dictionary=12))
    before = {name: read_split_indices(store, name, 0) for name in SPLIT_NAMES}
    with pytest.raises(SplitError, match=r"splits/seed-0/validation: no validation set .*synthcal split .*--validation"):
        read_split_indices(store, "validation", 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SplitsResized)  # adding a validation set resizes nothing
        result = draw_splits(store, seeds=[0], sizes=SplitSizes(train=24, test=8, dictionary=12, validation=4))
    assert result.drawn == (0,)
    for name in SPLIT_NAMES:
        np.testing.assert_array_equal(read_split_indices(store, name, 0), before[name])
    validation = read_split_indices(store, "validation", 0)
    assert len(validation) == 4 and not set(validation) & set(np.concatenate(list(before.values())))
    manifest = read_manifest(store)  # resealed by draw_splits: the new array is under the checksums
    assert "splits/seed-0/validation/c/0" in manifest.files and not check_files(store, manifest, full=True)
