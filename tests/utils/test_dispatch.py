"""Stopping a local dispatch early leaves nothing running behind it."""

import multiprocessing
import threading
import time

import pytest

from synthcal.utils.dispatch import dispatch


def test_closing_a_dispatch_early_leaves_no_worker_and_no_pool_thread():
    # time.sleep pickles by name; one short task gives a first result while the others still sleep.
    results = dispatch(time.sleep, [0.0, 30.0, 30.0, 30.0], workers=2)
    assert next(results) is None
    results.close()
    # A pool thread still alive here races the interpreter's exit hook, which writes to the pipe that
    # thread closes: "OSError: Bad file descriptor" after our one-line Ctrl-C message (seen in CI).
    pool_threads = [t.name for t in threading.enumerate() if type(t).__name__ == "_ExecutorManagerThread"]
    assert pool_threads == []
    assert multiprocessing.active_children() == []



def test_a_started_pool_serves_dispatch_with_the_same_workers_and_stops_on_leaving():
    from synthcal.utils.dispatch import worker_pool

    with worker_pool(2) as pool:
        children = set(multiprocessing.active_children())
        assert pool is not None and len(children) == 2  # started before any dispatch
        assert sorted(dispatch(abs, [-3, -1, -2], pool=pool)) == [1, 2, 3]
        assert set(multiprocessing.active_children()) == children  # the same workers, left running
    assert multiprocessing.active_children() == []
    with worker_pool(1) as none:
        assert none is None  # one worker: the caller's own process


def test_the_workers_import_the_preloaded_modules_as_they_start():
    from concurrent.futures.process import BrokenProcessPool

    from synthcal.utils.dispatch import worker_pool

    with pytest.raises(BrokenProcessPool), worker_pool(2, preload=("synthcal_no_such_module",)) as pool:
        list(dispatch(abs, [1, 2], pool=pool))
    assert multiprocessing.active_children() == []
