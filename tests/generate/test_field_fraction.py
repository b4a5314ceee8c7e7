"""Empty samples (issue 14, item 6): the store counts them; ``min_field_fraction`` redraws
cameras whose semantic map is (nearly) all background, deterministically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from synthcal.config import ConfigError, load_config
from synthcal.generate.grid import redraw_cameras, sample_cameras
from synthcal.generate.pipeline import generate_dataset
from synthcal.generate.render import foreground_fraction
from synthcal.store import open_store

ROOT = Path(__file__).resolve().parents[2]


def _config(folder: Path, datasets: dict) -> Path:
    raw = yaml.safe_load((ROOT / "datasets.yaml").read_text())
    raw["datasets"].update(datasets)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "datasets.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_foreground_fraction_counts_non_background_pixels():
    maps = np.zeros((3, 2, 4), np.uint8)
    maps[1, 0, :2] = [1, 3]
    maps[2] = 2
    np.testing.assert_array_equal(foreground_fraction(maps), [0.0, 0.25, 1.0])


def test_redraw_replaces_only_rejected_cameras_with_distinct_accepted_ones():
    grid = load_config(ROOT / "datasets.yaml").config.grids["soccer"]
    position = (600.0, 1000.0, 170.0)
    samples = sample_cameras(grid, 2000, seed=4, scene_position=position)

    def keep(values: np.ndarray) -> np.ndarray:
        return values[:, 1] <= -8  # tilt at least 8° down

    first, count = redraw_cameras(grid, samples, keep, seed=4, scene_position=position)
    again, _ = redraw_cameras(grid, samples, keep, seed=4, scene_position=position)
    rejected = ~keep(samples.values)
    assert count == rejected.sum() > 500
    assert keep(first.values).all()
    assert len(np.unique(first.grid_index)) == 2000  # still distinct grid cameras
    np.testing.assert_array_equal(first.values[~rejected], samples.values[~rejected])
    np.testing.assert_array_equal(first.grid_index, again.grid_index)  # deterministic
    with pytest.raises(ValueError, match="no acceptable camera"):
        redraw_cameras(grid, samples, lambda v: v[:, 1] < -100, seed=4, scene_position=position, max_draws=20)


@pytest.fixture(scope="module")
def soccer_pools(tmp_path_factory):
    """The same soccer dataset with and without ``min_field_fraction: 0.05`` (smoke size, 1 worker)."""
    folder = tmp_path_factory.mktemp("field")
    entry = {"scene": "soccer", "grid": "soccer", "pool_size": 4500}
    plain = load_config(_config(folder / "plain", {"pitch": entry})).resolve("pitch", "smoke")
    path = _config(folder / "filtered", {"pitch": {**entry, "min_field_fraction": 0.05}})
    filtered = load_config(path).resolve("pitch", "smoke")
    return (generate_dataset(plain, folder / "plain-out", progress=False),
            generate_dataset(filtered, folder / "filtered-out", progress=False), filtered, folder)


def test_min_field_fraction_leaves_no_sample_under_it(soccer_pools):
    plain, filtered, _, _ = soccer_pools
    before = foreground_fraction(open_store(plain)["semantic"][:])
    after = foreground_fraction(open_store(filtered)["semantic"][:])
    assert (before < 0.05).sum() >= 2 and (before == 0).any()  # the default pool has empty samples
    assert after.min() >= 0.05
    # only those were redrawn: every other sample kept its camera (same name ⇒ same first draw)
    a, b = open_store(plain), open_store(filtered)
    kept = before >= 0.05
    np.testing.assert_array_equal(a["camera/grid_index"][:][kept], b["camera/grid_index"][:][kept])
    assert not np.array_equal(a["camera/grid_index"][:][~kept], b["camera/grid_index"][:][~kept])


def test_min_field_fraction_is_the_same_with_two_workers(soccer_pools, tmp_path):
    _, filtered, spec, _ = soccer_pools
    two = generate_dataset(spec, tmp_path, workers=2, progress=False)
    files = sorted(p.relative_to(filtered) for p in filtered.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(two) for p in two.rglob("*") if p.is_file())
    for name in files:
        assert (filtered / name).read_bytes() == (two / name).read_bytes(), name


def test_the_store_records_its_empty_samples(soccer_pools):
    for store in soccer_pools[:2]:
        group = open_store(store)
        fractions = foreground_fraction(group["semantic"][:])
        recorded = group.attrs["foreground"]
        assert recorded["empty_samples"] == int((fractions == 0).sum())
        assert recorded["min_fraction"] == pytest.approx(fractions.min())
        assert recorded["mean_fraction"] == pytest.approx(fractions.mean())


def test_info_reports_the_share_of_empty_samples(soccer_pools, capsys):
    from synthcal.cli import main

    plain, filtered, _, _ = soccer_pools
    empty = open_store(plain).attrs["foreground"]["empty_samples"]
    assert main(["info", str(plain)]) in (0, None)
    out = capsys.readouterr().out
    assert f"empty maps   {empty} of 48 ({100 * empty / 48:.1f} %) all background" in out
    assert main(["info", str(filtered)]) in (0, None)
    assert "min_field_fraction 0.05: cameras below it redrawn" in capsys.readouterr().out


@pytest.mark.parametrize("value", [1.0, -0.1, "lots"])
def test_a_bad_min_field_fraction_names_file_key_and_value(tmp_path, value):
    path = _config(tmp_path, {"pitch": {"scene": "soccer", "grid": "soccer", "pool_size": 10,
                                        "min_field_fraction": value}})
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert str(path) in str(error.value) and "datasets.pitch.min_field_fraction" in str(error.value)
    assert repr(value) in str(error.value)


def test_min_field_fraction_is_refused_for_given_poses(tmp_path):
    path = _config(tmp_path, {"wc": {"scene": "soccer", "poses": "worldcup2014", "dictionary_from": "soccer",
                                     "min_field_fraction": 0.05}})
    with pytest.raises(ConfigError, match="min_field_fraction: the poses 'worldcup2014' are given cameras"):
        load_config(path)
