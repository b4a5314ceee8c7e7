"""Test helper: every shard of ``synthcal generate`` takes at least ``SECONDS`` more to render.

Importing it replaces :func:`synthcal.generate.pipeline.run_shard` by :func:`run_shard`,
which the pool pickles by name, so worker processes import this module too and
render slowly as well. ``tests/test_cli_errors.py`` interrupts such a run: its
workers are still busy for many seconds when SIGINT arrives, however fast the machine.
"""

from __future__ import annotations

import time

from synthcal.generate import pipeline

SECONDS = 1.0

_render = pipeline.run_shard


def run_shard(task: pipeline.ShardTask) -> int:
    """Sleep, then render and write the shard as usual."""
    time.sleep(SECONDS)
    return _render(task)


pipeline.run_shard = run_shard
