"""Timing shared by the benchmarks: the machine is shared and noisy, so take the best of several calls."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any


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


def add_stn_stage_arguments(parser: argparse.ArgumentParser) -> None:
    """The STN-stage benchmarks' shared options: ``--size W H``, ``--batch``, ``--batches``, ``--epochs``."""
    parser.add_argument("--size", type=int, nargs=2, default=(128, 72), metavar=("W", "H"),
                        help="work size (default: the quick profile's 128 × 72)")
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--batches", type=int, default=4, help="batches per epoch")
    parser.add_argument("--epochs", type=int, default=3)


def compared_weights(first: dict[str, Any], second: dict[str, Any]) -> tuple[bool, float]:
    """Whether two state dicts (``nn.Module.state_dict()``) are equal to the bit, and their largest difference."""
    import torch

    pairs = [(first[key], second[key]) for key in first]
    same = all(torch.equal(a, b) for a, b in pairs)
    return same, max((a - b).abs().max().item() for a, b in pairs if a.is_floating_point())
