"""A batch of images (SPEC §8): failed estimates, the truth's checks, the estimate's scale and
skipped images."""

import numpy as np
import pandas as pd
import pytest
import torch
from metric_cases import PERFECT, SIZE, blobs, perspective, top_down

from synthcal.config import METRICS
from synthcal.eval.metrics import (
    TruthError,
    check_truth,
    iou,
)
from synthcal.eval.polygon import iou_part, iou_whole
from synthcal.eval.scoring import completeness, evaluate, summarize

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
    assert frame.loc[1, list(METRICS)].tolist() == PERFECT
    summary = summarize(frame)
    assert summary["n_skipped"] == 1 and summary["n_images"] == 1 and summary["iou"] == 1.0
    # Outside evaluate, an empty true region is never agreement: the estimate scores 0.
    assert iou_part(scene.shape, top_down(96, 50), top_down(96, 50), SIZE, field=field) == 0.0
    assert iou_part(scene.shape, top_down(0, 0), top_down(96, 50), SIZE, field=field) == 0.0
