"""Bad input through `synthcal generate`: a clear message (file, key, value), exit 2, nothing written."""

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from synthcal.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


def base_config() -> dict:
    return yaml.safe_load((ROOT / "datasets.yaml").read_text())


def run(tmp_path: Path, config: dict, *args: str, capsys) -> tuple[int, str, Path]:
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    out = tmp_path / "out"
    code = main(["generate", *args, "--profile", "smoke", "--quiet", "--out", str(out), "--config", str(path)])
    return code, capsys.readouterr().err, out


def assert_nothing_written(out: Path) -> None:
    assert not out.exists() or not any(out.iterdir())


def with_user_scene(tmp_path: Path, image_shape=(200, 300), semantic: np.ndarray | None = None, palette=None) -> dict:
    image = np.full((*image_shape, 3), 90, np.uint8)
    if semantic is None:
        semantic = np.zeros(image_shape, np.uint8)
        semantic[80:120] = 1
    cv2.imwrite(str(tmp_path / "scene.png"), image)
    cv2.imwrite(str(tmp_path / "labels.png"), semantic)
    config = base_config()
    scene = {"image": "scene.png", "semantic": "labels.png"}
    if palette is not None:
        scene["palette"] = palette
    config["scenes"] = {"mine": scene}
    config["grids"]["small"] = {"pan_deg": {"start": 0, "stop": 90, "step": 45},
                                "tilt_deg": {"start": -20, "stop": -10, "step": 10},
                                "focal_px": {"start": 100, "stop": 100, "step": 1},
                                "x": {"start": 100, "stop": 200, "step": 100},
                                "y": {"start": 50, "stop": 150, "step": 100}, "z": {"start": 30, "stop": 30, "step": 1}}
    config["datasets"] = {"mine": {"scene": "mine", "grid": "small", "pool_size": 8}}
    config.pop("mixed_dictionaries", None)
    return config


def test_a_valid_user_scene_generates(tmp_path, capsys):
    code, err, out = run(tmp_path, with_user_scene(tmp_path), "mine", capsys=capsys)
    assert code == 0, err
    assert (out / "mine.zarr" / "zarr.json").exists()


def test_unknown_key(tmp_path, capsys):
    config = base_config()
    config["grids"]["soccer"]["tilt_deg"]["stpe"] = 1
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    assert code == 2
    assert "datasets.yaml" in err and "grids.soccer.tilt_deg.stpe" in err and "unknown key" in err
    assert_nothing_written(out)


def test_empty_range(tmp_path, capsys):
    config = base_config()
    config["grids"]["soccer"]["pan_deg"] = {"start": 25, "stop": -25, "step": 1}
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    assert code == 2 and "grids.soccer.pan_deg" in err and "empty range" in err and "-25" in err
    assert_nothing_written(out)


@pytest.mark.parametrize("step", [0, -5])
def test_step_not_positive(tmp_path, capsys, step):
    config = base_config()
    config["grids"]["intersection"]["z"]["step"] = step
    code, err, out = run(tmp_path, config, "intersection-1", capsys=capsys)
    assert code == 2 and "grids.intersection.z.step" in err and str(step) in err
    assert_nothing_written(out)


def test_more_samples_than_the_grid(tmp_path, capsys):
    code, err, out = run(tmp_path, base_config(), "soccer", "--n", "6000", capsys=capsys)
    assert code == 2 and "6000" in err and "5712" in err
    assert_nothing_written(out)


def test_missing_scene_file(tmp_path, capsys):
    config = with_user_scene(tmp_path)
    (tmp_path / "labels.png").unlink()
    code, err, out = run(tmp_path, config, "mine", capsys=capsys)
    assert code == 2 and "labels.png" in err
    assert_nothing_written(out)


def test_mis_sized_scene_files(tmp_path, capsys):
    config = with_user_scene(tmp_path)
    cv2.imwrite(str(tmp_path / "labels.png"), np.zeros((100, 300), np.uint8))
    code, err, out = run(tmp_path, config, "mine", capsys=capsys)
    assert code == 2 and "scene.png" in err and "labels.png" in err
    assert_nothing_written(out)


def test_unknown_palette_colour(tmp_path, capsys):
    labels = np.zeros((200, 300, 3), np.uint8)
    labels[80:120] = (128, 128, 128)
    labels[5, 7] = (1, 2, 250)  # BGR on disk: RGB (250, 2, 1)
    config = with_user_scene(tmp_path, semantic=labels, palette={0: [0, 0, 0], 1: [128, 128, 128]})
    code, err, out = run(tmp_path, config, "mine", capsys=capsys)
    assert code == 2 and "labels.png" in err and "250" in err
    assert_nothing_written(out)


def test_grid_leaving_the_scene(tmp_path, capsys):
    config = with_user_scene(tmp_path)
    config["grids"]["small"]["x"] = {"start": 100, "stop": 400, "step": 100}
    code, err, out = run(tmp_path, config, "mine", capsys=capsys)
    assert code == 2 and "datasets.mine" in err and "x range" in err and "400" in err
    assert_nothing_written(out)


def test_unknown_dataset(tmp_path, capsys):
    code, err, out = run(tmp_path, base_config(), "intersection-9", capsys=capsys)
    assert code == 2 and "intersection-9" in err
    assert_nothing_written(out)


def test_the_default_metric_is_the_documented_reading():
    from synthcal.config import DEFAULT_READING, METRICS, READINGS

    # iou, not iou_weighted: an all-background estimate scores ~53 of iou_weighted (docs/benchmark.md).
    assert DEFAULT_READING == "iou" and DEFAULT_READING in READINGS
    assert build_parser()._subparsers._group_actions[0].choices["table"]._option_string_actions["--metric"].choices \
        == METRICS
    assert build_parser().parse_args(["table", "results"]).metric == DEFAULT_READING
    assert build_parser().parse_args(["plot", "results", "-o", "figures"]).metric == DEFAULT_READING
