"""Suggestions for a mistyped name, for one-line errors."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["did_you_mean"]


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """``" (did you mean 'smoke'?)"`` for the closest known names, or ``""`` when none is close.

    >>> did_you_mean("smok", ["smoke", "demo", "paper"])
    " (did you mean 'smoke'?)"
    >>> did_you_mean("zzz", ["smoke"])
    ''
    """
    close = difflib.get_close_matches(name, list(known), n=3)
    return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
