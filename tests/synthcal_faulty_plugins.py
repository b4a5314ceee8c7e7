"""Test-only plug-in estimators that misbehave, loaded by dotted path like any plug-in.

* :class:`RaisingEstimator` — ``predict`` raises: the run must be recorded as failed.
* :class:`NaNEstimator` — returns NaN matrices: every image fails.
* :class:`InterruptingEstimator` — ``fit`` raises ``KeyboardInterrupt`` once, while
  the file named by ``$SYNTHCAL_TEST_INTERRUPT`` exists (it deletes it), then
  behaves as the identity: a sweep killed midway.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from synthcal.estimators import IdentityEstimator, SceneLike, SplitLike


class RaisingEstimator:
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        pass

    def predict(self, images: np.ndarray) -> np.ndarray:
        raise ValueError("this estimator always fails")


class NaNEstimator:
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        pass

    def predict(self, images: np.ndarray) -> np.ndarray:
        return np.full((len(images), 3, 3), np.nan)


class InterruptingEstimator(IdentityEstimator):
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        marker = Path(os.environ.get("SYNTHCAL_TEST_INTERRUPT", "/nonexistent"))
        if marker.exists():
            marker.unlink()
            raise KeyboardInterrupt("simulated Ctrl-C")
        super().fit(train, dictionary, scene)
