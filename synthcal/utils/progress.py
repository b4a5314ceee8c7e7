"""Whether to draw progress bars: only on a terminal.

tqdm bars redraw themselves in place with carriage returns; written to a file or a
CI log, every redraw becomes a line (nested epoch bars gave thousands). Every bar
synthcal draws asks :func:`show_progress` first.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["interactive", "show_progress"]


def interactive(stream: TextIO | None = None) -> bool:
    """Whether ``stream`` (default: standard error, where bars go) is a terminal.

    >>> import io
    >>> interactive(io.StringIO())
    False
    """
    stream = sys.stderr if stream is None else stream
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # replaced by an object without isatty, or closed
        return False


def show_progress(progress: bool | None = None) -> bool:
    """``progress``, where None (the default of synthcal's functions) means: on a terminal only.

    >>> show_progress(False), show_progress(True)
    (False, True)
    """
    return interactive() if progress is None else progress
