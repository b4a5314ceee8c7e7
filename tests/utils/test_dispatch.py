"""Stopping a local dispatch early leaves nothing running behind it."""

import multiprocessing
import threading
import time

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
