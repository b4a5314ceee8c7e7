"""``iou_part`` and ``iou_whole`` (SPEC §8): clipping to the scene, exact polygon areas against
brute-force rasterisation, and the soccer pitch as the field."""

import cv2
import numpy as np
import pytest
from metric_cases import SIZE, perspective, stripes, top_down

from synthcal.eval.polygon import iou_part, iou_whole
from synthcal.generate.camera import homography
from synthcal.scenes import build_scene
from synthcal.scenes.soccer import CAMERA_POSITION as SOCCER_CAMERA
from synthcal.scenes.soccer import HEADING_DEG as SOCCER_HEADING


def test_iou_part_is_clipped_to_the_scene():
    """An estimate whose view runs past the scene's right edge is cut at the edge."""
    scene = stripes(width=140)  # scene columns cover u ∈ [−0.5, 139.5]
    H_true, H_est = top_down(80, 50), top_down(100, 50)
    # Truth: u ∈ [79.5, 127.5] → 48 wide. Estimate: u ∈ [99.5, 147.5] ∩ scene → 40 wide.
    # Overlap [99.5, 127.5] → 28. IoU = 28 / (48 + 40 − 28).
    assert iou_part(scene.shape, H_est, H_true, SIZE) == pytest.approx(28 / 60, abs=1e-12)


# --- exact areas against rasterisation ---------------------------------------------------------


def _raster_part(shape, H_est, H_true, size):
    v, u = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    ground = np.stack([u.ravel(), v.ravel(), np.ones(u.size)])

    def seen(H):
        p = H @ ground
        with np.errstate(all="ignore"):
            x, y = p[0] / p[2], p[1] / p[2]
        return (p[2] > 0) & (x >= -0.5) & (x <= size[0] - 0.5) & (y >= -0.5) & (y <= size[1] - 0.5)

    a, b = seen(H_true), seen(H_est)
    return (a & b).sum() / max((a | b).sum(), 1)


def _raster_whole(H_est, H_true, size, scale=2, sub=(4, 32)):
    """Raster of the canvas; rows are finer because roll-free horizons are horizontal lines."""
    width, height = size
    xs = (width - 1) / 2 - scale * width / 2 + (np.arange(scale * width * sub[0]) + 0.5) / sub[0]
    ys = (height - 1) / 2 - scale * height / 2 + (np.arange(scale * height * sub[1]) + 0.5) / sub[1]
    X, Y = np.meshgrid(xs, ys)
    y = np.stack([X.ravel(), Y.ravel(), np.ones(X.size)])
    inside = (y[0] >= -0.5) & (y[0] <= width - 0.5) & (y[1] >= -0.5) & (y[1] <= height - 0.5)
    a = inside & ((np.linalg.inv(H_true) @ y)[2] > 0)
    g = np.linalg.inv(H_est) @ y
    p = H_true @ g
    with np.errstate(all="ignore"):
        px, py = p[0] / p[2], p[1] / p[2]
    b = (g[2] > 0) & (p[2] > 0) & (px >= -0.5) & (px <= width - 0.5) & (py >= -0.5) & (py <= height - 0.5)
    return (a & b).sum() / max((a | b).sum(), 1)


def test_exact_areas_match_rasterisation():
    rng = np.random.default_rng(7)
    shape = (400, 300)
    for _ in range(5):
        pan, tilt, focal = rng.uniform(-30, 30), rng.uniform(-20, 0), rng.uniform(25, 50)
        H_true = perspective(pan, tilt, focal)
        H_est = perspective(pan + rng.normal(0, 3), tilt + rng.normal(0, 2), focal * rng.uniform(0.9, 1.1),
                            position=(150 + rng.normal(0, 5), 200 + rng.normal(0, 5), 40 + rng.normal(0, 3)))
        assert iou_part(shape, H_est, H_true, SIZE) == pytest.approx(_raster_part(shape, H_est, H_true, SIZE),
                                                                     abs=0.005)
        assert iou_whole(H_est, H_true, SIZE, canvas_scale=2) == pytest.approx(
            _raster_whole(H_est, H_true, SIZE), abs=0.005)

# --- iou_part on the soccer pitch (SPEC §4, §8) ------------------------------------------------


SOCCER_SIZE = (64, 36)


def soccer_camera(pan, tilt, focal, position=SOCCER_CAMERA):
    """A broadcast camera of the soccer scene; focal at the 256-pixel reference width."""
    return homography([pan + SOCCER_HEADING], [tilt], [focal * SOCCER_SIZE[0] / 256], [position], SOCCER_SIZE)[0]


def test_soccer_field_is_the_pitch():
    scene = build_scene("soccer")
    u, v = np.array(scene.field_polygon()).T
    assert (u.min(), u.max(), v.min(), v.max()) == (100.0, 1150.0, 100.0, 780.0)  # 105 × 68 m at 10 px/m
    # Inside the polygon the map is the pitch (classes 1–3); just outside, background.
    assert scene.semantic[440, 625] > 0 and scene.semantic[440, 95] == 0 and scene.semantic[95, 625] == 0
    intersection = build_scene("intersection-1")
    assert intersection.field_polygon() == [[-0.5, -0.5], [1299.5, -0.5], [1299.5, 1899.5], [-0.5, 1899.5]]


def test_soccer_estimate_differing_only_beyond_the_touchline_scores_one():
    """Same near edge and side edges as the truth, far edge moved within the margin beyond the far touchline."""
    scene = build_scene("soccer")
    field = np.array(scene.field_polygon())
    H_true = soccer_camera(0, -18.4, 400)
    width, height = SOCCER_SIZE
    image_corners = np.array([[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]])
    ground = cv2.perspectiveTransform(image_corners[None], np.linalg.inv(H_true))[0]
    far, near = ground[:2], ground[2:]
    # The far edge (v ≈ 50) lies in the margin beyond the far touchline (v = 100), the near one beyond the near (780).
    assert (far[:, 1] < 100).all() and (far[:, 1] > 0).all() and (near[:, 1] > 780).all()
    # Slide the far corners outward along the side edges (v = 15 instead of ≈ 50 px): same lines, other homography.
    moved = far + (far - near[::-1]) * ((far[:, 1] - 15) / (near[::-1, 1] - far[:, 1]))[:, None]
    H_est = cv2.getPerspectiveTransform(image_corners.astype(np.float32), np.vstack([moved, near]).astype(np.float32))
    H_est = np.linalg.inv(H_est)
    assert not np.allclose(H_est / H_est[2, 2], H_true / H_true[2, 2], rtol=1e-3)
    assert iou_part(scene.semantic.shape, H_est, H_true, SOCCER_SIZE, field=field) == pytest.approx(1.0, abs=1e-6)
    # Clipped to the whole scene (pitch and margin), as before, the margin would count.
    assert iou_part(scene.semantic.shape, H_est, H_true, SOCCER_SIZE) < 0.95


def _pitch_template_iou(H_est, H_true, size, step=1.0):
    """The literature's rasterised iou_part: warp the frame into a pitch template with each H, compare masks.

    Template pixel (i, j) is bird's-eye point (100 + (j + ½)·step, 100 + (i + ½)·step): the pitch only.
    """
    template = (int(1050 / step), int(680 / step))
    to_scene = np.array([[step, 0, 100 + step / 2], [0, step, 100 + step / 2], [0, 0, 1.0]])
    frame = np.ones(size[::-1], np.uint8)

    def seen(H):
        return cv2.warpPerspective(frame, H @ to_scene, template, flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP) > 0

    a, b = seen(H_true), seen(H_est)
    return (a & b).sum() / max((a | b).sum(), 1)


def test_soccer_iou_part_matches_the_literatures_rasterised_pitch():
    """Per image within the references' own spread (2.6 points); the pitch lies in front of every camera here."""
    scene = build_scene("soccer")
    field = np.array(scene.field_polygon())
    rng = np.random.default_rng(2014)
    ours, theirs, whole = [], [], []
    for _ in range(12):
        pan, tilt, focal = rng.uniform(-25, 25), rng.uniform(-14, -8), rng.uniform(500, 800)
        H_true = soccer_camera(pan, tilt, focal)
        position = np.array(SOCCER_CAMERA) + rng.normal(0, [15, 15, 8])
        H_est = soccer_camera(pan + rng.normal(0, 1.5), tilt + rng.normal(0, 1), focal * rng.uniform(0.9, 1.1),
                              tuple(position))
        ours.append(iou_part(scene.semantic.shape, H_est, H_true, SOCCER_SIZE, field=field))
        theirs.append(_pitch_template_iou(H_est, H_true, SOCCER_SIZE))
        whole.append(iou_part(scene.semantic.shape, H_est, H_true, SOCCER_SIZE))
    ours, theirs = np.array(ours), np.array(theirs)
    assert 0.3 < ours.mean() < 0.99
    np.testing.assert_allclose(ours, theirs, atol=0.026)  # measured: within 0.01 points
    # Clipping to the whole scene (pitch and margin) instead misses it on some image (by 7 points here).
    assert np.abs(np.array(whole) - theirs).max() > 0.026
