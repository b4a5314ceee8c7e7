"""How docs/reproduction.md prints a difference, shared by the sweep scripts that print its tables.

The package's own tables (``synthcal table``) print an ASCII minus; the report's prose uses a true minus sign, so the
scripts whose output is pasted into the report format their figures here.
"""

from __future__ import annotations


def signed(value: float) -> str:
    """``+2.34`` / ``−3.05``: a difference as the report prints it (a true minus sign)."""
    return f"{value:+.2f}".replace("-", "\u2212")


def interval(mean: float, low: float, high: float) -> str:
    """``−0.35 [−1.47, +0.78]``: a paired difference and its 95 % t interval."""
    return f"{signed(mean)} [{signed(low)}, {signed(high)}]"
