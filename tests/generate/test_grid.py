"""The paper's grids: sizes, enumeration, sampling without replacement, jitter."""

import itertools

import numpy as np
import pytest

from synthcal.config import AxisRange, GridConfig, load_config
from synthcal.generate.grid import grid_axes, sample_cameras

ROOT_CONFIG = "datasets.yaml"


@pytest.fixture(scope="module")
def grids():
    return load_config(ROOT_CONFIG).config.grids


def test_paper_grid_sizes(grids):
    assert grids["soccer"].size() == 5712
    assert grids["intersection"].size() == 871200


def test_full_circle_pan_drops_its_upper_end(grids):
    pan = grids["intersection"].pan_deg.values("pan_deg")
    assert len(pan) == 24 and pan[0] == -180 and pan[-1] == 165
    tilt = grids["intersection"].tilt_deg.values("tilt_deg")
    np.testing.assert_array_equal(tilt, [-20, -15, -10, -5, 0])


def test_samples_are_distinct_grid_cameras(grids):
    grid = grids["soccer"]
    samples = sample_cameras(grid, 4500, seed=0, scene_position=(1, 2, 3))
    assert len(np.unique(samples.grid_index)) == 4500
    # Every sample is the grid camera its index names (enumerated independently here).
    enumerated = list(itertools.product(*[a.tolist() for a in grid_axes(grid, (1, 2, 3))]))
    for k in range(0, 4500, 97):
        np.testing.assert_array_equal(samples.values[k], enumerated[samples.grid_index[k]])


def test_whole_grid_can_be_drawn_and_no_more(grids):
    samples = sample_cameras(grids["soccer"], 5712, seed=1, scene_position=(0, 0, 1))
    assert sorted(samples.grid_index.tolist()) == list(range(5712))
    with pytest.raises(ValueError, match="5712"):
        sample_cameras(grids["soccer"], 5713, seed=1, scene_position=(0, 0, 1))


def test_sampling_is_seeded(grids):
    anchor = (650.0, 950.0)  # the bundled intersection grid's X/Y are relative to the scene's anchor
    a = sample_cameras(grids["intersection"], 1000, seed=7, anchor=anchor)
    b = sample_cameras(grids["intersection"], 1000, seed=7, anchor=anchor)
    c = sample_cameras(grids["intersection"], 1000, seed=8, anchor=anchor)
    np.testing.assert_array_equal(a.grid_index, b.grid_index)
    assert not np.array_equal(a.grid_index, c.grid_index)


def test_jitter_stays_in_cell_and_range():
    grid = GridConfig(pan_deg=AxisRange(start=-180, stop=180, step=15), tilt_deg=AxisRange(start=-20, stop=0, step=5),
                      focal_px=AxisRange(start=50, stop=500, step=50), x=AxisRange(start=600, stop=700, step=10),
                      y=AxisRange(start=900, stop=1000, step=10), z=AxisRange(start=50, stop=100, step=10), jitter=True)
    plain = sample_cameras(grid.model_copy(update={"jitter": False}), 5000, seed=3)
    jittered = sample_cameras(grid, 5000, seed=3)
    np.testing.assert_array_equal(plain.grid_index, jittered.grid_index)
    offset = jittered.values - plain.values
    steps = np.array([15, 5, 50, 10, 10, 10])
    assert np.all(np.abs(offset) <= steps / 2 + 1e-9)
    assert np.all(np.abs(offset).max(axis=0) > 0.4 * steps)  # really spread over the cell
    assert jittered.values[:, 1].max() <= 0.0  # tilt never above the grid's top
    assert jittered.values[:, 0].min() < -180.0  # the full-circle pan wraps, unclipped
