"""config.py imports nothing of the generator (tests/test_architecture.py), so it records the
generator facts it validates with; they must agree with the generator."""

from pathlib import Path

from synthcal.config import BUILTIN_SCENE_NAMES, POSE_SET_SPLITS
from synthcal.generate.worldcup import pose_partition
from synthcal.scenes import BUILTIN_SCENES

ROOT = Path(__file__).resolve().parents[1]


def test_builtin_scene_names_match_the_scenes():
    assert BUILTIN_SCENE_NAMES == tuple(BUILTIN_SCENES)


def test_pose_set_sizes_match_the_annotations():
    for name, sizes in POSE_SET_SPLITS.items():
        assert {part: len(index) for part, index in pose_partition(name).items()} == sizes


def test_a_stored_configuration_validates_again(tmp_path):
    """A store keeps its spec as JSON (palette class ids become strings); reading it back must work
    under the strict number types."""
    import json

    from synthcal.config import DatasetSpec, load_config

    (tmp_path / "datasets.yaml").write_text((ROOT / "datasets.yaml").read_text().replace(
        "scenes: {}", "scenes:\n  mine: {image: a.png, semantic: b.png, palette: {0: [0, 0, 0], 1: [9, 9, 9]}}"))
    text = (tmp_path / "datasets.yaml").read_text()
    assert "mine:" in text
    config = load_config(tmp_path / "datasets.yaml")
    spec = config.resolve("soccer").model_copy(update={"user_scene": config.config.scenes["mine"]})
    stored = json.loads(json.dumps(spec.stored_config()))
    assert DatasetSpec.model_validate(stored) == spec
