"""One writer per store: an exclusive ``flock`` on ``<folder>/.<name>.lock``.

``synthcal generate`` holds it for the whole run and split drawing while it writes
into the store; a second writer fails at once with :class:`StoreLocked`, naming the
store and the holder's PID (written into the lock file). The kernel releases an
``flock`` when its holder dies, however it dies, so a lock is never stale. The file
itself stays (removing it would let two writers lock two different files).

The lock file's descriptor is not inherited by child processes (Python's default),
so worker processes never hold it.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from synthcal.store.errors import StoreError, StoreLocked

__all__ = ["lock_path", "store_lock"]


def lock_path(store: str | Path) -> Path:
    """The lock file of a store ``<folder>/<name>.zarr``: ``<folder>/.<name>.lock``.

    >>> lock_path("out/intersection-1.zarr").as_posix()
    'out/.intersection-1.lock'
    """
    store = Path(store)
    return store.parent / f".{store.name.removesuffix('.zarr')}.lock"


@contextmanager
def store_lock(store: str | Path) -> Iterator[Path]:
    """Hold the store's exclusive lock for the block (its folder must exist).

    Yields:
        the lock file.

    Raises:
        StoreLocked: another process holds it; the message names the store, the
            lock file and the holder's PID.
        StoreError: the lock file cannot be created (e.g. a read-only folder).
    """
    path = lock_path(store)
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise StoreError(f"{store}: cannot create the lock file {path} ({exc.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            raise StoreLocked(f"{store}: another synthcal process (PID {holder}) is writing this store "
                              f"(lock {path}); wait for it to finish") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        try:
            yield path
        finally:
            os.ftruncate(fd, 0)  # released: no PID to blame any more
    finally:
        os.close(fd)  # closing the last descriptor releases the flock
