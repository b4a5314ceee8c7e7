"""Per-image metrics (SPEC §8): oracle, hand-computed cases, sign handling, and the three
readings of the paper's IoU."""

import numpy as np
import pytest
from metric_cases import FAILED, PERFECT, SIZE, blobs, perspective, stripes, top_down

from synthcal.config import METRICS, READINGS
from synthcal.eval.metrics import (
    TruthError,
    check_homography,
    iou,
    readings,
    semantic_iou,
    semantic_readings,
)
from synthcal.eval.polygon import iou_part, iou_whole
from synthcal.eval.scoring import evaluate

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
    assert list(frame.columns[:len(METRICS)]) == list(METRICS)
    assert list(METRICS[:5]) == ["iou", "iou_bg", "iou_weighted", "iou_part", "iou_whole"]
    assert frame.loc[0, list(READINGS)].tolist() == pytest.approx([(8 - d) / (8 + d)] * 3, abs=1e-12)
    assert frame.loc[1, list(METRICS)].tolist() == PERFECT and frame.loc[2, list(METRICS)].tolist() == FAILED
    assert readings(scene, None, H_true, SIZE) == dict.fromkeys(READINGS, 0.0)


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
