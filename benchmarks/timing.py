"""Timing shared by the benchmarks: the machine is shared and noisy, so take the best of several calls."""

from __future__ import annotations

import time
from collections.abc import Callable


def best_of(repeat: int, fn: Callable[[], object], clock: Callable[[], float] = time.perf_counter) -> float:
    """Smallest time, in seconds, of ``repeat`` calls of ``fn``: wall time, or ``clock``'s
    (``time.process_time``: CPU time, which waiting for a core shared with other jobs does
    not count)."""
    times = []
    for _ in range(repeat):
        started = clock()
        fn()
        times.append(clock() - started)
    return min(times)
