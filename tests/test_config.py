"""config.py imports nothing of the generator (tests/test_architecture.py), so it records the
generator facts it validates with; they must agree with the generator."""

from synthcal.config import BUILTIN_SCENE_NAMES, POSE_SET_SPLITS
from synthcal.generate.worldcup import pose_partition
from synthcal.scenes import BUILTIN_SCENES


def test_builtin_scene_names_match_the_scenes():
    assert BUILTIN_SCENE_NAMES == tuple(BUILTIN_SCENES)


def test_pose_set_sizes_match_the_annotations():
    for name, sizes in POSE_SET_SPLITS.items():
        assert {part: len(index) for part, index in pose_partition(name).items()} == sizes
