"""Test helper: every shard of ``synthcal generate`` takes at least ``SECONDS`` more to render.

:func:`install` replaces :func:`synthcal.generate.pipeline.run_shard` by :func:`run_shard`,
which the pool pickles by name, so worker processes import this module and render
slowly as well. ``tests/test_cli_errors.py`` interrupts such a run: its workers are
still busy for many seconds when SIGINT arrives, however fast the machine.

Importing alone changes nothing: pytest imports every module under ``tests/`` to
collect doctests (``--doctest-modules``), and a patch made on import would slow
every store the rest of the suite generates by a second a shard.
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


def install() -> None:
    """Make this process's ``synthcal generate`` render through :func:`run_shard`."""
    pipeline.run_shard = run_shard
