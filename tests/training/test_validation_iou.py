"""The validation ``iou`` that can rank fits (``training.selection_score: iou``) against the scorer's own code:
SPEC §8's ``iou`` (:func:`synthcal.eval.metrics.semantic_readings`), SPEC §2's sign rule
(:func:`synthcal.generate.camera.orient_homography`) and the generator's renderer."""

from pathlib import Path

import numpy as np
import pytest
import torch

from synthcal.config import load_config
from synthcal.data import load_split, load_splits
from synthcal.estimators import load_estimator
from synthcal.eval.metrics import semantic_readings
from synthcal.generate.camera import orient_homography
from synthcal.generate.render import render_semantic
from synthcal.generate.splits import draw_splits
from synthcal.training import class_iou, orient_homographies, resolution_matrix

ROOT = Path(__file__).resolve().parents[2]


def test_class_iou_is_the_scorers_iou_per_map():
    rng = np.random.default_rng(0)
    # Some maps lack a class or every foreground class: the "present in either" rule matters.
    shares = [[0.7, 0.1, 0.1, 0.1], [0.9, 0.1, 0, 0], [1, 0, 0, 0], [0.4, 0, 0.3, 0.3]] * 2
    predicted, target = (np.stack([rng.choice(4, size=(12, 16), p=p) for p in shares]) for _ in range(2))
    predicted[3] = target[3]  # an exact estimate
    ours = class_iou(torch.from_numpy(predicted), torch.from_numpy(target)).numpy()
    theirs = [semantic_readings(p, t)["iou"] for p, t in zip(predicted, target, strict=True)]
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12)
    assert ours[3] == 1.0 and ours[2] == 1.0  # exact; neither map shows a foreground class
    assert 0.0 < ours[0] < 1.0


def test_the_sign_is_fixed_as_the_scorer_fixes_it():
    rng = np.random.default_rng(1)
    size = (32, 18)
    homographies = rng.normal(size=(64, 3, 3))
    ours = orient_homographies(torch.from_numpy(homographies), size).numpy()
    theirs = orient_homography(homographies, size)
    np.testing.assert_array_equal(ours, theirs)
    assert (ours != homographies).any() and (ours == homographies).any()  # both branches taken


@pytest.fixture(scope="module")
def splits(smoke_stores, tmp_path_factory):
    path = smoke_stores.copy(["intersection-1"], tmp_path_factory.mktemp("select-iou"))["intersection-1"]
    draw_splits(path, seeds=[0])
    return {**load_splits(path, 0), "validation": load_split(path, "validation", 0)}


def test_fits_ranked_by_validation_iou_score_what_the_renderer_and_scorer_give(splits):
    validation = splits["validation"]
    semantics = np.asarray(validation.semantics)
    work_size = (semantics.shape[2] // 2, semantics.shape[1] // 2)  # not the image's: A must be applied
    settings = {**load_config(ROOT / "datasets.yaml").training("smoke").settings(), "stn_epochs": 3, "patience": 3,
                "select": {"learning_rate": [1e-4, 3e-3]}, "selection_score": "iou", "work_size": work_size}
    estimator = load_estimator("proposed", settings=settings, device="cpu", segmentation="ground-truth")
    estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=validation)
    selection = estimator.selection
    assert selection["score"] == "1 − iou of the estimates (working resolution)"
    scores = selection["scores"]["learning_rate"]
    chosen = int(np.argmin(scores))
    assert selection["chosen"]["learning_rate"] == [1e-4, 3e-3][chosen]
    # The kept fit's score, recomputed from its predictions with the generator's renderer and the scorer's iou
    # at the working resolution (validation's true maps in, full-resolution homographies out).
    A = resolution_matrix((semantics.shape[2], semantics.shape[1]), work_size)
    estimates = orient_homography(A @ estimator.predict_semantic(semantics), work_size)
    truths = A @ np.asarray(validation.homographies, np.float64)
    scene = np.asarray(splits["train"].scene.semantic)
    iou = np.mean([semantic_readings(render_semantic(scene, H, work_size), render_semantic(scene, T, work_size))["iou"]
                   for H, T in zip(estimates, truths, strict=True)])
    assert 0.0 < iou < 1.0
    assert scores[chosen] == pytest.approx(1.0 - iou, abs=1e-3)  # a pixel on a rounding boundary may flip
    # Its epochs were ranked by the same score: the kept epoch's is the kept fit's.
    assert estimator.history["stn-validation"][selection["chosen"]["stn_epochs"] - 1] == pytest.approx(scores[chosen])


def test_a_selection_score_without_anything_to_rank_is_refused():
    from synthcal.config import TrainingSettings

    with pytest.raises(ValueError, match="selection_score 'iou' ranks fits .* set patience or select"):
        TrainingSettings(selection_score="iou")
    assert TrainingSettings(selection_score="iou", patience=2).selection_score == "iou"
