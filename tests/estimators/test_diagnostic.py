"""oracle-template against an independent NumPy matching score on a hand-made dictionary."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from synthcal.estimators import load_estimator
from synthcal.estimators.diagnostic import OracleTemplateEstimator

ALPHA = BETA = 0.3


def _patch_mse(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(4, 4) per-patch MSE of two class-id maps, ``sum`` over classes: 2 × the share of differing pixels."""
    rows = zip(np.array_split(q, 4, axis=0), np.array_split(t, 4, axis=0), strict=True)
    return np.array([[2.0 * (a != b).mean() for a, b in zip(np.array_split(qr, 4, axis=1),
                                                             np.array_split(tr, 4, axis=1), strict=True)]
                     for qr, tr in rows])


def _score(q: np.ndarray, t: np.ndarray, score: str) -> float:
    """SPEC §7: plain MSE, or L_Top = mean over patches of ℓ_ij + α Σ_neighbours (incl. itself) max(0, ℓ − β)."""
    if score == "mse":
        return 2.0 * float((q != t).mean())
    mse = _patch_mse(q, t)
    hinge = np.pad(np.maximum(0.0, mse - BETA), 1)
    neighbours = sum(hinge[1 + di:5 + di, 1 + dj:5 + dj] for di in (-1, 0, 1) for dj in (-1, 0, 1))
    return float((mse + ALPHA * neighbours).mean())


@pytest.fixture
def dictionary():
    rng = np.random.default_rng(0)
    truth = rng.integers(0, 4, (3, 24, 32), dtype=np.uint8)
    # Each test map's templates: itself with a share of its pixels relabelled, clumped or scattered.
    templates = []
    for t in truth:
        for share in (0.05, 0.15, 0.3):
            scattered = t.copy()
            mask = rng.random(t.shape) < share
            scattered[mask] = (scattered[mask] + 1) % 4
            clumped = t.copy()
            rows = int(share * 24 * 1.5)
            clumped[:rows] = (clumped[:rows] + 1) % 4
            templates += [scattered, clumped]
    templates = np.stack(templates)
    homographies = rng.normal(size=(len(templates), 3, 3))
    return truth, SimpleNamespace(semantics=templates, homographies=homographies)


@pytest.mark.parametrize("matching", ["top-mse", "mse"])
def test_oracle_picks_the_template_of_lowest_true_score(dictionary, matching):
    truth, split = dictionary
    oracle = OracleTemplateEstimator(matching=matching, device="cpu")
    oracle.fit(split, split, None)
    scores = np.array([[_score(q, t, matching.replace("-", "_")) for t in split.semantics] for q in truth])
    np.testing.assert_array_equal(oracle.predict_semantic(truth), split.homographies[scores.argmin(1)])
    assert len(set(scores.argmin(1))) == len(truth)  # a different template per map: the check can fail


def test_oracle_scores_differ_by_matching(dictionary):
    """The two scores disagree on this dictionary somewhere, so the option is not idle."""
    truth, split = dictionary
    picks = {}
    for matching in ("top-mse", "mse"):
        oracle = OracleTemplateEstimator(matching=matching, device="cpu")
        oracle.fit(split, split, None)
        picks[matching] = oracle.predict_semantic(truth)
    assert not np.array_equal(picks["top-mse"], picks["mse"])


def test_oracle_returns_the_truth_when_it_is_in_the_dictionary(dictionary):
    truth, split = dictionary
    homographies = np.concatenate([split.homographies, np.arange(27.0).reshape(3, 3, 3)])
    with_truth = SimpleNamespace(semantics=np.concatenate([split.semantics, truth]), homographies=homographies)
    oracle = load_estimator("synthcal.estimators.diagnostic:OracleTemplateEstimator", device="cpu")
    oracle.fit(with_truth, with_truth, None)
    np.testing.assert_array_equal(oracle.predict_semantic(truth), homographies[-3:])
    with pytest.raises(RuntimeError, match="segmentation ground-truth"):
        oracle.predict(np.zeros((1, 24, 32, 3), np.uint8))
