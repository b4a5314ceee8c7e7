"""Atomic file writes: a reader sees the old file, the whole new one, or none — never a part.

The content goes to a temporary name in the destination's folder (so the rename
stays on one file system), which :func:`os.replace` then moves over the
destination in one step. On error the temporary file is removed and the
destination left as it was.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_write"]


@contextmanager
def atomic_write(path: str | Path) -> Iterator[Path]:
    """A temporary path to write to; renamed onto ``path`` when the block ends without error.

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with atomic_write(folder / "run.json") as tmp:
    ...     _ = tmp.write_text('{"iou": 0.5}')
    >>> sorted(p.name for p in folder.iterdir()), (folder / "run.json").read_text()
    (['run.json'], '{"iou": 0.5}')

    Args:
        path: the destination file (its folder must exist).

    Yields:
        ``.<name>.<pid>-<random>.tmp`` beside ``path``, not yet created: the caller
        creates it (``write_bytes``, ``torch.save``, ...), so it gets the usual
        permissions (``0o666`` less the umask), as a file written in place would.
    """
    path = Path(path)
    # pid and a random part: distinct for concurrent writers, processes or threads.
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:  # the caller's error, or the rename's: leave no temporary behind
        tmp.unlink(missing_ok=True)
        raise
