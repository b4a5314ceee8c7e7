"""Test-only plug-in estimators for retries, devices, split sizes and Ctrl-C (loaded by dotted path).

* :class:`FlakyEstimator` — ``fit`` raises while the file named by ``$SYNTHCAL_TEST_BROKEN``
  exists (a bug), else the identity (the bug fixed).
* :class:`SizeRecordingEstimator` — the identity, recording in ``history`` the sizes it is
  handed (train, dictionary and its sources, test) and the device it was given.
* :class:`SlowEstimator` — ``predict`` writes its PID to ``$SYNTHCAL_TEST_SLOW.started``,
  then waits while ``$SYNTHCAL_TEST_SLOW`` exists (at most two minutes): a run to interrupt.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from synthcal.estimators import IdentityEstimator, SceneLike, SplitLike


def _flag(name: str) -> Path:
    return Path(os.environ.get(name, "/nonexistent/flag"))


class FlakyEstimator(IdentityEstimator):
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        if _flag("SYNTHCAL_TEST_BROKEN").exists():
            raise RuntimeError("not fixed yet")
        super().fit(train, dictionary, scene)


class SizeRecordingEstimator(IdentityEstimator):
    def __init__(self, device: str = "unset") -> None:
        super().__init__()
        self.history: dict[str, Any] = {"device": device}

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        source = getattr(dictionary, "source", None)
        self.history.update(train=len(train.images), dictionary=len(dictionary.images),
                            dictionary_sources=[] if source is None else np.bincount(source).tolist())
        super().fit(train, dictionary, scene)

    def predict(self, images: np.ndarray) -> np.ndarray:
        self.history["test"] = len(images)
        return super().predict(images)


class SlowEstimator(IdentityEstimator):
    def predict(self, images: np.ndarray) -> np.ndarray:
        flag = _flag("SYNTHCAL_TEST_SLOW")
        flag.with_suffix(".started").write_text(str(os.getpid()))
        deadline = time.monotonic() + 120
        while flag.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        return super().predict(images)
