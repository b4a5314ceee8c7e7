"""The same-layout mixed dictionaries of intersection-1 (issue 27): second stores, labels, blank templates,
and the existing stores left as they were."""

import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import zarr

from synthcal.cli import main
from synthcal.config import ConfigError, load_config
from synthcal.eval.harness import execute_run, expand_runs
from synthcal.generate.pipeline import generate_dataset
from synthcal.generate.splits import draw_splits
from synthcal.scenes import build_scene
from synthcal.store import open_store
from synthcal.store.splits import STORED_SPLITS, read_mixed_dictionary, read_split_indices, resolve_mixed_dictionary

ROOT = Path(__file__).resolve().parents[2]
INTERSECTIONS = [f"intersection-{k}" for k in range(1, 6)]
# SHA-256 of the JSON {key: sha256 of the array's bytes} over the five paper scenes' and soccer's pixels and
# every array (splits and mixed-1 included) of intersection-1's smoke store, its splits drawn beside the
# other four: computed on main at a3ffd61, before intersection-1's family and the same_pool_as key existed,
# under each OpenCV version (the RGB warp's bytes differ between them, tests/generate/test_pipeline.py).
MAIN_DIGEST = {"5.0.0": "e7637484cf6b509bdfeb127fb84b3acbc993769b62c6417d439155ffe2deac4a",
               "5.1.0": "caa6e929788d675d441bf7cd3f12b21b5f86d60a3df6fa11f883a33aaf67f89b"}


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "datasets.yaml")


@pytest.fixture(scope="module")
def data(smoke_stores, tmp_path_factory, config) -> Path:
    """intersection-1 and its second stores for mixed-blank-1 and mixed-heading-90 with their sources, splits drawn."""
    out = tmp_path_factory.mktemp("same-layout")
    smoke_stores.copy(INTERSECTIONS, out)
    for name in ("blank-1", "intersection-1-blank", "heading-90", "intersection-1-turn90"):
        generate_dataset(config.resolve(name, "smoke"), out, workers=1, progress=False)
    for name in ("intersection-1", "blank-1", "heading-90"):
        draw_splits(out / f"{name}.zarr")
    return out


def _walk(group, prefix=""):
    for key, array in sorted(group.arrays()):
        yield prefix + key, array
    for key, sub in sorted(group.groups()):
        yield from _walk(sub, prefix + key + "/")


def test_existing_scenes_stores_and_splits_are_as_on_main(data):
    digests = {}
    for name in [*INTERSECTIONS, "soccer"]:
        scene = build_scene(name)
        digests["scene:" + name] = hashlib.sha256(scene.image.tobytes() + scene.semantic.tobytes()).hexdigest()
    group = zarr.open_group(zarr.storage.LocalStore(data / "intersection-1.zarr", read_only=True), mode="r")
    for key, array in _walk(group):
        digests["store:" + key] = hashlib.sha256(np.ascontiguousarray(array[...]).tobytes()).hexdigest()
    assert any(key.endswith("mixed_dictionary/index") for key in digests)
    assert cv2.__version__ in MAIN_DIGEST, f"no digest recorded for OpenCV {cv2.__version__}"
    assert hashlib.sha256(json.dumps(digests, sort_keys=True).encode()).hexdigest() == MAIN_DIGEST[cv2.__version__]


def test_a_second_store_holds_intersection_1s_pool_and_splits_bit_for_bit(data):
    own, second = open_store(data / "intersection-1.zarr"), open_store(data / "blank-1.zarr")
    for key in ("image", "semantic", "homography", "camera/pan_deg", "camera/grid_index"):
        np.testing.assert_array_equal(np.asarray(second[key][...]), np.asarray(own[key][...]), err_msg=key)
    for seed in (0, 4):
        for split in STORED_SPLITS:
            np.testing.assert_array_equal(read_split_indices(data / "blank-1.zarr", split, seed),
                                          read_split_indices(data / "intersection-1.zarr", split, seed))
    assert second.attrs["config_hash"] != own.attrs["config_hash"]  # another dataset, recorded as such
    assert "same_pool_as" in second.attrs["pool_seed"]["rule"]
    # the turned source draws its own cameras: no template shares a test image's pool
    turned = np.asarray(open_store(data / "intersection-1-turn90.zarr")["camera/grid_index"][...])
    assert not np.array_equal(turned, np.asarray(own["camera/grid_index"][...]))


def test_blank_templates_are_blank_with_real_grid_cameras(data, config):
    templates = resolve_mixed_dictionary(data / "blank-1.zarr", 0)
    assert read_mixed_dictionary(data / "blank-1.zarr", 0).sources == ("intersection-1-blank",)
    assert len(templates["semantic"]) == config.resolve("blank-1", "smoke").splits.dictionary
    assert not templates["semantic"].any()
    # their cameras are the grid's, as intersection-1's are: the same pose prior
    source = open_store(data / "intersection-1-blank.zarr")
    pans = np.asarray(source["camera/pan_deg"][...])[templates["index"]]
    assert set(pans.tolist()) <= set(range(-180, 180, 15))
    assert np.all(np.isfinite(templates["homography"])) and np.all(templates["homography"][:, 2, 2] != 0)


def test_the_new_labels_resolve_in_datasets_and_bench(data, tmp_path, capsys):
    assert main(["datasets", "--profile", "quick"]) == 0
    out = capsys.readouterr().out
    for label in ("mixed-family-1", "mixed-heading-0", "mixed-heading-15", "mixed-heading-45", "mixed-heading-90",
                  "mixed-blank-1", "mixed-1 "):
        assert f"\n{label}" in out, label
    assert "intersection-1-turn90" in out and "intersection-1d" in out
    runs = expand_runs(data, ["mixed-blank-1", "mixed-heading-90"], ["template"], [0])
    assert [(r.mixed, Path(r.store).name) for r in runs] == [(True, "blank-1.zarr"), (True, "heading-90.zarr")]
    record = json.loads((execute_run(runs[0], tmp_path, device="cpu") / "run.json").read_text())
    assert record["status"] == "ok" and record["run"]["dataset"] == "mixed-blank-1"


def test_same_pool_as_must_match_its_pool(tmp_path):
    bad = tmp_path / "datasets.yaml"
    bad.write_text("datasets:\n  twin: {scene: intersection-2, grid: intersection, pool_size: 200000, "
                   "same_pool_as: intersection-1}\n")
    with pytest.raises(ConfigError, match=r"datasets\.twin\.same_pool_as: scene differs"):
        load_config(bad).resolve("twin", "smoke")
    bad.write_text("datasets:\n  twin: {scene: intersection-1, grid: intersection, pool_size: 9, "
                   "same_pool_as: nowhere}\n")
    with pytest.raises(ConfigError, match=r"datasets\.twin\.same_pool_as: must be another dataset"):
        load_config(bad)
