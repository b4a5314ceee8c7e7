"""``synthcal import``: real annotated frames as a store (SPEC §4, *Real frames*).

The frames are the soccer scene rendered through bundled World Cup 2014
annotations at 320 × 180 (their matrices scaled to that frame size), written in
the release's layout; the store is the smoke profile's 64 × 36.
"""

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from synthcal.cli import main
from synthcal.generate.camera import orient_homography
from synthcal.generate.render import render_image, render_semantic
from synthcal.generate.worldcup import (
    METRES_PER_YARD,
    WC14_FRAME,
    bird_eye_to_yards,
    convert_homographies,
    load_worldcup_poses,
)
from synthcal.scenes import build_scene, soccer
from synthcal.store import open_store, read_samples

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ["--config", str(ROOT / "datasets.yaml")]
FRAME = (320, 180)
IMAGE = (64, 36)  # the smoke profile's
PER_PART = 3


def frame_matrix(k: int) -> np.ndarray:
    """Annotation ``k`` (yards → 1280 × 720) as yards → FRAME pixels, by the pixel-centre rule."""
    s = FRAME[0] / WC14_FRAME[0]
    return np.array([[s, 0, 0.5 * s - 0.5], [0, s, 0.5 * s - 0.5], [0, 0, 1.0]]) @ load_worldcup_poses().homographies[k]


def render_frame(scene, bird_to_frame: np.ndarray) -> np.ndarray:
    """The scene's RGB as a camera with this bird's-eye → frame homography sees it (BGR, for imwrite)."""
    return render_image(scene.image, orient_homography(bird_to_frame, FRAME), FRAME)[..., ::-1]


@pytest.fixture(scope="module")
def wc14_folder(tmp_path_factory) -> tuple[Path, list[int]]:
    """A WC14-layout folder of 3 + 3 frames, and the pool index of each frame in store order."""
    folder = tmp_path_factory.mktemp("release") / "wc14"
    poses, scene = load_worldcup_poses(), build_scene("soccer")
    order = []
    for part, sub in (("train", "train_val"), ("test", "test")):
        (folder / sub).mkdir(parents=True)
        first = poses.partition[part][0]
        for k in (first + 9, first + 1, first):  # written out of order: 10.jpg must follow 2.jpg
            stem = poses.image_names[k].removesuffix(".jpg")
            cv2.imwrite(str(folder / sub / f"{stem}.jpg"), render_frame(scene, frame_matrix(k) @ bird_eye_to_yards()))
            np.savetxt(folder / sub / f"{stem}.homographyMatrix", frame_matrix(k))
            (folder / sub / f"{stem}_grass_gt.mat").write_bytes(b"ignored")
        order += [first, first + 1, first + 9]
    return folder, order


def import_cli(folder: Path, out: Path, *extra: str) -> int:
    return main(["import", str(folder), "--scene", "soccer", "--out", str(out), "--profile", "smoke", *CONFIG,
                 *(extra or ("--layout", "wc14")), ])


@pytest.fixture(scope="module")
def imported(wc14_folder, smoke_stores, tmp_path_factory) -> Path:
    """The imported store, its splits drawn, beside a copy of the synthetic soccer pool."""
    out = tmp_path_factory.mktemp("data")
    smoke_stores.copy(["soccer"], out)
    assert import_cli(wc14_folder[0], out) == 0
    assert main(["split", str(out / "wc14.zarr"), "--seeds", "0-1"]) == 0
    return out / "wc14.zarr"


def test_homography_maps_pitch_points_as_the_annotation(imported, wc14_folder):
    # Pitch points in metres (scene convention: y away from the camera) → yards by
    # hand, through each frame's matrix with OpenCV, scaled to the image by hand.
    metres = np.stack(np.meshgrid(np.linspace(0, 105, 22), np.linspace(0, 68, 18)), axis=-1).reshape(-1, 2)
    yards = np.c_[metres[:, 0], soccer.PITCH_WIDTH_M - metres[:, 1]] / METRES_PER_YARD
    bird = np.stack(soccer.pitch_to_pixel(metres[:, 0], metres[:, 1]), axis=-1)
    H = open_store(imported)["homography"][:]
    for k, pool_index in enumerate(wc14_folder[1]):
        in_frame = cv2.perspectiveTransform(yards[None], frame_matrix(pool_index))[0]
        expected = (in_frame + 0.5) * np.array(IMAGE) / np.array(FRAME) - 0.5
        got = cv2.perspectiveTransform(bird[None], H[k])[0]
        visible = np.all((expected > -0.5) & (expected < np.array(IMAGE) - 0.5), axis=1)
        assert visible.sum() >= 20
        np.testing.assert_allclose(got[visible], expected[visible], atol=1e-6)
        depth = np.c_[bird, np.ones(len(bird))] @ H[k][2]
        assert np.all(depth[visible] > 0), "the third coordinate is the depth"


def test_homography_equals_the_worldcup2014_conversion(imported, wc14_folder):
    expected = convert_homographies(load_worldcup_poses().homographies[wc14_folder[1]], IMAGE)
    np.testing.assert_allclose(open_store(imported)["homography"][:], expected, rtol=1e-9, atol=1e-12)


def test_image_is_the_frame_and_semantic_the_render(imported, wc14_folder):
    group = open_store(imported)
    samples = read_samples(group, np.arange(2 * PER_PART))
    scene = build_scene("soccer")
    poses = load_worldcup_poses()
    for k, pool_index in enumerate(wc14_folder[1]):
        sub = "train_val" if k < PER_PART else "test"
        frame = cv2.imread(str(wc14_folder[0] / sub / poses.image_names[pool_index]))
        resized = cv2.resize(frame, IMAGE, interpolation=cv2.INTER_AREA)[..., ::-1]
        np.testing.assert_array_equal(samples["image"][k], resized)
        view = render_semantic(scene.semantic, samples["homography"][k], IMAGE)
        np.testing.assert_array_equal(samples["semantic"][k], view)
        assert (view > 0).mean() > 0.3
    attrs = group.attrs
    assert attrs["poses"]["partition"] == {"train": [0, PER_PART], "test": [PER_PART, 2 * PER_PART]}
    assert attrs["poses"]["image_names"][:PER_PART] == ["train_val/1.jpg", "train_val/2.jpg", "train_val/10.jpg"]
    assert np.all(group["camera/grid_index"][:] == -1) and np.all(group["camera/tilt_deg"][:] < 0)


def test_verify_show_and_bench_work_unchanged(imported, tmp_path, capsys):
    assert main(["verify", str(imported)]) == 0
    assert main(["show", str(imported), "-o", str(tmp_path / "show.png")]) == 0
    assert main(["bench", "--data", str(imported.parent), "--datasets", "wc14", "--estimator", "identity",
                 "--seeds", "0-1", "--results", str(tmp_path / "results"), "--quiet", *CONFIG]) == 0
    out = capsys.readouterr().out
    assert f"OK {imported}" in out and "train 3 of 3, test 3 of 3, dictionary 12 of 12" in out
    assert "2 runs (0 failed)" in out


def test_same_folder_gives_the_same_bytes(wc14_folder, tmp_path, capsys):
    stores = []
    for name in ("a", "b"):
        assert import_cli(wc14_folder[0], tmp_path / name) == 0
        stores.append(tmp_path / name / "wc14.zarr")
    files = [sorted(p.relative_to(s) for p in s.rglob("*") if p.is_file()) for s in stores]
    assert files[0] == files[1] and len(files[0]) > 20
    for relative in files[0]:
        assert (stores[0] / relative).read_bytes() == (stores[1] / relative).read_bytes(), relative
    assert import_cli(wc14_folder[0], tmp_path / "a") == 0
    assert "already imported" in capsys.readouterr().out


def test_plain_layout(wc14_folder, smoke_stores, tmp_path):
    # Bird's-eye → frame matrices of any scale and sign, one frame at another size.
    folder, poses, scene = tmp_path / "plain", load_worldcup_poses(), build_scene("soccer")
    folder.mkdir()
    expected = {}
    for n, pool_index in enumerate(wc14_folder[1] + [250]):
        bird_to_frame = frame_matrix(pool_index) @ bird_eye_to_yards() * (-3.0 if n % 2 else 0.5)
        frame_size = FRAME
        if n == 0:  # half the size: the matrix scales with the frame
            frame_size = (160, 90)
            bird_to_frame = np.array([[0.5, 0, -0.25], [0, 0.5, -0.25], [0, 0, 1]]) @ bird_to_frame
        image = render_image(scene.image, orient_homography(bird_to_frame, frame_size), frame_size)
        cv2.imwrite(str(folder / f"view{n}.png"), image[..., ::-1])
        np.savetxt(folder / f"view{n}.homography.txt", bird_to_frame)
        expected[f"view{n}.png"] = convert_homographies(poses.homographies[pool_index][None], IMAGE)[0]
    out = tmp_path / "data"
    assert import_cli(folder, out, "--layout", "plain", "--name", "real") == 0
    group = open_store(out / "real.zarr")
    names = group.attrs["poses"]["image_names"]
    assert group.attrs["poses"]["partition"] == {"train": [0, 6], "test": [6, 7]}  # round(0.2 · 7) = 1
    assert sorted(names) == sorted(expected) and names[:6] == sorted(names[:6])
    for k, name in enumerate(names):
        np.testing.assert_allclose(group["homography"][k], expected[name], rtol=1e-9, atol=1e-12)


def damage(folder: Path, case: str) -> tuple[str, str]:
    """Break the folder in one way; return the file the error must name and the reason it must give."""
    train, test = folder / "train_val", folder / "test"
    if case == "singular":
        np.savetxt(train / "2.homographyMatrix", np.array([[1.0, 2, 3], [2, 4, 6], [0, 0, 1]]))
        return str(train / "2.homographyMatrix"), "singular matrix"
    if case == "non-finite":
        (train / "2.homographyMatrix").write_text("1 0 0\n0 nan 0\n0 0 1\n")
        return str(train / "2.homographyMatrix"), "non-finite matrix"
    if case == "not 3 × 3":
        (test / "10.homographyMatrix").write_text("1 0 0\n0 1 0\n")
        return str(test / "10.homographyMatrix"), "a 2 × 3 matrix, expected 3 × 3"
    if case == "unreadable image":
        (train / "10.jpg").write_bytes(b"not a jpeg")
        return str(train / "10.jpg"), "unreadable image"
    if case == "frame without matrix":
        (test / "1.homographyMatrix").unlink()
        return str(test / "1.jpg"), "no 1.homographyMatrix"
    if case == "matrix without frame":
        (test / "2.jpg").unlink()
        return str(test / "2.homographyMatrix"), "no image 2.jpg"
    raise AssertionError(case)


@pytest.mark.parametrize("case", ["singular", "non-finite", "not 3 × 3", "unreadable image", "frame without matrix",
                                  "matrix without frame"])
def test_bad_input_is_one_line_and_writes_nothing(wc14_folder, tmp_path, capsys, case):
    folder = Path(shutil.copytree(wc14_folder[0], tmp_path / "wc14"))
    named, reason = damage(folder, case)
    assert import_cli(folder, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("synthcal: error: "), err
    assert f"{named} ({reason})" in err, err
    assert not (tmp_path / "out").exists()


def test_many_bad_files_are_counted_and_ten_named(wc14_folder, tmp_path, capsys):
    folder = Path(shutil.copytree(wc14_folder[0], tmp_path / "wc14"))
    for k in range(12):
        np.savetxt(folder / "test" / f"{100 + k}.homographyMatrix", np.eye(3))
    assert import_cli(folder, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert "12 bad frame file(s)" in err and "; and 2 more" in err and err.count("(no image") == 10


def test_wc14_needs_the_soccer_scene(wc14_folder, tmp_path, capsys):
    assert main(["import", str(wc14_folder[0]), "--layout", "wc14", "--scene", "intersection-1", "--out",
                 str(tmp_path / "out"), *CONFIG]) == 2
    assert "the wc14 layout's matrices map pitch yards" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
