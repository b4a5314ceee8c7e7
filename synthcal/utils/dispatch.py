"""Running independent tasks here, on local worker processes, or on a Dask cluster.

Generation farms out shards (:mod:`synthcal.generate.pipeline`) and the harness
runs (:func:`synthcal.eval.harness.run_sweep`) through :func:`dispatch`; both write their
results to files, so the order in which tasks finish never shapes the output.

Local worker processes die with their parent: each sets, on Linux, a parent-death
signal (``prctl(PR_SET_PDEATHSIG, SIGKILL)``) as it starts, so a ``kill -9`` of the
parent leaves no orphan rendering on (the resource tracker then sees its last
user gone and exits too). Elsewhere a worker checks its parent at every task.

Interrupting: local workers ignore SIGINT (a Ctrl-C reaches the whole process
group), so the parent alone decides. When the parent stops consuming — Ctrl-C,
a task's error, the consumer closing the generator — the workers are terminated
at once and the tasks not yet started are cancelled, instead of the pool
finishing them first. A Dask scheduler that does not answer within
:data:`CONNECT_TIMEOUT` seconds is an error naming its address
(:class:`SchedulerUnreachable`).
"""

from __future__ import annotations

import ctypes
import functools
import importlib
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    from dask.distributed import Client

__all__ = ["CONNECT_TIMEOUT", "SchedulerUnreachable", "UnguardedScript", "check_main_guarded", "check_scheduler",
           "dispatch", "worker_pool", "die_with_parent", "usable_cores", "thread_environment"]

CONNECT_TIMEOUT = 5.0
"""Seconds to wait for a Dask scheduler to answer (Dask's own default is 30)."""

T = TypeVar("T")
R = TypeVar("R")

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity where the OS has one), at least 1."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def thread_environment(threads: int) -> dict[str, str]:
    """The variables that set the thread count of torch and the BLAS libraries, all to ``threads``.

    Read when those libraries are imported: set them before the import, or in a child's environment.
    """
    return {name: str(threads) for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")}


class UnguardedScript(RuntimeError):
    """Worker processes would re-run the main script, which has no ``if __name__ == "__main__":``."""


def check_main_guarded() -> None:
    """Refuse to start spawned workers from a script without a ``__main__`` guard.

    A spawned worker imports the main script again to find the task's function; without
    the guard, that import runs the script's calls again (a second ``generate`` of the same
    store in every worker, which fails on the store's lock with a traceback per worker).

    Raises:
        UnguardedScript: naming the script.
    """
    import ast

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or getattr(main, "__spec__", None) is not None:  # -c, a notebook, -m: safe
        return
    try:
        tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return
    for node in tree.body:
        if isinstance(node, ast.If) and "__main__" in ast.unparse(node.test) and "__name__" in ast.unparse(node.test):
            return
    raise UnguardedScript(f"{path}: workers > 1 start processes that import this script again and so re-run its "
                          f"calls: put them under `if __name__ == \"__main__\":` (or use workers=1)")


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


def _worker_start(parent: int, preload: tuple[str, ...] = ()) -> None:
    """A local pool worker's initializer: die with the parent, leave Ctrl-C to it, import ``preload``.

    The worker started with SIGINT blocked (:func:`_sigint_blocked`); ignoring it
    discards one that arrived meanwhile, then unblocking is safe.
    """
    die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if "fork" in multiprocessing.get_all_start_methods():
        # Locks made here with the default context (numcodecs' Blosc makes one) are then
        # anonymous semaphores, so a worker terminated mid-task leaves no named one for the
        # resource tracker to report as leaked. Workers start no processes of their own.
        multiprocessing.set_start_method("fork", force=True)
    for module in preload:
        importlib.import_module(module)


@contextmanager
def _sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread meanwhile: processes started here inherit the mask, so a
    Ctrl-C during their start-up cannot interrupt them; one sent to this process is held, not lost."""
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no signal masks
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _guarded(fn: Callable[[T], R], parent: int, task: T) -> R:
    """``fn(task)`` unless the parent is gone (a worker orphaned where no death signal exists)."""
    if os.getppid() != parent:
        os._exit(1)
    return fn(task)


class SchedulerUnreachable(ConnectionError):
    """No Dask scheduler answered at the given address in time (or the address is malformed)."""


@contextmanager
def _connect(address: str, timeout: float | None = None) -> Iterator[Client]:
    """A Dask client of the scheduler at ``address``, closed on leaving (``timeout`` None: :data:`CONNECT_TIMEOUT`).

    Raises:
        SchedulerUnreachable: no answer within ``timeout`` seconds, or not an address.
    """
    from dask.distributed import Client

    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    try:
        client = Client(address, timeout=timeout)
    except OSError as exc:  # Dask's connect timeout; a refused connection is retried until then
        detail = "" if "Timed out" in str(exc) else f" ({exc})"
        raise SchedulerUnreachable(f"Dask scheduler {address!r}: no answer within {timeout:g} s{detail}") from None
    except ValueError as exc:
        raise SchedulerUnreachable(f"Dask scheduler {address!r}: not a scheduler address ({exc})") from None
    with client:
        yield client


def check_scheduler(address: str, timeout: float | None = None) -> None:
    """Connect to the Dask scheduler at ``address`` and disconnect: call before writing anything
    (``timeout`` None: :data:`CONNECT_TIMEOUT` seconds).

    Raises:
        SchedulerUnreachable: no answer within ``timeout`` seconds, or not an address.
    """
    with _connect(address, timeout):
        pass


@contextmanager
def worker_pool(workers: int, preload: Sequence[str] = ()) -> Iterator[ProcessPoolExecutor | None]:
    """``workers`` local processes started now, for :func:`dispatch`'s ``pool``; None if ``workers`` ≤ 1.

    Their start-up (an interpreter each, the ``preload`` modules' imports: ≈ 0.5 s)
    overlaps whatever the caller does before dispatching. Leaving the block waits for
    the pool's tasks, or, on an error or Ctrl-C, terminates the workers at once.
    """
    if workers <= 1:
        yield None
        return
    pool = _new_pool(workers, tuple(preload))
    try:
        with _sigint_blocked():
            for _ in range(workers):  # each submit finds no idle worker and spawns one
                pool.submit(os.getpid)
        yield pool
    except BaseException:
        _terminate(pool)
        raise
    pool.shutdown()


def _new_pool(workers: int, preload: tuple[str, ...] = ()) -> ProcessPoolExecutor:
    # spawn, not fork: the parent may hold threads (OpenCV, torch, the progress bar)
    # that a forked child would inherit mid-state; and it is what every OS has.
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_worker_start, initargs=(os.getpid(), preload))


def dispatch(fn: Callable[[T], R], tasks: Sequence[T], workers: int = 1, scheduler: str | None = None,
             pool: ProcessPoolExecutor | None = None) -> Iterator[R]:
    """``fn(task)`` for every task, yielded as each finishes (any order but in-process).

    Args:
        fn: a picklable (module-level, or a :func:`functools.partial` of one) function.
        tasks: picklable task arguments.
        workers: local worker processes; 1 (or less) runs the tasks one after another
            in this process, in order.
        scheduler: a Dask distributed scheduler address (``tcp://host:port``); overrides
            ``workers``.
        pool: local workers already started (:func:`worker_pool`): used instead of
            starting ``workers`` new ones, and left running for the caller to close.

    Yields:
        the results; an exception raised by a task is raised here when its result is reached.
    """
    if scheduler is not None:
        yield from _on_cluster(fn, tasks, scheduler)
    elif pool is not None:
        yield from _on_processes(fn, tasks, pool)
    elif workers <= 1:
        yield from map(fn, tasks)
    else:
        with worker_pool(workers) as started:
            assert started is not None  # workers > 1
            yield from _on_processes(fn, tasks, started)


def _on_cluster(fn: Callable[[T], R], tasks: Sequence[T], scheduler: str) -> Iterator[R]:
    """:func:`dispatch` on a Dask cluster; the tasks not yet finished are cancelled if we stop early."""
    from dask.distributed import as_completed as dask_completed

    with _connect(scheduler) as client:
        futures = client.map(fn, tasks, pure=False)  # pure=False: never deduplicated
        try:
            for future in dask_completed(futures):
                yield future.result()
        except BaseException:
            client.cancel(futures)
            raise


def _on_processes(fn: Callable[[T], R], tasks: Sequence[T], pool: ProcessPoolExecutor) -> Iterator[R]:
    """:func:`dispatch` on local processes; stopping early terminates them (module docstring)."""
    check_main_guarded()
    parent = os.getpid()
    try:
        call = functools.partial(_guarded, fn, parent)
        with _sigint_blocked():  # the pool starts its workers as tasks are submitted
            futures = [pool.submit(call, task) for task in tasks]
        for future in as_completed(futures):
            yield future.result()
    except BaseException:  # Ctrl-C, a task's error, the consumer closing the generator
        _terminate(pool)
        raise


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel its queued tasks and terminate its workers mid-task."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # Python ≥ 3.14: terminate_workers()
    manager = getattr(pool, "_executor_manager_thread", None)  # shutdown() forgets it
    for process in processes:
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.join(timeout=5)
    # The pool's manager thread notices the dead workers and closes its wake-up pipe. Python
    # < 3.12 writes to that pipe at exit without a lock, so an exit racing the close prints an
    # "OSError: Bad file descriptor" traceback after our one-line message: wait for it here.
    if manager is not None:
        manager.join(timeout=5)
