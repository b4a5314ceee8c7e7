"""Metrics (SPEC §8): oracle, hand-computed cases, sign handling, failures, and the
exact polygon areas against brute-force rasterisation."""

import cv2
import numpy as np
import pytest
import torch

from synthcal.eval.metrics import (
    check_homography,
    completeness,
    evaluate,
    iou,
    iou_part,
    iou_whole,
    semantic_iou,
    summarize,
)
from synthcal.generate.camera import homography

SIZE = (48, 24)
STRIPE = 8  # bird's-eye pixels per stripe; classes 1, 2, 3 repeat every 24 columns


def stripes(height: int = 200, width: int = 400) -> np.ndarray:
    """Vertical stripes of classes 1, 2, 3, each STRIPE columns wide, starting at u = 0."""
    return np.broadcast_to((np.arange(width) // STRIPE % 3 + 1).astype(np.uint8), (height, width)).copy()


def top_down(u0: float, v0: float) -> np.ndarray:
    """A camera looking straight down at scale 1: image pixel (x, y) sees ground (x + u0, y + v0)."""
    return np.array([[1.0, 0, -u0], [0, 1.0, -v0], [0, 0, 1.0]])


def blobs(seed: int = 0, shape=(400, 300)) -> np.ndarray:
    coarse = np.random.default_rng(seed).integers(0, 4, (shape[0] // 20, shape[1] // 20)).astype(np.uint8)
    return cv2.resize(coarse, shape[::-1], interpolation=cv2.INTER_NEAREST)


def perspective(pan, tilt, focal, position=(150.0, 200.0, 40.0), size=SIZE):
    return homography([pan], [tilt], [focal], [position], size)[0]


# --- oracle and hand-made cases ----------------------------------------------------------


@pytest.mark.parametrize("pan, tilt, focal", [(0, 0, 30), (20, -5, 40), (-35, -15, 25), (10, -60, 30)])
def test_oracle_scores_exactly_one(pan, tilt, focal):
    scene = blobs()
    H = perspective(pan, tilt, focal)
    assert iou(scene, H, H, SIZE) == 1.0
    assert iou_part(scene.shape, H, H, SIZE) == 1.0
    assert iou_whole(H, H, SIZE) == 1.0  # tilt 0: half the image is sky, still exactly 1


def test_shifted_view_of_stripes_by_hand():
    """The estimate sees the ground d columns further right than the truth.

    The view is 48 columns = two periods of the three 8-wide stripes, starting on a
    stripe edge. Per class: truth 16 columns, estimate 16, overlap 2 · (8 − d), so
    IoU = (8 − d) / (8 + d) for every class. On the ground and in the image, the two
    48 × 24 rectangles overlap in (48 − d) columns: IoU = (48 − d) / (48 + d).
    """
    scene, d = stripes(), 2
    H_true, H_est = top_down(96, 50), top_down(96 + d, 50)
    assert iou(scene, H_est, H_true, SIZE) == pytest.approx((8 - d) / (8 + d), abs=1e-12)
    assert iou_part(scene.shape, H_est, H_true, SIZE) == pytest.approx((48 - d) / (48 + d), abs=1e-12)
    assert iou_whole(H_est, H_true, SIZE) == pytest.approx((48 - d) / (48 + d), abs=1e-12)


def test_zoomed_estimate_by_hand():
    """Estimate = truth zoomed ×2 about the image centre: it sees a quarter of the ground."""
    scene, H_true = stripes(), top_down(96, 50)
    cx, cy = (SIZE[0] - 1) / 2, (SIZE[1] - 1) / 2
    zoom = np.array([[2.0, 0, -cx], [0, 2.0, -cy], [0, 0, 1]])
    H_est = zoom @ H_true
    assert iou_part(scene.shape, H_est, H_true, SIZE) == pytest.approx(0.25, abs=1e-12)
    # In the image the round trip of the rectangle is the rectangle ×2: area 4, IoU 1/4.
    assert iou_whole(H_est, H_true, SIZE) == pytest.approx(0.25, abs=1e-12)


def test_iou_part_is_clipped_to_the_scene():
    """An estimate whose view runs past the scene's right edge is cut at the edge."""
    scene = stripes(width=140)  # scene columns cover u ∈ [−0.5, 139.5]
    H_true, H_est = top_down(80, 50), top_down(100, 50)
    # Truth: u ∈ [79.5, 127.5] → 48 wide. Estimate: u ∈ [99.5, 147.5] ∩ scene → 40 wide.
    # Overlap [99.5, 127.5] → 28. IoU = 28 / (48 + 40 − 28).
    assert iou_part(scene.shape, H_est, H_true, SIZE) == pytest.approx(28 / 60, abs=1e-12)


def test_semantic_iou_edge_cases():
    empty = np.zeros((4, 4), np.uint8)
    assert semantic_iou(empty, empty) == 1.0  # nothing to see in either: agreement
    one = empty.copy()
    one[:2] = 1
    assert semantic_iou(one, empty) == 0.0  # class 1 only predicted: IoU 0 for it
    two = one.copy()
    two[3] = 2
    # class 1: 8/8; class 2: 0/4 (only in the prediction) → mean 0.5
    assert semantic_iou(two, one) == 0.5


# --- sign ---------------------------------------------------------------------------------


def test_sign_of_foreign_estimates_does_not_matter():
    scene = blobs(1)
    H_true = perspective(5, -10, 35)
    H = perspective(8, -11, 33)  # looks along +u from u = 150: the origin is behind it
    assert H[2, 2] < 0
    variants = [H, -H, H / H[2, 2], 3.5 * H]
    scores = [(iou(scene, V, H_true, SIZE), iou_part(scene.shape, V, H_true, SIZE), iou_whole(V, H_true, SIZE))
              for V in variants]
    assert 0 < scores[0][0] < 1
    for score in scores[1:]:
        assert score == pytest.approx(scores[0], abs=1e-12)
    np.testing.assert_allclose(check_homography(H / H[2, 2], SIZE)[0] * abs(H[2, 2]), H, rtol=1e-12)


# --- failures ----------------------------------------------------------------------------


def test_failed_estimates_score_zero_and_are_flagged():
    scene = blobs(2)
    H_true = perspective(0, -10, 30)
    singular = H_true.copy()
    singular[2] = singular[0] + singular[1]
    nan, inf = H_true.copy(), H_true.copy()
    nan[0, 0], inf[1, 2] = np.nan, np.inf
    estimates = [None, nan, inf, np.ones((3, 4)), singular, "junk", H_true]
    frame = evaluate(scene, estimates, np.repeat(H_true[None], len(estimates), 0), SIZE)
    assert frame["failed"].tolist() == [True] * 6 + [False]
    assert frame["failure"].tolist() == [
        "no estimate", "non-finite entries", "non-finite entries", "wrong shape (3, 4)", "singular",
        "not numeric", "",
    ]
    failed = frame[frame["failed"]]
    assert (failed[["iou", "iou_part", "iou_whole"]] == 0).all().all()
    assert frame.iloc[-1][["iou", "iou_part", "iou_whole"]].tolist() == [1.0, 1.0, 1.0]
    assert completeness(frame) == pytest.approx(1 / 7)
    assert summarize(frame)["iou"] == pytest.approx(1 / 7)
    # The single-image functions agree.
    for bad in estimates[:-1]:
        assert iou(scene, bad, H_true, SIZE) == iou_part(scene.shape, bad, H_true, SIZE) == iou_whole(
            bad, H_true, SIZE) == 0.0


def test_whole_batch_failures():
    scene = blobs(3)
    H_true = np.repeat(perspective(0, -10, 30)[None], 3, 0)
    for batch, reason in [(None, "no estimate"), (H_true[:2], "wrong batch shape (2, 3, 3), expected (3, 3, 3)")]:
        frame = evaluate(scene, batch, H_true, SIZE)
        assert frame["failed"].all() and (frame["failure"] == reason).all()
        assert completeness(frame) == 0.0 and (frame["iou"] == 0).all()
    for batch in (H_true.copy(), torch.from_numpy(H_true.copy())):
        frame = evaluate(scene, batch, H_true, SIZE)
        assert not frame["failed"].any() and (frame[["iou", "iou_part", "iou_whole"]] == 1.0).all().all()


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
