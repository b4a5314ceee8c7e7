"""Scenes: built-in intersections and soccer pitch, user scenes, drawing."""

from __future__ import annotations

import hashlib
import math
from itertools import pairwise

import cv2
import numpy as np
import pytest

from synthcal.generate.camera import homography
from synthcal.generate.render import render_semantic
from synthcal.scenes import (
    BUILTIN_SCENES,
    Scene,
    SceneError,
    build_scene,
    colorize,
    draw_scene,
    load_user_scene,
    soccer,
)

INTERSECTIONS = [f"intersection-{k}" for k in range(1, 6)]

# SHA-256 of (image bytes + semantic bytes) of every built-in scene. Built-in scenes
# must be bit-identical on every machine (SPEC §5: same configuration → same
# arrays); a deliberate change of a scene's design must update its digest here.
GOLDEN = {
    "intersection-1": "a18a1249cc74846456f81d624123331d7703cfa48b3e57bf7126f833f9daa0d8",
    "intersection-2": "8d8c568ddce0f10246d4e7c166629b7a2e28faa490470143ea84a2bdc66e9d48",
    "intersection-3": "ad1342f020ec6bf28f6e02f78c9ea025c2ed020863204a828518a9482542808c",
    "intersection-4": "1bc9ebc58394d73e04c5fde76fc97d506e8d79857c0ee1b7567c9185124b4a8e",
    "intersection-5": "a869e9686598a09b4aaa4e0da44ccf7717b4e13e20ff4bc01debfc2132278fa9",
    "soccer": "fc101dc62179dffe5a71f40ffbb80e70e6a3177bfd3e5098cc4e5649bc5f86d6",
    "intersection-1a": "d75fcc9bad8f2f6722b9ecc47a0136593e5c5a25a6c3212919a68a411e7624c1",
    "intersection-1b": "b3cb49ef15e3ed8203c754b4ef5aab39f6ef8892cd91eab067c6f4acbd7a0ace",
    "intersection-1c": "a3ac4c8a4fa797a158add9d03c3b0e8efcfb38aaeac0b1991ae87d9c717a2641",
    "intersection-1d": "3bbd19857a0e73da1b3d51927d7178b5ece38909de1eedab39c9e2d86bc3d247",
    "intersection-1-turn15": "e02b15745280fbc8020c54929bfbd9f606adf3355142eb972169bdb15529a54d",
    "intersection-1-turn45": "4406e297ae6b28990be22bcbd09b24a2c858ebda5c55c7d1e15f239f0b123c0b",
    "intersection-1-turn90": "aca9d60ab2a101cc55f2520fe146cdbec695188d27d5a2f4b51640dd59530660",
    "intersection-1-blank": "30a6ae2e2d924f1f0b7dcaf219055850eff4e1e61e470feea637906f415e5f58",
}


def _digest(scene: Scene) -> str:
    return hashlib.sha256(scene.image.tobytes() + scene.semantic.tobytes()).hexdigest()


def _boundary(semantic: np.ndarray) -> int:
    """Number of 4-neighbour pixel pairs with different classes."""
    return int((semantic[1:] != semantic[:-1]).sum() + (semantic[:, 1:] != semantic[:, :-1]).sum())


def _border_runs(mask: np.ndarray) -> int:
    """Separate runs of True along the image border (closed loop)."""
    ring = np.concatenate([mask[0, :], mask[1:, -1], mask[-1, -2::-1], mask[-2:0:-1, 0]]).astype(np.int8)
    return int((np.diff(np.r_[ring, ring[:1]]) == 1).sum())


# --------------------------------------------------------------------------- built-ins


def test_builtin_names_and_unknown_name():
    family = [f"intersection-1{v}" for v in "abcd"]
    derived = [f"intersection-1-turn{a}" for a in (15, 45, 90)] + ["intersection-1-blank"]
    assert list(BUILTIN_SCENES) == INTERSECTIONS + family + ["soccer"] + derived
    assert all(isinstance(d, str) and d for d in BUILTIN_SCENES.values())
    with pytest.raises(SceneError, match="intersection-9"):
        build_scene("intersection-9")


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_builtin_deterministic_read_only_and_cached(name):
    """Built once per process (its speed is measured in benchmarks/scenes.py, not here)."""
    first = build_scene(name)
    hits = build_scene.cache_info().hits
    assert build_scene(name) is first  # cached per process
    assert build_scene.cache_info().hits == hits + 1
    second = build_scene.__wrapped__(name)  # the same build, bypassing the cache
    assert second is not first
    assert np.array_equal(first.image, second.image) and np.array_equal(first.semantic, second.semantic)
    for array in (second.image, second.semantic):
        assert not array.flags.writeable
        with pytest.raises(ValueError):
            array[0, 0] = 1


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_builtin_bit_identical_to_golden_digest(name):
    if not GOLDEN[name]:
        pytest.skip("no golden digest recorded")
    assert _digest(build_scene(name)) == GOLDEN[name], (
        f"{name} differs from its recorded digest: either the scene's design changed (update GOLDEN) or "
        f"this machine/library version draws differently, which breaks cross-machine reproducibility")


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_builtin_record(name):
    scene = build_scene(name)
    h, w = scene.semantic.shape
    assert scene.name == name
    assert scene.image.shape == (h, w, 3) and scene.image.dtype == np.uint8
    assert scene.semantic.dtype == np.uint8
    assert set(np.unique(scene.semantic)) <= {0, 1, 2, 3}
    assert len(scene.classes) == 4 and scene.classes[0] == "background"
    assert len(scene.palette) == 4 and len(set(scene.palette)) == 4
    assert all(len(c) == 3 and all(0 <= v <= 255 for v in c) for c in scene.palette)
    assert scene.pixels_per_metre == 10.0


@pytest.mark.parametrize("name", INTERSECTIONS)
def test_intersection_size_classes_and_centre(name):
    scene = build_scene(name)
    assert scene.semantic.shape == (1900, 1300)
    assert scene.classes == ("background", "road", "terrain", "bicycle path")
    fractions = np.bincount(scene.semantic.ravel(), minlength=4) / scene.semantic.size
    assert (fractions > 0.015).all(), fractions  # every class really present
    # the paper's camera grid (X 600..700, Y 900..1000) stands over the junction: roads
    # (or the roundabout's island) below, much road within 30 m
    grid_area = scene.semantic[900:1001, 600:701]
    assert (grid_area == 1).mean() > 0.9 or (name == "intersection-5" and (grid_area == 2).all())
    rows, cols = np.mgrid[0:1900, 0:1300]
    near = (cols - 650) ** 2 + (rows - 950) ** 2 < 300 ** 2
    assert (scene.semantic[near] == 1).mean() > 0.25
    # roads leave the scene on at least four sides' worth of legs
    assert _border_runs(scene.semantic == 1) >= 4
    assert _border_runs(scene.semantic == 3) >= 2


def test_intersection_complexity_rises():
    semantics = [build_scene(name).semantic for name in INTERSECTIONS]
    boundaries = [_boundary(s) for s in semantics]
    assert all(a < b for a, b in pairwise(boundaries)), boundaries
    assert boundaries[4] > 2 * boundaries[0], boundaries  # 5 is *much* more complex than 1
    # 1 and 2 are similar plain crossings: four road legs at the border, one carriageway each
    assert _border_runs(semantics[0] == 1) == 4 and _border_runs(semantics[1] == 1) == 4
    legs = [_border_runs(np.isin(s, (1, 3))) for s in semantics]
    assert legs[4] > legs[0] and legs[3] > legs[0], legs
    # islands, medians and parks: many more separate terrain regions in 5 than in 1
    terrain = [cv2.connectedComponents((s == 2).astype(np.uint8), connectivity=4)[0] - 1 for s in semantics]
    assert terrain[4] > 2 * terrain[0], terrain
    # the roundabout: the junction centre is the grass island, ringed by road
    s5 = semantics[4]
    assert s5[950, 650] == 2
    ring = [s5[int(950 + 200 * math.sin(a)), int(650 + 200 * math.cos(a))] for a in np.linspace(0, 2 * np.pi, 36)]
    assert all(v == 1 for v in ring)


@pytest.mark.parametrize("name", INTERSECTIONS)
def test_intersection_distractors_are_rgb_only(name):
    scene = build_scene(name)
    rgb, semantic = scene.image.astype(np.int16), scene.semantic
    road = semantic == 1
    # cars: strongly coloured, non-red pixels (blue, yellow, green bodies) on class-1 road
    spread = rgb.max(-1) - rgb.min(-1)
    car_paint = road & (spread > 70) & (rgb[..., 0] < rgb.max(-1))
    assert car_paint.sum() > 100, car_paint.sum()
    # shadows and tree crowns: grass much darker than grass usually is
    grass_luma = rgb[semantic == 2].mean(-1)
    assert (grass_luma < 0.6 * np.median(grass_luma)).mean() > 0.02
    # roofs, shadows, parked cars: much of the background is far from the pavement grey
    background = rgb[semantic == 0]
    far = np.abs(background - np.median(background, axis=0)).sum(-1) > 90
    assert far.mean() > 0.05, far.mean()
    # ... and none of it reaches the class map: trees, cars and roofs leave no holes
    for c in (1, 2):
        n = cv2.connectedComponents((semantic == c).astype(np.uint8), connectivity=4)[0] - 1
        assert n < 60


# --------------------------------------------------------------------------- soccer


def test_soccer_frame_and_camera():
    scene = build_scene("soccer")
    assert scene.semantic.shape == (881, 1251)
    assert scene.heading_deg == -90.0
    assert scene.camera_position == pytest.approx((625.0, 1230.0, 170.0))
    u, v = soccer.pitch_to_pixel(52.5, 34.0)
    assert (float(u), float(v)) == (625.0, 440.0)
    assert scene.semantic[440, 625] == 3  # the centre spot
    # pan 0 with the scene heading and tilt −atan(17/79) puts the pitch centre mid-image
    tilt = -math.degrees(math.atan2(17.0, 79.0))
    H = homography(np.array([0.0 + scene.heading_deg]), np.array([tilt]), np.array([600.0]),
                   np.array([scene.camera_position]), (256, 144))[0]
    p = H @ np.array([625.0, 440.0, 1.0])
    assert p[2] > 0
    assert p[:2] / p[2] == pytest.approx([127.5, 71.5], abs=0.5)
    # the far touchline is above the centre in the image, the near one below; left is x = 0
    far = H @ np.array([625.0, soccer.pitch_to_pixel(0, 68.0)[1], 1.0])
    near = H @ np.array([625.0, soccer.pitch_to_pixel(0, 0.0)[1], 1.0])
    assert far[1] / far[2] < 71.5 < near[1] / near[2]
    left = H @ np.array([soccer.pitch_to_pixel(40.0, 34.0)[0], 440.0, 1.0])
    assert left[0] / left[2] < 127.5
    view = render_semantic(scene.semantic, H, (256, 144))
    assert set(np.unique(view)) >= {1, 2, 3}


def test_soccer_lines_follow_the_line_model():
    semantic = build_scene("soccer").semantic
    points, segments = soccer.pitch_model()
    assert points.shape == (302, 2) and segments.shape == (151, 2)
    t = np.linspace(0.0, 1.0, 7)[:, None, None]
    samples = (1 - t) * points[segments[:, 0]] + t * points[segments[:, 1]]  # (7, 151, 2) metres
    u, v = soccer.pitch_to_pixel(samples[..., 0], samples[..., 1])
    on_line = semantic[np.round(v).astype(int), np.round(u).astype(int)]
    assert (on_line == 3).all()
    # lines are ~3 px wide: total class-3 area ≈ 3 px × total line length (+ the spots)
    length_px = 10 * np.linalg.norm(points[segments[:, 1]] - points[segments[:, 0]], axis=1).sum()
    assert 2.6 * length_px < (semantic == 3).sum() < 3.6 * length_px


@pytest.mark.parametrize(
    "x, y, expected",
    [
        (16.4592, 13.885164, 3),  # penalty-area corners
        (16.4592, 54.118764, 3),
        (88.541352, 13.885164, 3),
        (15.0, 15.5, 2),  # just inside the penalty area
        (18.0, 12.0, 1),  # just outside it
        (2.5, 34.0, 2),  # goal area
        (11.0, 34.0, 3),  # penalty spot
        (50.0, 36.0, 2),  # centre circle
        (50.0, 34.0 + 9.15 + 1.0, 1),  # just outside it
        (18.9, 34.0, 1),  # inside the penalty arc ("D"), not an area
        (30.0, 60.0, 1),
        (-2.0, 30.0, 0),  # beyond the goal line
        (60.0, -3.0, 0),  # beyond the near touchline
        (60.0, 71.0, 0),  # beyond the far touchline
    ],
)
def test_soccer_classes_at_known_points(x, y, expected):
    semantic = build_scene("soccer").semantic
    u, v = soccer.pitch_to_pixel(x, y)
    assert semantic[int(round(float(v))), int(round(float(u)))] == expected


# --------------------------------------------------------------------------- drawing


def test_colorize_and_draw_scene():
    scene = build_scene("intersection-1")
    coloured = colorize(scene.semantic, scene.palette)
    assert coloured.shape == scene.image.shape and coloured.dtype == np.uint8
    assert tuple(coloured[950, 650]) == scene.palette[scene.semantic[950, 650]]
    picture = draw_scene(scene)
    h, w = scene.semantic.shape
    assert picture.dtype == np.uint8 and picture.ndim == 3
    assert picture.shape[0] > h and picture.shape[1] > 2 * w
    legend = picture.shape[0] - h
    assert np.array_equal(picture[legend:, :w], scene.image)
    assert np.array_equal(picture[legend:, -w:], coloured)
    with pytest.raises(SceneError):
        colorize(np.array([[4]], np.uint8), scene.palette)


# --------------------------------------------------------------------------- user scenes


def _write(path, array):
    assert cv2.imwrite(str(path), array)
    return path


@pytest.fixture
def rgb_png(tmp_path):
    bgr = np.zeros((4, 6, 3), np.uint8)
    bgr[..., 2] = 255  # red in BGR order
    return _write(tmp_path / "rgb.png", bgr)


def test_user_scene_class_ids(tmp_path, rgb_png):
    ids = np.array([[0, 1, 2, 3, 0, 1]] * 4, np.uint8)
    scene = load_user_scene("mine", rgb_png, _write(tmp_path / "ids.png", ids), heading_deg=12.0,
                            camera_position=(1, 2, 30), pixels_per_metre=5.0)
    assert np.array_equal(scene.semantic, ids)
    assert tuple(scene.image[0, 0]) == (255, 0, 0)  # BGR file read back as RGB
    assert scene.heading_deg == 12.0 and scene.camera_position == (1.0, 2.0, 30.0)
    assert scene.pixels_per_metre == 5.0 and len(scene.classes) == 4 and len(scene.palette) == 4
    assert not scene.image.flags.writeable and not scene.semantic.flags.writeable


def test_user_scene_palette(tmp_path, rgb_png):
    palette = {0: (0, 0, 0), 1: (128, 128, 128), 2: (0, 160, 0), 3: (200, 40, 40)}
    ids = np.array([[0, 1, 2, 3, 3, 2]] * 4, np.uint8)
    colours = np.array([palette[int(i)] for i in ids.ravel()], np.uint8).reshape(4, 6, 3)
    path = _write(tmp_path / "labels.png", colours[..., ::-1])  # cv2 writes BGR
    scene = load_user_scene("mine", rgb_png, path, palette=palette, classes=("bg", "road", "grass", "bike"))
    assert np.array_equal(scene.semantic, ids)
    assert scene.classes == ("bg", "road", "grass", "bike")
    assert scene.palette[2] == (0, 160, 0)


def test_user_scene_class_id_out_of_range(tmp_path, rgb_png):
    ids = np.zeros((4, 6), np.uint8)
    ids[2, 5] = 7
    path = _write(tmp_path / "ids.png", ids)
    with pytest.raises(SceneError) as err:
        load_user_scene("mine", rgb_png, path)
    message = str(err.value)
    assert "ids.png" in message and "7" in message and "row 2" in message and "column 5" in message


def test_user_scene_unknown_colour(tmp_path, rgb_png):
    palette = {0: (0, 0, 0), 1: (128, 128, 128)}
    colours = np.zeros((4, 6, 3), np.uint8)
    colours[1, 3] = (10, 20, 30)  # RGB
    path = _write(tmp_path / "labels.png", colours[..., ::-1])
    with pytest.raises(SceneError) as err:
        load_user_scene("mine", rgb_png, path, palette=palette)
    message = str(err.value)
    assert "labels.png" in message and "(10, 20, 30)" in message and "row 1, column 3" in message


def test_user_scene_colour_map_without_palette(tmp_path, rgb_png):
    colours = np.zeros((4, 6, 3), np.uint8)
    colours[0, 0] = (0, 0, 200)
    with pytest.raises(SceneError, match="palette"):
        load_user_scene("mine", rgb_png, _write(tmp_path / "labels.png", colours))


def test_user_scene_missing_file(tmp_path, rgb_png):
    missing = tmp_path / "nope.png"
    with pytest.raises(SceneError, match="nope.png"):
        load_user_scene("mine", rgb_png, missing)
    with pytest.raises(SceneError, match="nope.png"):
        load_user_scene("mine", missing, rgb_png)
    garbage = tmp_path / "garbage.png"
    garbage.write_bytes(b"not a png")
    with pytest.raises(SceneError, match="garbage.png"):
        load_user_scene("mine", garbage, rgb_png)


def test_user_scene_size_mismatch(tmp_path, rgb_png):
    path = _write(tmp_path / "small.png", np.zeros((3, 6), np.uint8))
    with pytest.raises(SceneError) as err:
        load_user_scene("mine", rgb_png, path)
    message = str(err.value)
    assert "small.png" in message and "rgb.png" in message and "6 × 3" in message and "6 × 4" in message


@pytest.mark.parametrize(
    "kwargs, key",
    [
        ({"palette": {5: (1, 2, 3)}}, "palette"),
        ({"palette": {1: (1, 2, 300)}}, "palette"),
        ({"palette": {1: (9, 9, 9), 2: (9, 9, 9)}}, "palette"),
        ({"classes": ("a", "b", "c")}, "classes"),
        ({"camera_position": (1.0, 2.0)}, "camera_position"),
        ({"pixels_per_metre": 0.0}, "pixels_per_metre"),
    ],
)
def test_user_scene_bad_arguments(tmp_path, rgb_png, kwargs, key):
    ids = _write(tmp_path / "ids.png", np.zeros((4, 6), np.uint8))
    with pytest.raises(SceneError, match=key):
        load_user_scene("mine", rgb_png, ids, **kwargs)
