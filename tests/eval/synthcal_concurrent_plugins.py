"""Test-only plug-in for ``bench --workers`` (loaded by dotted path).

:class:`RendezvousEstimator` — the identity; ``fit`` leaves a file named by its seed in
``$SYNTHCAL_TEST_RENDEZVOUS`` and waits (at most 60 s) for another seed's file: it meets
another run only when two execute at once. ``history`` records whether it met one and
torch's thread count in its process.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import torch

from synthcal.estimators import IdentityEstimator, SceneLike, SplitLike


class RendezvousEstimator(IdentityEstimator):
    def __init__(self, seed: int = 0) -> None:
        super().__init__()
        self.seed = seed
        self.history: dict[str, Any] = {}

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        folder = Path(os.environ["SYNTHCAL_TEST_RENDEZVOUS"])
        (folder / str(self.seed)).touch()
        deadline = time.monotonic() + 60
        met = False
        while not met and time.monotonic() < deadline:
            met = any(path.name != str(self.seed) for path in folder.iterdir())
            time.sleep(0.05)
        self.history = {"met": met, "threads": torch.get_num_threads()}
        super().fit(train, dictionary, scene)
