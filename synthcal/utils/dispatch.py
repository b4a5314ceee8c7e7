"""Running independent tasks here, on local worker processes, or on a Dask cluster.

Generation farms out shards (:mod:`synthcal.generate.pipeline`) and the harness
runs (:mod:`synthcal.eval.harness`) through :func:`dispatch`; both write their
results to files, so the order in which tasks finish never shapes the output.

Local worker processes die with their parent: each sets, on Linux, a parent-death
signal (``prctl(PR_SET_PDEATHSIG, SIGKILL)``) as it starts, so a ``kill -9`` of the
parent leaves no orphan rendering on (the resource tracker then sees its last
user gone and exits too). Elsewhere a worker checks its parent at every task.
"""

from __future__ import annotations

import ctypes
import functools
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import TypeVar

__all__ = ["dispatch", "die_with_parent"]

T = TypeVar("T")
R = TypeVar("R")

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(parent: int) -> None:
    """Make this process end when process ``parent`` does (a pool worker's initializer).

    On Linux the kernel sends SIGKILL when the parent dies; if the parent is already
    gone (it died before this ran), exit now. Elsewhere this does nothing here and
    :func:`_guarded` checks the parent before each task.
    """
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:
        os._exit(1)


def _guarded(fn: Callable[[T], R], parent: int, task: T) -> R:
    """``fn(task)`` unless the parent is gone (a worker orphaned where no death signal exists)."""
    if os.getppid() != parent:
        os._exit(1)
    return fn(task)


def dispatch(fn: Callable[[T], R], tasks: Sequence[T], workers: int = 1, scheduler: str | None = None) -> Iterator[R]:
    """``fn(task)`` for every task, yielded as each finishes (any order but in-process).

    Args:
        fn: a picklable (module-level, or a :func:`functools.partial` of one) function.
        tasks: picklable task arguments.
        workers: local worker processes; 1 (or less) runs the tasks one after another
            in this process, in order.
        scheduler: a Dask distributed scheduler address (``tcp://host:port``); overrides
            ``workers``.

    Yields:
        the results; an exception raised by a task is raised here when its result is reached.
    """
    if scheduler is not None:
        from dask.distributed import Client
        from dask.distributed import as_completed as dask_completed

        with Client(scheduler) as client:
            for future in dask_completed(client.map(fn, tasks, pure=False)):  # pure=False: never deduplicated
                yield future.result()
    elif workers <= 1:
        yield from map(fn, tasks)
    else:
        # spawn, not fork: the parent may hold threads (OpenCV, torch, the progress bar)
        # that a forked child would inherit mid-state; and it is what every OS has.
        parent = os.getpid()
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                 initializer=die_with_parent, initargs=(parent,)) as pool:
            call = functools.partial(_guarded, fn, parent)
            for future in as_completed([pool.submit(call, task) for task in tasks]):
                yield future.result()
