"""Test-only plug-in estimators with constructor options (loaded by dotted path).

* :class:`OptionRecordingEstimator` — the identity, recording in ``history`` the options
  its constructor received: what reached it through ``bench``.
* :class:`RequiredOptionEstimator` — a constructor with a required ``threshold``.
* :class:`AnyOptionEstimator` — ``__init__(self, **options)``: takes any key.
"""

from __future__ import annotations

from typing import Any, Literal

from synthcal.estimators import IdentityEstimator


class OptionRecordingEstimator(IdentityEstimator):
    def __init__(self, ratio: float = 0.5, mode: Literal["fast", "slow"] = "fast", cross: bool = False,
                 steps: int = 1, name: str | None = None) -> None:
        super().__init__()
        self.history: dict[str, Any] = {"options": {"ratio": ratio, "mode": mode, "cross": cross, "steps": steps,
                                                    "name": name}}


class RequiredOptionEstimator(IdentityEstimator):
    def __init__(self, threshold: float) -> None:
        super().__init__()
        self.threshold = threshold


class AnyOptionEstimator(IdentityEstimator):
    def __init__(self, **options: Any) -> None:
        super().__init__()
        self.history: dict[str, Any] = {"options": options}
