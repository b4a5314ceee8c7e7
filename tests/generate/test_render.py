"""Rendering: cheirality, scene edges and anti-aliasing, checked against OpenCV projection."""

import cv2
import numpy as np

from synthcal.generate.camera import homography
from synthcal.generate.render import (
    Appearance,
    apply_appearance,
    apply_appearance_on_ground,
    ground_rows,
    mask_invisible,
    render_image,
    render_semantic,
    render_semantic_and_mask,
    scene_mask,
    visible_mask,
)

SIZE = (64, 36)


def test_tilt_zero_upper_half_is_background():
    scene = np.ones((1900, 1300), np.uint8)
    H = homography([30.0], [0.0], [60.0], [[650.0, 950.0, 80.0]], SIZE)[0]
    view = render_semantic(scene, H, SIZE)
    assert np.all(view[: SIZE[1] // 2] == 0)  # rows above the principal point see sky
    assert np.all(view[-3:] == 1)  # the ground right below the horizon line is in the scene
    # Plain warping paints a mirrored ground into the sky; the mask is what removes it.
    unmasked = cv2.warpPerspective(scene, H, SIZE, flags=cv2.INTER_NEAREST)
    assert unmasked[: SIZE[1] // 2].any()


def test_rgb_is_black_above_the_horizon():
    scene = np.full((1900, 1300, 3), 200, np.uint8)
    H = homography([0.0], [0.0], [60.0], [[650.0, 950.0, 80.0]], SIZE)[0]
    image = render_image(scene, H, SIZE, supersample=2)
    assert np.all(image[: SIZE[1] // 2 - 1] == 0)
    assert np.all(image[-3:] == 200)


def test_scene_edge_is_background_beyond():
    """Looking across the right edge u = W−1 of a scene that is class 1 everywhere."""
    height, width = 400, 300
    scene = np.ones((height, width), np.uint8)
    H = homography([0.0], [-25.0], [40.0], [[150.0, 200.0, 60.0]], SIZE)[0]
    view = render_semantic(scene, H, SIZE)
    # Independent ground truth: the ground point of each pixel centre by ray casting.
    K = np.array([[40.0, 0, 31.5], [0, 40.0, 17.5], [0, 0, 1]])
    tilt = np.deg2rad(-25.0)  # pan 0: the camera looks along +x
    right, view_dir = np.array([0.0, 1, 0]), np.array([np.cos(tilt), 0, -np.sin(tilt)])
    down = np.cross(view_dir, right)
    ys, xs = np.mgrid[0 : SIZE[1], 0 : SIZE[0]]
    rays_cam = np.linalg.inv(K) @ np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    rays = np.outer(right, rays_cam[0]) + np.outer(down, rays_cam[1]) + np.outer(view_dir, rays_cam[2])
    t = 60.0 / rays[2]  # the centre is at z = −60; the ground at z = 0
    u = 150.0 + t * rays[0]
    v = 200.0 + t * rays[1]
    inside = (t > 0) & (np.round(u) >= 0) & (np.round(u) <= width - 1) & (np.round(v) >= 0) & (np.round(v) <= height - 1)
    # Pixels within half a bird's-eye pixel of the edge may round either way.
    margin = (np.abs(u - (width - 0.5)) < 0.5) | (np.abs(u + 0.5) < 0.5) | (np.abs(v - (height - 0.5)) < 0.5)
    expected = inside.reshape(ys.shape).astype(np.uint8)
    sure = ~margin.reshape(ys.shape)
    assert (expected == 0).sum() > 100 and (expected == 1).sum() > 100, "the view must show both sides of the edge"
    np.testing.assert_array_equal(view[sure], expected[sure])


def test_visible_mask_matches_depth_sign():
    H = homography([45.0], [-5.0], [30.0], [[0.0, 0.0, 10.0]], SIZE)[0]
    mask = visible_mask(H, SIZE)
    ys, xs = np.mgrid[0 : SIZE[1], 0 : SIZE[0]]
    ground = np.linalg.solve(H, np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)]))
    np.testing.assert_array_equal(mask.ravel(), ground[2] > 0)
    assert mask.any() and not mask.all()


def test_supersampling_antialiases_a_fine_stripe_pattern():
    scene = np.zeros((2000, 2000, 3), np.uint8)
    scene[:, ::2] = 255  # one-pixel stripes: alias badly without anti-aliasing
    H = homography([90.0], [-60.0], [150.0], [[1000.0, 200.0, 300.0]], SIZE)[0]
    plain = render_image(scene, H, SIZE, supersample=1).astype(float)
    smooth = render_image(scene, H, SIZE, supersample=4).astype(float)
    lower = slice(SIZE[1] // 2, None)
    assert smooth[lower].std() < 0.5 * plain[lower].std()
    np.testing.assert_allclose(smooth[lower].mean(), 127.5, atol=20)


def test_appearance_is_seeded_and_bounded():
    image = np.full((36, 64, 3), 120, np.uint8)
    appearance = Appearance(brightness=20, contrast=0.2, blur_sigma=1.0, noise_sigma=5.0)
    a = apply_appearance(image, appearance, np.random.default_rng(3))
    b = apply_appearance(image, appearance, np.random.default_rng(3))
    c = apply_appearance(image, appearance, np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert abs(a.astype(float).mean() - 120) <= 21
    untouched = apply_appearance(image, Appearance(), np.random.default_rng(3))
    np.testing.assert_array_equal(untouched, image)


def test_mask_invisible_equals_the_full_mask():
    rng = np.random.default_rng(0)
    for k in range(20):
        H = homography([rng.uniform(-180, 180)], [rng.uniform(-30, 10)], [rng.uniform(20, 300)],
                       [[0.0, 0.0, 10.0]], SIZE)[0]
        roll = 0.2 * k  # rotating the image makes the horizon slant across rows
        H = np.array([[np.cos(roll), -np.sin(roll), 0], [np.sin(roll), np.cos(roll), 0], [0, 0, 1]]) @ H
        for s in (1, 2):
            image = np.full((SIZE[1] * s, SIZE[0] * s, 3), 7, np.uint8)
            expected = image.copy()
            expected[~visible_mask(H, SIZE, s)] = 0
            np.testing.assert_array_equal(mask_invisible(image, H, s), expected)


def _random_cameras(rng: np.random.Generator, count: int) -> np.ndarray:
    """Cameras at (150, 200) over a 300 × 400 scene, some seeing the horizon, some rolled."""
    cameras = []
    for k in range(count):
        H = homography(np.array([rng.uniform(-180, 180)]), np.array([rng.uniform(-30, 5)]),
                       np.array([rng.uniform(20, 100)]), np.array([[150.0, 200.0, rng.uniform(20, 80)]]), SIZE)[0]
        roll = rng.uniform(-0.5, 0.5) if k % 2 else 0.0
        cameras.append(np.array([[np.cos(roll), -np.sin(roll), 0], [np.sin(roll), np.cos(roll), 0], [0, 0, 1]]) @ H)
    return np.array(cameras)


def test_ground_rows_are_the_rows_with_visible_pixels():
    for H in _random_cameras(np.random.default_rng(1), 30):
        for s in (1, 2):
            # Independent: the depth sign of every pixel centre by solving H g = x.
            ys, xs = np.mgrid[0 : SIZE[1] * s, 0 : SIZE[0] * s]
            centres = np.stack([(xs.ravel() + 0.5) / s - 0.5, (ys.ravel() + 0.5) / s - 0.5, np.ones(xs.size)])
            seen = (np.linalg.solve(H, centres)[2] > 0).reshape(ys.shape).any(axis=1)
            expected = np.zeros(len(seen), bool)
            expected[ground_rows(H, ys.shape, s)] = True
            np.testing.assert_array_equal(expected, seen)


def test_render_image_equals_full_warp_masked_and_area_averaged():
    """Warping only the rows that see ground gives the plain recipe's image."""
    rng = np.random.default_rng(0)
    scene = cv2.GaussianBlur(rng.integers(0, 256, (400, 300, 3), np.uint8), (0, 0), 3)
    for H in _random_cameras(rng, 30):
        for s in (1, 2, 3):
            A = np.array([[s, 0, (s - 1) / 2], [0, s, (s - 1) / 2], [0, 0, 1]], float)
            fine = cv2.warpPerspective(scene, A @ H, (SIZE[0] * s, SIZE[1] * s), flags=cv2.INTER_LINEAR)
            fine[~visible_mask(H, SIZE, s)] = 0
            expected = cv2.resize(fine, SIZE, interpolation=cv2.INTER_AREA) if s > 1 else fine
            image = render_image(scene, H, SIZE, supersample=s)
            # The shifted warp may round a bilinear weight the other way: one grey level, rarely.
            difference = np.abs(image.astype(int) - expected)
            assert difference.max() <= 1 and (difference > 0).mean() < 0.01


def test_appearance_noise_is_gaussian_and_centred():
    image = np.full((144, 256, 3), 128, np.uint8)
    appearance = Appearance(noise_sigma=30.0)
    checked = 0
    for seed in range(8):
        rng = np.random.default_rng(seed)
        noise_level = np.random.default_rng(seed).uniform(size=4)[3]  # the fourth draw scales the noise
        noise = apply_appearance(image, appearance, rng).astype(float) - 128
        sigma = noise_level * 30.0
        if sigma < 3:
            continue  # too coarse to tell shapes apart in grey levels
        assert abs(noise.mean()) < 0.05 * sigma
        assert abs(noise.std() - sigma) < 0.05 * sigma
        # Gaussian: 68.3 % within one sigma (uniform noise of that std: 57.7 %).
        assert abs((np.abs(noise) <= sigma).mean() - 0.683) < 0.03
        checked += 1
    assert checked >= 3


def test_appearance_on_ground_leaves_the_sky_black():
    scene = np.full((1900, 1300, 3), 100, np.uint8)
    H = homography([20.0], [-3.0], [60.0], [[650.0, 950.0, 80.0]], SIZE)[0]
    image = render_image(scene, H, SIZE, supersample=1)
    changed = apply_appearance_on_ground(image.copy(), H, Appearance(brightness=40.0, blur_sigma=2.0, noise_sigma=5.0),
                                         np.random.default_rng(1))
    sky = ~visible_mask(H, SIZE)
    assert sky.any() and (~sky).any()
    assert np.all(changed[sky] == 0)
    assert np.abs(changed[~sky].astype(int) - 100).mean() > 1  # the ground did change


def _off_scene_reference(H: np.ndarray, size: tuple[int, int], scene_shape: tuple[int, int]) -> np.ndarray:
    """Pixels whose ground point (projected with numpy's own inverse) is behind the camera or off the scene."""
    width, height = size
    xs, ys = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    ground = np.einsum("ij,hwj->hwi", np.linalg.inv(H), np.stack([xs, ys, np.ones_like(xs)], -1))
    u, v = ground[..., 0] / ground[..., 2], ground[..., 1] / ground[..., 2]
    inside = (ground[..., 2] > 0) & (u > -0.5) & (u < scene_shape[1] - 0.5) & (v > -0.5) & (v < scene_shape[0] - 0.5)
    return ~inside


def test_off_scene_ground_is_black_in_the_rgb_as_in_the_semantic_map():
    """Issue 14, item 7: brightness and noise must not paint the ground beyond the scene's edge."""
    rng = np.random.default_rng(0)
    scene_rgb = rng.integers(60, 200, (300, 200, 3), dtype=np.uint8)
    scene_ids = rng.integers(0, 4, (300, 200), dtype=np.uint8)
    # looking from inside the scene toward its right edge, which falls mid-image
    H = homography([10.0], [-8.0], [60.0], [[100.0, 150.0, 30.0]], SIZE)[0]
    image = render_image(scene_rgb, H, SIZE, supersample=2)
    look = Appearance(brightness=40.0, contrast=0.2, blur_sigma=0.8, noise_sigma=5.0)
    old = apply_appearance_on_ground(image.copy(), H, look, np.random.default_rng(1))
    on = scene_mask(H, SIZE, scene_ids.shape)
    new = apply_appearance_on_ground(image.copy(), H, look, np.random.default_rng(1), on)
    off_ground = ~on & visible_mask(H, SIZE)  # in front of the camera, beyond the scene
    assert off_ground.sum() > 100 and on.sum() > 100
    assert np.all(new[~on] == 0)  # exactly black off the scene
    assert old[off_ground].max() > 10  # where the appearance used to paint it
    np.testing.assert_array_equal(new[on], old[on])  # the scene's pixels are untouched
    # the mask is the semantic map's: off-scene pixels are class 0 there, and it agrees with an
    # independent projection wherever a pixel is not within rounding of the edge
    semantic, mask = render_semantic_and_mask(scene_ids, H, SIZE)
    np.testing.assert_array_equal(semantic, render_semantic(scene_ids, H, SIZE))
    np.testing.assert_array_equal(mask, on)
    assert np.all(semantic[~on] == 0)
    reference = _off_scene_reference(H, SIZE, scene_ids.shape)
    assert (reference != ~on).sum() <= 0.01 * reference.size
