"""Metrics (SPEC §8): oracle, hand-computed cases, sign handling, failures, and the
exact polygon areas against brute-force rasterisation."""

import cv2
import numpy as np
import pandas as pd
import pytest
import torch

from synthcal.eval.metrics import (
    METRICS,
    READINGS,
    TruthError,
    check_homography,
    check_truth,
    completeness,
    evaluate,
    iou,
    iou_part,
    iou_whole,
    readings,
    semantic_iou,
    semantic_readings,
    summarize,
)
from synthcal.generate.camera import homography
from synthcal.scenes import build_scene
from synthcal.scenes.soccer import CAMERA_POSITION as SOCCER_CAMERA
from synthcal.scenes.soccer import HEADING_DEG as SOCCER_HEADING

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
    # Checked estimates come back oriented and scaled to a largest entry of 1.
    np.testing.assert_allclose(check_homography(H / H[2, 2], SIZE)[0], H / np.abs(H).max(), rtol=1e-12)


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


# --- the three readings of the paper's IoU (SPEC §8) ---------------------------------------


@pytest.mark.parametrize("estimate, truth, expected", [
    # Class 3 only in the estimate; per class J0 = 1/3, J1 = 2/4, J2 = 2/3, J3 = 0/1;
    # true shares 2/8, 3/8, 3/8, 0.
    ([0, 1, 1, 1, 3, 2, 2, 0], [0, 0, 1, 1, 1, 2, 2, 2],
     {"iou": (1 / 2 + 2 / 3 + 0) / 3, "iou_bg": (1 / 3 + 1 / 2 + 2 / 3 + 0) / 4,
      "iou_weighted": 2 / 8 * 1 / 3 + 3 / 8 * 1 / 2 + 3 / 8 * 2 / 3}),
    # The true view shows background only: J0 = 2/4, J1 = 0/2 (estimate only).
    ([0, 0, 1, 1], [0, 0, 0, 0], {"iou": 0.0, "iou_bg": 1 / 4, "iou_weighted": 1 / 2}),
    # The estimate shows background only: J0 = 2/4, J1 = 0/2 (truth only), true shares 1/2, 1/2.
    ([0, 0, 0, 0], [0, 0, 1, 1], {"iou": 0.0, "iou_bg": 1 / 4, "iou_weighted": 1 / 4}),
    # Both background only: they agree.
    ([0, 0, 0, 0], [0, 0, 0, 0], {"iou": 1.0, "iou_bg": 1.0, "iou_weighted": 1.0}),
])
def test_three_readings_by_hand(estimate, truth, expected):
    scores = semantic_readings(np.array([estimate], np.uint8), np.array([truth], np.uint8))
    assert scores == pytest.approx(expected, abs=1e-15)
    assert scores["iou"] == semantic_iou(np.array([estimate]), np.array([truth]))


def test_readings_match_scikit_learn_on_random_maps():
    """iou_weighted is sklearn's weighted Jaccard; iou_bg and iou are its macro mean over the present classes."""
    metrics = pytest.importorskip("sklearn.metrics")
    rng = np.random.default_rng(11)
    for trial in range(30):
        shape = tuple(rng.integers(3, 40, 2))
        # Some maps lack some classes (in one view or both), as real views do.
        truth_classes = rng.choice(4, rng.integers(1, 5), replace=False)
        estimate_classes = rng.choice(4, rng.integers(1, 5), replace=False)
        truth = rng.choice(truth_classes, shape).astype(np.uint8)
        estimate = truth.copy() if trial == 0 else rng.choice(estimate_classes, shape).astype(np.uint8)
        scores = semantic_readings(estimate, truth)
        y_true, y_pred = truth.ravel(), estimate.ravel()
        present = np.union1d(y_true, y_pred)
        assert scores["iou_weighted"] == pytest.approx(
            metrics.jaccard_score(y_true, y_pred, average="weighted", zero_division=0), abs=1e-12)
        assert scores["iou_bg"] == pytest.approx(
            metrics.jaccard_score(y_true, y_pred, labels=present, average="macro", zero_division=0), abs=1e-12)
        foreground = present[present > 0]
        if len(foreground):
            assert scores["iou"] == pytest.approx(
                metrics.jaccard_score(y_true, y_pred, labels=foreground, average="macro", zero_division=0), abs=1e-12)


def test_readings_come_from_the_two_renders():
    """Shifted stripes (no background in view): every class has IoU (8 − d)/(8 + d), so all three agree."""
    scene, d = stripes(), 2
    H_true, H_est = top_down(96, 50), top_down(96 + d, 50)
    assert readings(scene, H_est, H_true, SIZE) == pytest.approx(dict.fromkeys(READINGS, (8 - d) / (8 + d)), abs=1e-12)
    frame = evaluate(scene, [H_est, H_true, None], np.stack([H_true] * 3), SIZE)
    assert list(frame.columns[:5]) == list(METRICS) == ["iou", "iou_bg", "iou_weighted", "iou_part", "iou_whole"]
    assert frame.loc[0, list(READINGS)].tolist() == pytest.approx([(8 - d) / (8 + d)] * 3, abs=1e-12)
    assert (frame.loc[1, list(METRICS)] == 1.0).all() and (frame.loc[2, list(METRICS)] == 0.0).all()
    assert readings(scene, None, H_true, SIZE) == dict.fromkeys(READINGS, 0.0)


# --- the truth, the estimate's scale, skipped images -------------------------------------------


def test_a_true_homography_breaking_the_sign_rule_raises_with_the_sample():
    scene = blobs(4)
    H_true = np.stack([perspective(0, -10, 30), perspective(5, -12, 30)])
    bad = H_true.copy()
    bad[1] *= -1  # the negated truth: its bottom-centre pixel sees the ground behind the camera
    with pytest.raises(TruthError, match=r"store\.zarr: true homography of sample 17: its bottom-centre"):
        evaluate(scene, H_true, bad, SIZE, indices=[4, 17], source="store.zarr")
    with pytest.raises(TruthError, match="sample 0"):
        check_truth(np.full((3, 3), np.nan), SIZE, 0)
    np.testing.assert_allclose(check_truth(7.0 * H_true[0], SIZE), H_true[0] / np.abs(H_true[0]).max())


def _nan_entry(H: np.ndarray) -> np.ndarray:
    H = H.copy()
    H[1, 2] = np.nan
    return H


@pytest.mark.parametrize("metric", ["iou", "readings", "iou_part", "iou_whole"])
@pytest.mark.parametrize("truth", [_nan_entry, np.zeros_like], ids=["nan-entry", "zero"])
def test_every_metric_refuses_invalid_truth(metric, truth):
    """A NaN in the truth or a zero truth is an error in the data, not a score of 0 (nor a LinAlgError)."""
    scene = blobs(5)
    good = perspective(0, -10, 30)
    score = {"iou": lambda H: iou(scene, good, H, SIZE), "readings": lambda H: readings(scene, good, H, SIZE),
             "iou_part": lambda H: iou_part(scene.shape, good, H, SIZE),
             "iou_whole": lambda H: iou_whole(good, H, SIZE)}[metric]
    assert score(good) == (dict.fromkeys(READINGS, 1.0) if metric == "readings" else 1.0)
    with pytest.raises(TruthError, match=r"^true homography is not a finite \(3, 3\) matrix"):
        score(truth(good))


@pytest.mark.parametrize("scale", [1e150, 1e-150, 3.0, -1e150])
def test_scores_do_not_depend_on_the_estimates_scale(scale):
    scene = blobs(5)
    H_true = perspective(3, -12, 32)
    H_est = perspective(5, -11, 30)
    reference = evaluate(scene, H_est[None], H_true[None], SIZE)
    scaled = evaluate(scene, (scale * H_est)[None], H_true[None], SIZE)
    assert 0 < reference.loc[0, "iou"] < 1 and not scaled.loc[0, "failed"]
    pd.testing.assert_frame_equal(scaled, reference)


def test_truth_seeing_no_field_is_skipped_and_counted():
    scene = blobs(6)
    field = [[0, 0], [10, 0], [10, 10], [0, 10]]  # a field the truth below does not see
    H_true = np.stack([top_down(96, 50), top_down(0, 0)])  # sees u ∈ [95.5, 143.5]; then the field
    frame = evaluate(scene, np.stack([top_down(0, 0), top_down(0, 0)]), H_true, SIZE, field=field)
    assert frame["skipped"].tolist() == [True, False] and frame.loc[0, list(METRICS)].isna().all()
    assert (frame.loc[1, list(METRICS)] == 1.0).all()
    summary = summarize(frame)
    assert summary["n_skipped"] == 1 and summary["n_images"] == 1 and summary["iou"] == 1.0
    # Outside evaluate, an empty true region is never agreement: the estimate scores 0.
    assert iou_part(scene.shape, top_down(96, 50), top_down(96, 50), SIZE, field=field) == 0.0
    assert iou_part(scene.shape, top_down(0, 0), top_down(96, 50), SIZE, field=field) == 0.0


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
