"""Independent pools per dataset (issue 9, item 3): the pool's seed is derived from the
configured seed and the dataset's name; a dataset's own ``seed:`` is used as is."""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np
import pytest
import yaml

from synthcal.config import load_config
from synthcal.generate.grid import sample_cameras
from synthcal.generate.pipeline import anchored_spec, load_scene, plan_cameras, sample_rng

ROOT = Path(__file__).resolve().parents[2]


def _config(folder: Path, datasets: dict, seed: int = 0):
    """The bundled datasets.yaml with extra datasets and a default seed."""
    raw = yaml.safe_load((ROOT / "datasets.yaml").read_text())
    raw["defaults"]["seed"] = seed
    raw["datasets"].update(datasets)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "datasets.yaml"
    path.write_text(yaml.safe_dump(raw))
    return load_config(path)


def _pool(config, name: str) -> np.ndarray:
    spec = config.resolve(name, "smoke")
    camera, _ = plan_cameras(spec, load_scene(spec))
    return camera["grid_index"]


def test_entropy_is_the_seed_and_the_names_crc32(tmp_path):
    config = _config(tmp_path, {}, seed=3)
    spec = config.resolve("intersection-1", "smoke")
    assert spec.seed == 3 and spec.seed_from_name
    # zlib.crc32, not hash(): the same on every run, machine and Python version
    assert spec.pool_entropy == (3, zlib.crc32(b"intersection-1")) == (3, 1279528162)
    assert spec.pool_seed_attributes()["entropy"] == [3, 1279528162]


def test_same_seed_and_name_give_the_same_pool(tmp_path):
    a = _pool(_config(tmp_path / "a", {}), "intersection-2")
    b = _pool(_config(tmp_path / "b", {}), "intersection-2")
    np.testing.assert_array_equal(a, b)


def test_two_names_give_different_pools_even_over_one_scene(tmp_path):
    twin = {"twin": {"scene": "intersection-1", "grid": "intersection", "pool_size": 200000}}
    config = _config(tmp_path, twin)
    pools = {name: _pool(config, name) for name in ("intersection-1", "intersection-2", "twin")}
    assert len(set(pools["intersection-1"].tolist()) & set(pools["twin"].tolist())) < 3
    assert len(set(pools["intersection-1"].tolist()) & set(pools["intersection-2"].tolist())) < 3
    # and the configured seed still matters
    other = _pool(_config(tmp_path / "seed1", twin, seed=1), "twin")
    assert not np.array_equal(other, pools["twin"])


def test_an_explicit_seed_wins_and_is_used_as_is(tmp_path):
    config = _config(tmp_path, {"mine": {"scene": "intersection-1", "grid": "intersection", "pool_size": 1000,
                                         "seed": 7}}, seed=3)
    spec = config.resolve("mine", "smoke")
    assert spec.seed == 7 and not spec.seed_from_name and spec.pool_entropy == 7
    scene = load_scene(spec)
    grid = anchored_spec(spec, scene).grid
    assert grid is not None
    expected = sample_cameras(grid, spec.pool_size, 7)  # the plain seed, no name mixed in
    np.testing.assert_array_equal(_pool(config, "mine"), expected.grid_index)
    assert spec.pool_seed_attributes() == {"seed": 7, "entropy": 7, "from_name": False,
                                           "rule": "numpy.random.SeedSequence(seed): the dataset's own seed, as is"}
    # the appearance streams follow the pool's entropy too
    assert sample_rng(spec.pool_entropy, 5).random() == sample_rng(7, 5).random()


def test_a_negative_dataset_seed_names_the_key(tmp_path):
    from synthcal.config import ConfigError

    with pytest.raises(ConfigError, match=r"datasets\.mine\.seed"):
        _config(tmp_path, {"mine": {"scene": "soccer", "grid": "soccer", "pool_size": 10, "seed": -1}})


def test_the_store_records_seed_and_derivation(smoke_stores, tmp_path):
    from synthcal.store import open_store

    store = open_store(smoke_stores.path("intersection-3"))
    attrs = store.attrs
    assert attrs["seed"] == 0
    assert attrs["pool_seed"]["entropy"] == [0, zlib.crc32(b"intersection-3")] and attrs["pool_seed"]["from_name"]
    assert "crc32" in attrs["pool_seed"]["rule"]
