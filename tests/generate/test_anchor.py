"""Relative grids (issue 14, item 4): X/Y as offsets from the scene's camera anchor.

The bundled intersection grid is the paper's absolute grid (X 600..700, Y 900..1000)
written as −50..50 around the built-in intersections' anchor (650, 950); it must
give exactly the same cameras and store, and fit a user scene of any size.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from synthcal.config import AxisRange, ConfigError, GridConfig, load_config
from synthcal.generate.grid import sample_cameras
from synthcal.generate.pipeline import generate_dataset
from synthcal.scenes import build_scene
from synthcal.store import open_store

ROOT = Path(__file__).resolve().parents[2]

# The paper's intersection grid as SPEC §3 writes it: absolute bird's-eye pixels.
PAPER_INTERSECTION = GridConfig(
    pan_deg=AxisRange(start=-180, stop=180, step=15), tilt_deg=AxisRange(start=-20, stop=0, step=5),
    focal_px=AxisRange(start=50, stop=500, step=50), x=AxisRange(start=600, stop=700, step=10),
    y=AxisRange(start=900, stop=1000, step=10), z=AxisRange(start=50, stop=100, step=10),
)


@pytest.fixture(scope="module")
def bundled():
    return load_config(ROOT / "datasets.yaml")


def test_bundled_intersection_grid_is_the_papers_on_every_intersection(bundled):
    grid = bundled.config.grids["intersection"]
    assert grid.xy_relative
    for name in ("intersection-1", "intersection-3", "intersection-5"):
        anchor = build_scene(name).anchor
        assert anchor == (650.0, 950.0)
        absolute = grid.anchored(anchor)
        assert absolute == PAPER_INTERSECTION
        # what stores record and hash: the same JSON as the absolute grid (no xy_relative key)
        assert absolute.model_dump(mode="json") == PAPER_INTERSECTION.model_dump(mode="json")
    relative = sample_cameras(grid, 2000, seed=5, anchor=(650.0, 950.0))
    paper = sample_cameras(PAPER_INTERSECTION, 2000, seed=5)
    np.testing.assert_array_equal(relative.grid_index, paper.grid_index)
    np.testing.assert_array_equal(relative.values, paper.values)


def test_relative_grid_needs_an_anchor_and_its_xyz(bundled):
    with pytest.raises(ValueError, match="anchor"):
        sample_cameras(bundled.config.grids["intersection"], 10, seed=0)
    with pytest.raises(ValueError, match="xy_relative"):
        GridConfig(pan_deg=AxisRange(start=0, stop=1), tilt_deg=AxisRange(start=0, stop=1),
                   focal_px=AxisRange(start=50, stop=60), xy_relative=True)


def test_anchor_is_camera_position_else_the_centre(tmp_path):
    scene = _user_scene(tmp_path, 1200, 900)
    assert load_scene_of(scene, None).anchor == (600.0, 450.0)
    assert load_scene_of(scene, [300.0, 200.0, 60.0]).anchor == (300.0, 200.0)
    assert build_scene("soccer").anchor == build_scene("soccer").camera_position[:2]


def load_scene_of(paths: tuple[Path, Path], position: list[float] | None):
    from synthcal.scenes import load_user_scene

    return load_user_scene("mine", *paths, camera_position=position)


def _user_scene(folder: Path, width: int, height: int) -> tuple[Path, Path]:
    """A width × height scene: a road cross through the centre on terrain, as PNGs."""
    ids = np.full((height, width), 2, np.uint8)
    ids[height // 2 - 40:height // 2 + 40] = 1
    ids[:, width // 2 - 40:width // 2 + 40] = 1
    ids[:30] = 0
    rng = np.random.default_rng(0)
    rgb = (np.array([[0, 0, 0], [90, 90, 95], [60, 140, 50], [200, 40, 40]], np.uint8)[ids]
           + rng.integers(0, 20, (height, width, 3), dtype=np.uint8))
    image, semantic = folder / "scene.png", folder / "labels.png"
    assert cv2.imwrite(str(image), rgb[..., ::-1]) and cv2.imwrite(str(semantic), ids)
    return image, semantic


def _config(folder: Path, scene: dict, dataset: dict) -> Path:
    """The bundled datasets.yaml plus a user scene ``mine`` and a dataset ``mine`` over it."""
    raw = yaml.safe_load((ROOT / "datasets.yaml").read_text())
    raw["scenes"] = {"mine": {"image": "scene.png", "semantic": "labels.png", **scene}}
    raw["datasets"]["mine"] = {"scene": "mine", "grid": "intersection", "pool_size": 64, **dataset}
    path = folder / "datasets.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize("position, anchor", [(None, (600.0, 450.0)), ([400.0, 300.0, 70.0], (400.0, 300.0))])
def test_a_1200_x_900_user_scene_generates_with_the_intersection_grid(tmp_path, position, anchor):
    _user_scene(tmp_path, 1200, 900)
    config = load_config(_config(tmp_path, {} if position is None else {"camera_position": position}, {}))
    spec = config.resolve("mine", "smoke")
    store = open_store(generate_dataset(spec, tmp_path / "out", progress=False))
    x, y = store["camera/x"][:], store["camera/y"][:]
    offsets = np.arange(-50.0, 51.0, 10.0)
    # every camera is a grid point around the anchor, and they spread on both sides of it
    assert set((x - anchor[0]).tolist()) <= set(offsets) and set((y - anchor[1]).tolist()) <= set(offsets)
    assert x.min() < anchor[0] < x.max() and y.min() < anchor[1] < y.max()
    assert abs(x.mean() - anchor[0]) < 15 and abs(y.mean() - anchor[1]) < 15
    # the store records the absolute grid it drew from
    recorded = store.attrs["grid"]
    assert (recorded["x"]["start"], recorded["x"]["stop"]) == (anchor[0] - 50, anchor[0] + 50)
    assert (recorded["y"]["start"], recorded["y"]["stop"]) == (anchor[1] - 50, anchor[1] + 50)
    assert "xy_relative" not in recorded and (store["semantic"][:] == 1).any()


def test_a_grid_leaving_a_small_scene_names_the_anchor(tmp_path):
    _user_scene(tmp_path, 120, 90)
    spec = load_config(_config(tmp_path, {}, {"pool_size": 8})).resolve("mine", "smoke")
    with pytest.raises(ConfigError, match=r"datasets\.mine: grid y range -5\.\.95 \(offsets -50\.\.50 from the "
                                          r"scene's anchor 60, 45\) leaves scene 'mine'"):
        generate_dataset(spec, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "scene, key",
    [
        ({"camera_position": [10, 20, 0]}, "camera_position"),
        ({"camera_position": [10, 20]}, "camera_position"),
        ({"heading_deg": float("nan")}, "heading_deg"),
        ({"pixels_per_metre": -1}, "pixels_per_metre"),
        ({"classes": ["background", "road", "road", "x"]}, "classes"),
        ({"colour": 3}, "colour"),
    ],
)
def test_bad_scene_values_name_file_key_and_value(tmp_path, scene, key):
    _user_scene(tmp_path, 120, 90)
    path = _config(tmp_path, scene, {})
    with pytest.raises(ConfigError) as error:
        load_config(path)
    message = str(error.value)
    assert str(path) in message and f"scenes.mine.{key}" in message and "value" in message


def test_cli_error_for_a_bad_scene_value_is_one_line(tmp_path):
    _user_scene(tmp_path, 120, 90)
    path = _config(tmp_path, {"camera_position": [10, 20, -5]}, {})
    done = subprocess.run([sys.executable, "-m", "synthcal.cli", "generate", "mine", "--config", str(path),
                           "--out", str(tmp_path / "out")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.startswith("synthcal: error: ")
    assert "camera_position" in done.stderr and not (tmp_path / "out").exists()
