"""The pixel errors (SPEC §8): reproj_px, acc@k and corner_error against closed forms and OpenCV."""

import cv2
import numpy as np
import pandas as pd
import pytest
from metric_cases import SIZE, blobs, perspective

from synthcal.eval.plots import plot_iou
from synthcal.eval.reprojection import corner_error, ground_grid, reproj_px
from synthcal.eval.scoring import evaluate, summarize
from synthcal.eval.statistics import paired_frame
from synthcal.eval.tables import aggregate, format_table

SCENE = blobs(7)
STEEP = perspective(0, -30, 30)  # its four image corners see the ground
SHALLOW = perspective(0, -10, 30)  # its top corners look above the horizon
CORNERS = np.array([[-0.5, -0.5], [SIZE[0] - 0.5, -0.5], [SIZE[0] - 0.5, SIZE[1] - 0.5], [-0.5, SIZE[1] - 0.5]])


def image_shift(dx: float, dy: float) -> np.ndarray:
    return np.array([[1.0, 0, dx], [0, 1.0, dy], [0, 0, 1.0]])


def opencv_reproj(H_est: np.ndarray, H_true: np.ndarray) -> float:
    """The reading recomputed independently: the grid written out by hand, OpenCV's projections."""
    v, u = np.meshgrid(np.arange(0, SCENE.shape[0], 10), np.arange(0, SCENE.shape[1], 10), indexing="ij")
    ground = np.stack([u.ravel(), v.ravel()], 1).astype(np.float64)
    depth = ground @ H_true[2, :2] + H_true[2, 2]
    truth = cv2.perspectiveTransform(ground[:, None], H_true)[:, 0]
    inside = (depth > 0) & np.all((truth >= -0.5) & (truth <= np.array(SIZE) - 0.5), axis=1)
    assert inside.sum() > 50  # the case measures something
    estimate = cv2.perspectiveTransform(ground[inside, None], H_est)[:, 0]
    return float(np.linalg.norm(estimate - truth[inside], axis=1).mean())


@pytest.mark.parametrize(("dx", "dy"), [(3.0, 4.0), (-6.0, 0.5), (0.0, -12.0)])
def test_an_image_shift_gives_its_length(dx, dy):
    for H_true in (STEEP, SHALLOW):
        H_est = image_shift(dx, dy) @ H_true
        assert reproj_px(H_est, H_true, SIZE, SCENE.shape) == pytest.approx(np.hypot(dx, dy), rel=1e-9)


def test_reproj_px_agrees_with_opencv_and_ignores_scale_and_sign():
    H_est = perspective(3, -28, 33) @ np.array([[1.0, 0.02, 4], [0, 0.98, -3], [0, 0, 1]])
    expected = opencv_reproj(H_est, STEEP)
    assert expected > 1
    for scale in (1.0, -3.0, 1e-120):
        assert reproj_px(scale * H_est, STEEP, SIZE, SCENE.shape) == pytest.approx(expected, rel=1e-9)


def test_a_ground_shift_gives_its_length_at_the_corners():
    a, b = 7.0, -24.0
    H_est = STEEP @ np.linalg.inv(image_shift(a, b))  # the estimate sees every ground point moved by (a, b)
    assert corner_error(H_est, STEEP, SIZE) == pytest.approx(np.hypot(a, b), rel=1e-9)
    # Independently: OpenCV sends the corners to the ground through both inverses.
    other = perspective(2, -33, 28)
    ground = [cv2.perspectiveTransform(CORNERS[:, None], np.linalg.inv(H))[:, 0] for H in (other, STEEP)]
    expected = np.linalg.norm(ground[0] - ground[1], axis=1).mean()
    assert corner_error(-2.0 * other, STEEP, SIZE) == pytest.approx(expected, rel=1e-9)


def test_the_truth_scores_zero_exactly_and_failures_are_infinite():
    frame = evaluate(SCENE, [STEEP, None, np.full((3, 3), np.nan)], np.stack([STEEP] * 3), SIZE)
    pixel = ["reproj_px", "acc@5", "acc@10", "acc@20", "corner_error"]
    assert frame.loc[0, pixel].tolist() == [0.0, 1.0, 1.0, 1.0, 0.0]
    assert frame.loc[1, pixel].tolist() == frame.loc[2, pixel].tolist() == [np.inf, 0.0, 0.0, 0.0, np.inf]


def test_points_behind_the_estimated_camera_fail():
    # The estimate puts the top half of the true image behind its camera: depth y / (H/2) − 1 (its
    # bottom-centre pixel still sees the ground, so the orientation keeps this sign).
    behind = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 2.0 / SIZE[1], -1.0]]) @ STEEP
    assert reproj_px(behind, STEEP, SIZE, SCENE.shape) == np.inf
    # An estimate looking near the horizon: its top corners see the sky, the truth's see the ground.
    corners = np.linalg.solve(SHALLOW, np.c_[CORNERS, np.ones(4)].T)
    assert (corners[2, :2] < 0).all()
    assert corner_error(SHALLOW, STEEP, SIZE) == np.inf
    # The truth's own top corners see the sky: no reading (NaN), whatever the estimate.
    assert np.isnan(corner_error(STEEP, SHALLOW, SIZE)) and np.isnan(corner_error(None, SHALLOW, SIZE))


def test_summaries_give_the_median_the_failure_share_and_the_accuracies():
    shifts = [1.0, 2.0, 3.0, 8.0, 30.0]
    estimates = [image_shift(s, 0) @ STEEP for s in shifts] + [None]
    frame = evaluate(SCENE, estimates, np.stack([STEEP] * 6), SIZE)
    np.testing.assert_allclose(frame["reproj_px"], [*shifts, np.inf], rtol=1e-9)
    summary = summarize(frame)
    assert summary["reproj_px"] == pytest.approx(5.5)  # median of 1, 2, 3, 8, 30, inf
    assert summary["reproj_px_failed"] == pytest.approx(1 / 6)
    assert [summary[f"acc@{k}"] for k in (5, 10, 20)] == pytest.approx([3 / 6, 4 / 6, 4 / 6])
    # Images whose true corners see the sky have no corner_error and do not count in it.
    frame = evaluate(SCENE, [STEEP, None, SHALLOW], np.stack([STEEP, STEEP, SHALLOW]), SIZE)
    assert np.isnan(frame.loc[2, "corner_error"])
    summary = summarize(frame)
    assert summary["corner_error"] == np.inf and summary["corner_error_failed"] == 0.5  # median of 0 and inf


def runs(values) -> pd.DataFrame:
    return pd.DataFrame({"dataset": "intersection-1", "model": ["proposed", "sha2020"] * 2, "seed": [0, 0, 1, 1],
                         "reproj_px": values, "completeness": 1.0})


def test_tables_show_pixels_as_they_are_and_bold_the_lowest(tmp_path):
    frame = runs([2.0, 9.0, 4.0, 11.0])
    cells = aggregate(frame, "reproj_px").set_index("model")
    assert cells.loc["proposed", "mean"] == pytest.approx(3.0) and cells.loc["sha2020", "mean"] == pytest.approx(10.0)
    text = format_table(frame, "models", value="reproj_px")
    assert "**3.00 ± 1.41**" in text and "| 10.00 ± 1.41 |" in text and "reproj_px (px)" in text
    # Runs whose median image failed: inf, never the best; a row of infs has none.
    text = format_table(runs([2.0, np.inf, 4.0, np.inf]), "models", value="reproj_px")
    assert "| **3.00 ± 1.41** |" in text and "| inf |" in text
    assert "**" not in format_table(runs([np.inf] * 4), "models", value="reproj_px").splitlines()[2]
    with pytest.raises(ValueError, match="never negative"):
        format_table(runs([2.0, -1.0, 4.0, 3.0]), "models", value="reproj_px")
    pairs = paired_frame(frame, "proposed", "sha2020", value="reproj_px")
    assert pairs["mean"].iloc[0] == pytest.approx(-7.0) and pairs["a_wins"].iloc[0] == 0
    assert plot_iou(frame.assign(training=None, loss=None, matching_score=None, segmentation=None),
                    tmp_path / "px.png", "reproj_px").exists()


def test_the_grid_covers_the_scene_every_ten_pixels():
    points = ground_grid((25, 31))
    assert points.shape == (3, 3 * 4)
    assert set(points[0]) == {0, 10, 20, 30} and set(points[1]) == {0, 10, 20} and (points[2] == 1).all()
