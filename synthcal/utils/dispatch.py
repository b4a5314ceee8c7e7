"""Running independent tasks here, on local worker processes, or on a Dask cluster.

Generation farms out shards (:mod:`synthcal.generate.pipeline`) and the harness
runs (:mod:`synthcal.eval.harness`) through :func:`dispatch`; both write their
results to files, so the order in which tasks finish never shapes the output.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import TypeVar

__all__ = ["dispatch"]

T = TypeVar("T")
R = TypeVar("R")


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
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            for future in as_completed([pool.submit(fn, task) for task in tasks]):
                yield future.result()
