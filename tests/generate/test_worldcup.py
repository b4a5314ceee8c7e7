"""World Cup 2014 real poses: conversion to the soccer frame, the dataset, its splits."""

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from synthcal.cli import main
from synthcal.config import ConfigError, SplitSizes, load_config
from synthcal.data import load_split
from synthcal.generate.camera import homography
from synthcal.generate.pipeline import load_scene
from synthcal.generate.splits import SplitsResized, draw_indices, draw_splits
from synthcal.generate.worldcup import (
    METRES_PER_YARD,
    bird_eye_to_pitch,
    camera_fields,
    convert_homographies,
    frame_scaling,
    load_worldcup_poses,
)
from synthcal.scenes import soccer
from synthcal.store import CAMERA_FIELDS, open_store, read_samples
from synthcal.store.splits import SplitError, dictionary_is_mixed, read_split_indices

ROOT = Path(__file__).resolve().parents[2]
FRAME_16 = Path(__file__).resolve().parents[3] / "shared/data/wc14/16.jpg"
SEEDS = (0, 1, 2, 3, 4)


def project(H: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) points through one homography → (N, 2) pixels and (N,) third coordinates."""
    q = np.c_[points, np.ones(len(points))] @ H.T
    return q[:, :2] / q[:, 2:], q[:, 2]


def test_pose_files():
    poses = load_worldcup_poses()
    assert len(poses.image_names) == 395 and poses.homographies.shape == (395, 3, 3)
    assert poses.partition == {"train": (0, 209), "test": (209, 395)}
    assert poses.image_names[15] == "16.jpg" and poses.image_names[209] == "1.jpg"


@pytest.mark.parametrize("image_size", [(1280, 720), (256, 144), (64, 36)])
def test_conversion_agrees_with_the_pitch_geometry(image_size):
    """Scene pitch point (x_m, y_m) → the original H at (x_m, 68 − y_m) / 0.9144 yards.

    The yard frame's second axis starts at the far touchline (checked on 16.jpg);
    the scene's y_m grows away from the camera, hence 68 − y_m.
    """
    poses = load_worldcup_poses()
    converted = convert_homographies(poses.homographies, image_size)
    pitch = np.array([[0, 0], [105, 0], [0, 68], [105, 68], [52.5, 34]], np.float64)
    pixels = np.stack(soccer.pitch_to_pixel(pitch[:, 0], pitch[:, 1]), axis=-1)
    yards = np.c_[pitch[:, 0], 68.0 - pitch[:, 1]] / METRES_PER_YARD
    S = frame_scaling(image_size)
    for H_yards, H in zip(poses.homographies, converted, strict=True):
        got, depth = project(H, pixels)
        want, _ = project(S @ H_yards, yards)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-6 * image_size[0])
        assert depth[-1] > 0, "the centre spot is in front of every broadcast camera"
    np.testing.assert_allclose(np.stack(bird_eye_to_pitch(*pixels.T), -1), pitch, atol=1e-9)


def test_pixel_centre_scaling():
    S = frame_scaling((256, 144))
    corners = np.array([[-0.5, -0.5], [1279.5, 719.5], [639.5, 359.5]])
    np.testing.assert_allclose(project(S, corners)[0], [[-0.5, -0.5], [255.5, 143.5], [127.5, 71.5]])


def test_fitted_cameras_match_the_published_statistics():
    """Fitted in the scene frame, the cameras sit behind the near touchline, ~17 m up.

    SCCvSD's statistics of these 395 cameras: centre mean (52.4, −45.2, 16.8) m,
    std (2.2, 9.4, 2.9), range x 45..61, y −66..−17, z 10..23; focal mean 3018 px
    at 1280 wide. A wrong axis or flip would put them beyond the far touchline, or
    looking away from the pitch.
    """
    poses = load_worldcup_poses()
    H = convert_homographies(poses.homographies, (1280, 720))
    fields = camera_fields(H, load_scene(load_config(ROOT / "datasets.yaml").resolve("worldcup2014")), (1280, 720), 1280)
    x_m, y_m = bird_eye_to_pitch(fields["x"], fields["y"])
    np.testing.assert_allclose([x_m.mean(), y_m.mean(), fields["z"].mean() / soccer.PPM], [52.4, -45.2, 16.8], atol=4)
    assert 40 < x_m.min() and x_m.max() < 65 and -75 < y_m.min() and y_m.max() < -10
    assert abs(fields["focal_px"].mean() - 3018) < 150
    assert abs(np.median(fields["pan_deg"])) < 5 and np.all(fields["tilt_deg"] < 0)
    assert np.median(fields["rms_px"]) < 5 and np.all(fields["rms_px"] < 30)
    # Re-synthesised from the fitted values (no roll), the camera sees what H sees.
    fitted = homography(fields["pan_deg"] + soccer.HEADING_DEG, fields["tilt_deg"], fields["focal_px"],
                        np.c_[fields["x"], fields["y"], fields["z"]], (1280, 720))
    centre = np.array([[639.5, 359.5]])
    errors = [np.linalg.norm(project(a, project(np.linalg.inv(b), centre)[0])[0] - centre)
              for a, b in zip(fitted, H, strict=True)]
    assert np.median(errors) < 10


@pytest.mark.skipif(not FRAME_16.is_file(), reason=f"{FRAME_16} not available")
def test_pitch_lines_land_on_frame_16():
    poses = load_worldcup_poses()
    k = poses.image_names.index("16.jpg")
    H = convert_homographies(poses.homographies[k:k + 1], (1280, 720))[0]
    frame = cv2.cvtColor(cv2.imread(str(FRAME_16)), cv2.COLOR_BGR2HSV)
    frame = cv2.resize(frame, (1280, 720), interpolation=cv2.INTER_NEAREST)
    white = (frame[..., 2] > 170) & (frame[..., 1] < 60)
    distance = cv2.distanceTransform((~white).astype(np.uint8), cv2.DIST_L2, 5)
    points, segments = soccer.pitch_model()  # metres, y from the far touchline (the yard frame's axes)
    t = np.linspace(0, 1, 20)[:, None, None]
    samples = (points[segments[:, 0]] * (1 - t) + points[segments[:, 1]] * t).reshape(-1, 2)
    pixels = np.stack(soccer.pitch_to_pixel(samples[:, 0], 68.0 - samples[:, 1]), axis=-1)
    xy, depth = project(H, pixels)
    inside = (depth > 0) & (xy[:, 0] >= 0) & (xy[:, 0] <= 1279) & (xy[:, 1] >= 0) & (xy[:, 1] <= 719)
    assert inside.sum() > 300
    d = distance[np.round(xy[inside, 1]).astype(int), np.round(xy[inside, 0]).astype(int)]
    assert d.mean() < 4.0 and np.median(d) <= 2.0, f"mean {d.mean():.1f} px, median {np.median(d):.1f} px"


@pytest.fixture(scope="module")
def stores(smoke_stores, tmp_path_factory) -> dict[str, Path]:
    paths = smoke_stores.copy(["soccer", "worldcup2014"], tmp_path_factory.mktemp("worldcup"))
    draw_splits(paths["worldcup2014"])
    return paths


def test_store_holds_the_converted_poses(stores):
    config = load_config(ROOT / "datasets.yaml")
    spec = config.resolve("worldcup2014", "smoke")
    group = open_store(stores["worldcup2014"])
    assert group["image"].shape == (395, 36, 64, 3) and group.attrs["grid"] is None
    assert group.attrs["poses"]["partition"] == {"train": [0, 209], "test": [209, 395]}
    H = group["homography"][:]
    np.testing.assert_allclose(H, convert_homographies(load_worldcup_poses().homographies, (64, 36)))
    assert np.all(group["camera/grid_index"][:] == -1)
    camera = {name: group[f"camera/{name}"][:] for name in CAMERA_FIELDS}
    assert np.median(camera["focal_px"]) == pytest.approx(3018 / 5, rel=0.1)  # at the reference width 256
    assert np.all(camera["tilt_deg"] < 0) and abs(np.median(camera["pan_deg"])) < 5
    assert np.median(camera["z"]) / soccer.PPM == pytest.approx(16.8, abs=3)
    assert group["image"][:, -1].mean() > 40, "the bottom row of a broadcast view shows the ground"
    assert spec.config_hash() == group.attrs["config_hash"]


def test_validation_is_carved_from_train_val_and_test_is_the_papers(stores):
    store = stores["worldcup2014"]
    validations = []
    for seed in SEEDS:
        train, validation = (read_split_indices(store, split, seed) for split in ("train", "validation"))
        np.testing.assert_array_equal(read_split_indices(store, "test", seed), np.arange(209, 395))
        assert len(validation) == 42 and len(np.intersect1d(train, validation)) == 0  # 20 % of train_val
        np.testing.assert_array_equal(np.union1d(train, validation), np.arange(209))
        validations.append(validation)
    assert len({tuple(v) for v in validations}) == len(SEEDS), "each seed draws its own validation set"
    # Drawn from the seed alone: a second draw of seed 3 gives the same sets.
    again = draw_indices(395, SplitSizes(train=209, test=186, validation=42), open_store(store).attrs["seed"], 3,
                         {"train": np.arange(209), "test": np.arange(209, 395)}, own_dictionary=False)
    np.testing.assert_array_equal(again["validation"], validations[3])
    np.testing.assert_array_equal(again["train"], read_split_indices(store, "train", 3))


def test_split_adds_validation_to_a_store_drawn_before_it(stores, tmp_path, capsys):
    import shutil

    for path in stores.values():
        shutil.copytree(path, tmp_path / path.name)
    store = tmp_path / "worldcup2014.zarr"
    with pytest.warns(SplitsResized):  # as drawn before validation sets existed
        draw_splits(store, seeds=[0], sizes=SplitSizes(train=209, test=186, dictionary=12, validation=0))
    np.testing.assert_array_equal(read_split_indices(store, "train", 0), np.arange(209))
    with pytest.raises(SplitError, match=f"{store}: splits/seed-0/validation: .*`synthcal split {store} --validation N`"):
        read_split_indices(store, "validation", 0)
    with pytest.warns(SplitsResized, match=r"replacing its splits \(train 209, test 186, .*\) with train 167, test 186"):
        assert main(["split", str(store), "--seeds", "0", "--validation", "42"]) in (0, None)
    fresh = stores["worldcup2014"]  # drawn with validation from the start: the same sets
    for split in ("train", "validation"):
        np.testing.assert_array_equal(read_split_indices(store, split, 0), read_split_indices(fresh, split, 0))
    np.testing.assert_array_equal(read_split_indices(store, "test", 0), np.arange(209, 395))
    with pytest.raises(SplitError, match=r"validation 209 samples asked for, but the given train part holds 209"):
        draw_splits(store, seeds=[0], sizes=SplitSizes(train=209, test=186, dictionary=12, validation=209))


def test_dictionary_comes_from_the_soccer_pool(stores):
    store = stores["worldcup2014"]
    dictionary = load_split(store, "dictionary", 2)  # mixed by default: there is no own dictionary
    assert dictionary.sources == ("soccer",) and len(dictionary) == 12
    assert dictionary_is_mixed(open_store(store), store) and not dictionary_is_mixed(open_store(stores["soccer"]),
                                                                                      stores["soccer"])
    # what a run asks for wins over the store's default, both ways
    assert not dictionary_is_mixed(open_store(store), store, False)
    assert dictionary_is_mixed(open_store(stores["soccer"]), stores["soccer"], True)
    direct = read_samples(open_store(stores["soccer"]), dictionary.indices)
    np.testing.assert_array_equal(dictionary.homographies, direct["homography"])
    with pytest.raises(SplitError, match=r"splits/seed-2/dictionary: dataset has no own dictionary"):
        load_split(store, "dictionary", 2, mixed=False)
    test = load_split(store, "test", 2)
    assert len(test) == 186 and test.scene.name == "soccer"


def test_paper_dictionary_is_the_whole_soccer_pool(stores, tmp_path):
    import shutil

    for path in stores.values():
        shutil.copytree(path, tmp_path / path.name)
    store = tmp_path / "worldcup2014.zarr"

    with pytest.warns(SplitsResized, match="mixed dictionary 12\\) with .*mixed dictionary 48"):
        draw_splits(store, seeds=[0], sizes=SplitSizes(train=209, test=186, dictionary=48))
    np.testing.assert_array_equal(load_split(store, "dictionary", 0).indices, np.arange(48))
    with pytest.raises(SplitError, match=r"worldcup2014.zarr: mixed dictionary of 49 templates.*soccer N = 48"):
        draw_splits(store, seeds=[0], sizes=SplitSizes(train=209, test=186, dictionary=49))
    with pytest.raises(SplitError, match=r"worldcup2014.zarr: splits.train: the poses fix train at 209 samples"):
        draw_splits(store, seeds=[0], sizes=SplitSizes(train=100, test=186, dictionary=12))


def write_config(tmp_path: Path, **dataset) -> Path:
    raw = yaml.safe_load((ROOT / "datasets.yaml").read_text())
    # The user's file layers over the packaged one (mappings merge): null removes each packaged
    # key the entry leaves out, so that the entry is exactly ``dataset``.
    raw["datasets"]["worldcup2014"] = dict.fromkeys(raw["datasets"]["worldcup2014"]) | dataset
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize("dataset, message", [
    ({"scene": "soccer", "grid": "soccer", "poses": "worldcup2014", "dictionary_from": "soccer"},
     "give exactly one of grid: .* or poses: .*, got both"),
    ({"scene": "soccer"}, "got neither"),
    ({"scene": "soccer", "poses": "worldcup2014"}, "dictionary_from: is required"),
    ({"scene": "soccer", "poses": "worldcup2014", "dictionary_from": "soccer", "pool_size": 10},
     "fix the pool; leave pool_size out"),
    ({"scene": "soccer", "poses": "euro2016", "dictionary_from": "soccer"}, "datasets.worldcup2014.poses"),
    ({"scene": "soccer", "poses": "worldcup2014", "dictionary_from": "nowhere"},
     "datasets.worldcup2014.dictionary_from: 'nowhere' must be another dataset"),
    ({"scene": "intersection-1", "poses": "worldcup2014", "dictionary_from": "soccer"},
     "datasets.worldcup2014.scene: the poses 'worldcup2014' are World Cup broadcast cameras"),
])
def test_config_errors(tmp_path, dataset, message):
    path = write_config(tmp_path, **dataset)
    with pytest.raises(ConfigError, match=message) as error:
        load_config(path)
    assert str(path) in str(error.value)


def test_fixed_split_sizes_in_config(tmp_path):
    path = write_config(tmp_path, scene="soccer", poses="worldcup2014", dictionary_from="soccer",
                        splits={"train": 100})
    with pytest.raises(ConfigError, match=r"datasets.worldcup2014.splits.train: .* fix train at 209 \(value 100\)"):
        load_config(path).resolve("worldcup2014")
    config = load_config(ROOT / "datasets.yaml")
    with pytest.raises(ConfigError, match="pool_size: the poses 'worldcup2014' fix the pool size"):
        config.resolve("worldcup2014", "smoke", pool_size=10)
    spec = config.resolve("worldcup2014", "smoke")
    assert (spec.pool_size, spec.splits.train, spec.splits.test, spec.splits.validation) == (395, 209, 186, 42)
    path = write_config(tmp_path, scene="soccer", poses="worldcup2014", dictionary_from="soccer",
                        splits={"validation": 30})
    assert load_config(path).resolve("worldcup2014", "smoke").splits.validation == 30
    path = write_config(tmp_path, scene="soccer", poses="worldcup2014", dictionary_from="soccer",
                        splits={"validation": 209})
    with pytest.raises(ConfigError, match=r"datasets.worldcup2014.splits.validation: .* 209 train .* \(value 209\)"):
        load_config(path).resolve("worldcup2014")
    assert spec.mixed_sources == ("soccer",) and not spec.own_dictionary
    assert config.resolve("worldcup2014", "paper").splits.dictionary == 4500


def test_mixed_dictionaries_config(tmp_path):
    raw = yaml.safe_load((ROOT / "datasets.yaml").read_text())
    assert raw["mixed_dictionaries"]["intersection-5"] == [f"intersection-{k}" for k in (1, 2, 3, 4)]
    raw["mixed_dictionaries"]["intersection-2"] = ["intersection-2"]
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(ConfigError, match=r"mixed_dictionaries.intersection-2: 'intersection-2' must be another"):
        load_config(path)


def test_worldcup_stats_cli(capsys, tmp_path):
    montage = tmp_path / "poses.png"
    assert main(["worldcup-stats", "--config", str(ROOT / "datasets.yaml"), "--montage", str(montage),
                 "--count", "2"]) == 0
    out = capsys.readouterr().out
    assert "of 395" in out and montage.is_file()


def test_harness_selection_reads_world_cups_validation(stores, tmp_path):
    import shutil

    from synthcal.data.loaders import read_scene
    from synthcal.eval.harness import expand_runs
    from synthcal.eval.isolation import load_run_split

    config = load_config(ROOT / "datasets.yaml")
    settings = {**config.training("smoke").settings(), "select": {"learning_rate": [1e-4, 1e-3]}}

    def run_of(folder: Path):
        (run,) = expand_runs(folder, ["worldcup2014"], ["proposed"], [0], "smoke", settings,
                             segmentations=["ground-truth"], device="cpu", limits=config.split_caps("smoke"))
        return run

    run = run_of(stores["worldcup2014"].parent)
    assert run.limits == {"dictionary": 12, "train": 167, "validation": 4}  # smoke caps validation, never train
    scene = read_scene(run.store)
    train, validation, test = (load_run_split(run, split, scene) for split in ("train", "validation", "test"))
    assert (len(train), len(validation), len(test)) == (167, 4, 186)
    assert not set(validation.indices) & (set(train.indices) | set(test.indices))
    # Runs on the train set of before validation existed (all 209) keep other ids: never reused for these.
    for path in stores.values():
        shutil.copytree(path, tmp_path / path.name)
    with pytest.warns(SplitsResized):
        draw_splits(tmp_path / "worldcup2014.zarr", sizes=SplitSizes(train=209, test=186, dictionary=12))
    before = run_of(tmp_path)
    assert before.limits == {"dictionary": 12, "validation": 4} and before.id != run.id
