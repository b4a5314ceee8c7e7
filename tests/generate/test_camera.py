"""Camera geometry against independent constructions (scipy rotations, OpenCV projection)."""

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from synthcal.generate.camera import decompose_homography, homography, orient_homography

IMAGE_SIZE = (256, 144)


def random_cameras(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    pan = rng.uniform(-180, 180, n)
    tilt = rng.uniform(-40, -1, n)
    focal = rng.uniform(50, 800, n)
    position = np.stack([rng.uniform(0, 1300, n), rng.uniform(0, 1900, n), rng.uniform(20, 200, n)], -1)
    return pan, tilt, focal, position


def camera_to_world(pan_deg: float, tilt_deg: float) -> np.ndarray:
    """Built from elementary rotations, not from the SPEC's closed form.

    At pan = tilt = 0 the camera looks along +x with image right = +y and image
    down = +z (into the ground); tilting up turns the optical axis about the
    camera's x axis, panning turns everything about the world z axis.
    """
    base = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # columns: camera x, y, z in world
    tilt = Rotation.from_euler("x", tilt_deg, degrees=True).as_matrix()
    pan = Rotation.from_euler("z", pan_deg, degrees=True).as_matrix()
    return pan @ base @ tilt


def test_homography_matches_opencv_projection():
    pan, tilt, focal, position = random_cameras(50)
    H = homography(pan, tilt, focal, position, IMAGE_SIZE)
    rng = np.random.default_rng(1)
    checked = 0
    for k in range(len(pan)):
        R_wc = camera_to_world(pan[k], tilt[k]).T
        centre = position[k] * np.array([1, 1, -1])
        K = np.array([[focal[k], 0, 127.5], [0, focal[k], 71.5], [0, 0, 1]])
        # ground points in front of the camera
        ground = np.c_[rng.uniform(0, 1300, 400), rng.uniform(0, 1900, 400), np.zeros(400)]
        depth = (ground - centre) @ R_wc[2]
        ground = ground[depth > 1.0]
        if len(ground) < 3:
            continue
        checked += 1
        rvec, _ = cv2.Rodrigues(R_wc)
        expected, _ = cv2.projectPoints(ground, rvec, -R_wc @ centre, K, None)
        projected = np.c_[ground[:, :2], np.ones(len(ground))] @ H[k].T
        assert np.all(projected[:, 2] > 0), "third coordinate must be the (positive) depth"
        pixels = projected[:, :2] / projected[:, 2:]
        np.testing.assert_allclose(pixels, expected[:, 0], rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    assert checked >= 40


def test_depth_is_third_coordinate():
    pan, tilt, focal, position = random_cameras(5, seed=3)
    H = homography(pan, tilt, focal, position, IMAGE_SIZE)
    for k in range(5):
        R_wc = camera_to_world(pan[k], tilt[k]).T
        centre = position[k] * np.array([1, 1, -1])
        point = np.array([400.0, 700.0, 0.0])
        depth = R_wc[2] @ (point - centre)
        np.testing.assert_allclose((H[k] @ [400.0, 700.0, 1.0])[2], depth, rtol=1e-9)


def test_focal_scales_with_width_only_through_argument():
    """Same field of view at two resolutions: the image centre ray hits the same ground point."""
    H_small = homography([10.0], [-20.0], [100.0], [[650, 950, 80]], (128, 72))[0]
    H_large = homography([10.0], [-20.0], [200.0], [[650, 950, 80]], (256, 144))[0]
    centre_small = np.linalg.solve(H_small, [63.5, 35.5, 1.0])
    centre_large = np.linalg.solve(H_large, [127.5, 71.5, 1.0])
    np.testing.assert_allclose(centre_small[:2] / centre_small[2], centre_large[:2] / centre_large[2], rtol=1e-9)


def test_decompose_recovers_parameters():
    pan, tilt, focal, position = random_cameras(40, seed=5)
    H = homography(pan, tilt, focal, position, IMAGE_SIZE)
    scaled = H * np.random.default_rng(0).uniform(-3, 3, (40, 1, 1))  # arbitrary scale and sign
    params = decompose_homography(scaled, IMAGE_SIZE)
    np.testing.assert_allclose(params["focal_px"], focal, rtol=1e-6)
    np.testing.assert_allclose(params["tilt_deg"], tilt, atol=1e-6)
    np.testing.assert_allclose((params["pan_deg"] - pan + 180) % 360 - 180, 0, atol=1e-6)
    np.testing.assert_allclose(np.c_[params["x"], params["y"], params["z"]], position, rtol=1e-6)
    np.testing.assert_allclose(params["roll_deg"], 0, atol=1e-6)


def test_orient_restores_depth_sign():
    pan, tilt, focal, position = random_cameras(10, seed=7)
    H = homography(pan, tilt, focal, position, IMAGE_SIZE)
    normalised = H / H[:, 2:3, 2:3]  # loses the sign where H[2,2] < 0
    assert np.any(H[:, 2, 2] < 0), "the test needs some cameras with H[2,2] < 0"
    oriented = orient_homography(normalised, IMAGE_SIZE)
    ratio = oriented / H
    assert np.all(ratio > 0)


@pytest.mark.parametrize("pan", [0.0, 90.0, -135.0])
def test_pan_turns_from_u_toward_v(pan):
    """The image centre looks along (cos pan, sin pan) on the ground."""
    H = homography([pan], [-30.0], [200.0], [[0.0, 0.0, 50.0]], IMAGE_SIZE)[0]
    ground = np.linalg.solve(H, [127.5, 71.5, 1.0])
    u, v = ground[:2] / ground[2]
    distance = 50.0 / np.tan(np.deg2rad(30.0))
    np.testing.assert_allclose([u, v], distance * np.array([np.cos(np.deg2rad(pan)), np.sin(np.deg2rad(pan))]), atol=1e-9)
