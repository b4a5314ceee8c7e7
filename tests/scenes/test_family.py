"""intersection-1's family, its turned copies and the blank scene (issue 27): topology, rotation, blankness."""

import math

import cv2
import numpy as np
import pytest

from synthcal.scenes import BUILTIN_SCENES, build_scene

FAMILY = ["intersection-1a", "intersection-1b", "intersection-1c", "intersection-1d"]
CENTRE = (650.0, 950.0)


def road_across(semantic: np.ndarray, angle_deg: float, distance: float, half_width: float = 80.0) -> bool:
    """Whether a segment across the ray at ``angle_deg`` (image angles), ``distance`` px out, meets road (class 1)."""
    e = np.array([math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))])
    n = np.array([-e[1], e[0]])
    points = np.array(CENTRE) + distance * e + np.linspace(-half_width, half_width, 161)[:, None] * n
    u, v = np.round(points).astype(int).T
    return bool(np.any(semantic[v, u] == 1))


@pytest.mark.parametrize("name", ["intersection-1", *FAMILY])
def test_the_family_has_intersection_1s_four_legs_and_nothing_on_the_diagonals(name):
    semantic = build_scene(name).semantic
    for distance in (250.0, 450.0, 600.0):
        assert all(road_across(semantic, angle, distance) for angle in (0, 90, 180, 270)), (name, distance)
        assert not any(road_across(semantic, angle, distance, 60.0) for angle in (45, 135, 225, 315)), (name, distance)


def test_the_family_differs_from_intersection_1_and_from_each_other():
    scenes = [build_scene(name) for name in ["intersection-1", *FAMILY]]
    for i, a in enumerate(scenes):
        assert a.camera_position == scenes[0].camera_position and a.semantic.shape == scenes[0].semantic.shape
        for b in scenes[i + 1:]:
            assert np.mean(a.semantic != b.semantic) > 0.02, (a.name, b.name)
            assert np.mean(np.any(a.image != b.image, axis=-1)) > 0.5, (a.name, b.name)
    for name in FAMILY:
        assert name in BUILTIN_SCENES and "intersection-1" in BUILTIN_SCENES[name]


@pytest.mark.parametrize("angle", [15, 45, 90])
def test_the_turned_scene_is_intersection_1_rotated_about_its_centre(angle):
    original, turned = build_scene("intersection-1"), build_scene(f"intersection-1-turn{angle}")
    assert turned.heading_deg == original.heading_deg + angle
    assert turned.camera_position == original.camera_position
    # cv2 turns counter-clockwise on screen for a positive angle; image angles grow clockwise
    matrix = cv2.getRotationMatrix2D(CENTRE, -angle, 1.0)
    height, width = original.semantic.shape
    expected = cv2.warpAffine(original.semantic, matrix, (width, height), flags=cv2.INTER_NEAREST,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    agreement = np.mean(turned.semantic == expected)
    assert agreement > (0.9999 if angle == 90 else 0.995), agreement
    # the legs: road along angle, angle + 90, ... and none half-way between
    for distance in (250.0, 450.0):
        assert all(road_across(turned.semantic, a + angle, distance) for a in (0, 90, 180, 270))
        assert not any(road_across(turned.semantic, a + angle, distance, 60.0) for a in (45, 135, 225, 315))


def grid_homography(pan, tilt, focal, centre, size=(256, 144)):
    """SPEC §2 written out: H = K [r1 r2 t], bird's-eye pixel → image pixel."""
    p, t = math.radians(pan), math.radians(tilt)
    z = np.array([math.cos(t) * math.cos(p), math.cos(t) * math.sin(p), -math.sin(t)])
    x = np.array([-math.sin(p), math.cos(p), 0.0])
    rot = np.stack([x, np.cross(z, x), z])
    trans = -rot @ np.array([centre[0], centre[1], -centre[2]])
    k = np.array([[focal, 0, (size[0] - 1) / 2], [0, focal, (size[1] - 1) / 2], [0, 0, 1]])
    return k @ np.column_stack([rot[:, 0], rot[:, 1], trans])


def project(h, point):
    x = h @ np.array([point[0], point[1], 1.0])
    return x[:2] / x[2]


@pytest.mark.parametrize("angle", [15, 45, 90])
def test_a_turned_template_shows_the_same_view_with_a_pose_turned_by_the_angle(angle):
    """A grid camera of the turned scene (its heading added to the pan) sees a ground point where the
    original's camera at the same pan, offset turned back, sees the point before the turn."""
    from synthcal.generate.camera import homography

    turned = build_scene(f"intersection-1-turn{angle}")
    a = math.radians(angle)
    turn = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    offset, pan, tilt, focal, height = np.array([30.0, -20.0]), 30.0, -10.0, 200.0, 70.0
    h_turned = grid_homography(pan + turned.heading_deg, tilt, focal, (*(np.array(CENTRE) + offset), height))
    # the project's own camera agrees with SPEC §2 written out (pan + heading)
    ours = homography(np.array([pan + turned.heading_deg]), np.array([tilt]), np.array([focal]),
                      np.array([[*(np.array(CENTRE) + offset), height]]), (256, 144))[0]
    np.testing.assert_allclose(ours / ours[2, 2], h_turned / h_turned[2, 2], rtol=1e-9, atol=1e-9)
    h_original = grid_homography(pan, tilt, focal, (*(np.array(CENTRE) + turn.T @ offset), height))
    for ground in ([700.0, 980.0], [640.0, 1100.0], [760.0, 900.0]):
        moved = np.array(CENTRE) + turn @ (np.array(ground) - np.array(CENTRE))
        np.testing.assert_allclose(project(h_turned, moved), project(h_original, ground), atol=1e-6)
    # used for intersection-1, the same homography sends the point elsewhere: its pose is turned
    assert np.linalg.norm(project(h_turned, [700.0, 980.0]) - project(h_original, [700.0, 980.0])) > 5


def test_the_blank_scene_is_background_and_black_in_intersection_1s_frame():
    blank, original = build_scene("intersection-1-blank"), build_scene("intersection-1")
    assert blank.semantic.shape == original.semantic.shape and not blank.semantic.any() and not blank.image.any()
    assert (blank.camera_position, blank.heading_deg, blank.classes) == (original.camera_position, 0.0,
                                                                         original.classes)
