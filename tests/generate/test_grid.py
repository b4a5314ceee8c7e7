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


def materialised(axis: AxisRange, name: str) -> np.ndarray:
    """The axis as it was built before counts had a closed form (the reference): every value, then
    a full-circle pan's upper end dropped."""
    values = axis.start + axis.step * np.arange(int(np.floor((axis.stop - axis.start) / axis.step + 1e-9)) + 1)
    if name == "pan_deg" and len(values) > 1 and np.isclose(values[-1] - values[0], 360.0):
        values = values[:-1]
    return values


def test_closed_form_counts_match_the_materialised_axes():
    rng = np.random.default_rng(23)
    steps = [1.0, 0.5, 0.1, 1 / 3, 15.0, 0.25, 7.5, 2.2]
    checked = 0
    for _ in range(3000):
        step = float(rng.choice(steps)) * float(rng.choice([1, 1, 10, 0.01]))
        start = float(np.round(rng.uniform(-400, 400), int(rng.integers(0, 3))))
        # Stops on, near and between grid points (and whole circles, where pan drops its end).
        k = int(rng.integers(0, 60))
        stop = start + float(rng.choice([k * step, k * step + step / 2, k * step * (1 + 1e-12), 360.0, 0.0]))
        axis = AxisRange(start=start, stop=stop, step=step)
        for name in ("pan_deg", "tilt_deg"):
            reference = materialised(axis, name)
            assert axis.count(name) == len(reference), (axis, name)
            assert axis.values(name).tobytes() == reference.tobytes()
            checked += name == "pan_deg" and len(reference) < len(materialised(axis, "tilt_deg"))
    assert checked > 10  # full circles really came up


def test_a_grid_of_10_to_the_11_cameras_is_sampled_without_materialising_an_axis():
    pan = AxisRange(start=-50, stop=50, step=1e-9)  # 1e11 values: 800 GB as an array
    grid = GridConfig(pan_deg=pan, tilt_deg=AxisRange(start=-10, stop=-10), focal_px=AxisRange(start=500, stop=500),
                      jitter=True)
    assert grid.size() == pan.count() == 100_000_000_001
    samples = sample_cameras(grid, 20, seed=5, scene_position=(1.0, 2.0, 3.0))
    assert len(set(samples.grid_index.tolist())) == 20 and samples.grid_index.max() < grid.size()
    offset = samples.values[:, 0] - (-50 + 1e-9 * samples.grid_index)
    assert np.all(np.abs(offset) <= 1e-9 / 2 + 1e-12)
    np.testing.assert_array_equal(samples.values[:, 1:], [[-10, 500, 1, 2, 3]] * 20)


def test_an_axis_over_10_to_the_12_values_is_refused():
    with pytest.raises(ValueError, match="step 1e-12 from -50 to 50 gives more than 1e\\+12 values"):
        AxisRange(start=-50, stop=50, step=1e-12)


def test_a_grid_over_10_to_the_12_cameras_names_its_largest_axis():
    with pytest.raises(ValueError, match=r"1\.82e\+13 cameras.*raise the step of focal_px \(9000001 values\)"):
        GridConfig(pan_deg=AxisRange(start=-50, stop=50, step=1), tilt_deg=AxisRange(start=-20, stop=0, step=1e-3),
                   focal_px=AxisRange(start=100, stop=1000, step=1e-4))
