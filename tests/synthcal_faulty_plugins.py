"""Test-only plug-in estimators that misbehave, loaded by dotted path like any plug-in.

* :class:`RaisingEstimator` — ``predict`` raises: the run must be recorded as failed.
* :class:`NaNEstimator` — returns NaN matrices: every image fails.
* :class:`InterruptingEstimator` — while the file named by ``$SYNTHCAL_TEST_INTERRUPT``
  exists, ``fit`` deletes it, writes its PID beside it (``.pid``) and sends SIGINT to the
  sweep (its parent process), as Ctrl-C at the terminal would, then waits to be killed;
  otherwise it is the
  identity: a sweep killed midway.
* :class:`SleepingEstimator` — ``predict`` sleeps for an hour: only a time limit ends it.
* :class:`ExitingEstimator` — ``fit`` calls ``os._exit(1)``.
* :class:`SegfaultingEstimator` — ``predict`` reads address 0 (SIGSEGV).
* :class:`MutatingEstimator` — fails if any array it is handed is writeable; else the
  identity, after zeroing ``scene.semantic`` (and the train split's) in ``fit`` by
  any means it can: with the scene's classes gone, every view would score IoU 1.
* :class:`UnreadableEstimator` — ``predict`` returns an object whose ``__array__`` raises.
* :class:`SpawningEstimator` — ``predict`` starts ``sleep 600``, writes its PID to the file
  named by ``$SYNTHCAL_TEST_SPAWNED`` and returns the identity's estimates, leaving it running.
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

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
            marker.with_suffix(".pid").write_text(str(os.getpid()))
            os.kill(os.getppid(), signal.SIGINT)
            time.sleep(60)
        super().fit(train, dictionary, scene)


class SleepingEstimator(IdentityEstimator):
    def predict(self, images: np.ndarray) -> np.ndarray:
        time.sleep(3600)
        return super().predict(images)


class ExitingEstimator(IdentityEstimator):
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        os._exit(1)


class SegfaultingEstimator(IdentityEstimator):
    def predict(self, images: np.ndarray) -> np.ndarray:
        ctypes.string_at(0)
        return super().predict(images)


def _zero(array: Any) -> None:
    """Zero an array in place, making it writeable first if it can."""
    try:
        array.setflags(write=True)
    except (ValueError, AttributeError):
        pass
    try:
        array[...] = 0
    except ValueError:  # read-only: write through the memory it views
        base = array.base if isinstance(array.base, np.ndarray) else array
        try:
            base.setflags(write=True)
            base[...] = 0
        except ValueError:
            pass


class MutatingEstimator(IdentityEstimator):
    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        handed = {"scene.semantic": scene.semantic, "scene.image": scene.image, "train.images": train.images,
                  "train.homographies": train.homographies, "dictionary.semantics": dictionary.semantics}
        writeable = [name for name, array in handed.items() if array.flags.writeable]
        if writeable:
            raise ValueError(f"handed writeable arrays: {writeable}")
        _zero(scene.semantic)
        _zero(train.scene.semantic)  # type: ignore[attr-defined]
        super().fit(train, dictionary, scene)

    def predict(self, images: np.ndarray) -> np.ndarray:
        if images.flags.writeable:
            raise ValueError("handed writeable test images")
        return super().predict(images)


class _Unreadable:
    def __len__(self) -> int:
        return 1

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        raise RuntimeError("no numbers here")


class UnreadableEstimator(IdentityEstimator):
    def predict(self, images: np.ndarray) -> Any:
        return _Unreadable()


class SpawningEstimator(IdentityEstimator):
    def predict(self, images: np.ndarray) -> np.ndarray:
        helper = subprocess.Popen(["sleep", "600"])
        Path(os.environ["SYNTHCAL_TEST_SPAWNED"]).write_text(str(helper.pid))
        return super().predict(images)
