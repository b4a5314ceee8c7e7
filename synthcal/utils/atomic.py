"""Atomic file writes: a reader sees the old file, the whole new one, or none — never a part.

The content goes to a temporary name in the destination's folder (so the rename
stays on one file system), which :func:`os.replace` then moves over the
destination in one step. On error the temporary file is removed and the
destination left as it was. A process killed between the write and the rename
leaves its temporary behind: :func:`remove_temporaries` sweeps a folder of them
(and of Zarr's own, ``NAME.<32 hex>.partial``) once no writer is left.
"""

from __future__ import annotations

import os
import re
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_write", "is_temporary", "remove_temporaries"]

# atomic_write's ``.<name>.<pid>-<8 hex>.tmp`` and zarr's LocalStore ``<stem>.<32 hex>.partial``
_TEMPORARY = re.compile(r"(\..+\.\d+-[0-9a-f]{8}\.tmp|.*\.[0-9a-f]{32}\.partial)")


def is_temporary(name: str) -> bool:
    """Whether a file name is one of :func:`atomic_write`'s (or Zarr's) temporaries.

    >>> is_temporary(".0.4242-0123abcd.tmp"), is_temporary("zarr.0123456789abcdef0123456789abcdef.partial")
    (True, True)
    >>> is_temporary("0"), is_temporary("zarr.json"), is_temporary("intersection-1.zarr.partial")
    (False, False, False)
    """
    return _TEMPORARY.fullmatch(name) is not None


def remove_temporaries(root: str | Path) -> list[Path]:
    """Delete every temporary file under ``root`` (call only while no writer is at work there).

    Returns:
        the files removed, sorted.
    """
    found = sorted(p for p in Path(root).rglob("*") if p.is_file() and is_temporary(p.name))
    for path in found:
        path.unlink(missing_ok=True)
    return found


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

    Raises:
        OSError: the block's own, re-raised naming ``path`` when it named no file
            (``write`` into a full disk raises ``[Errno 28]`` without a file name)
            or the temporary.
    """
    path = Path(path)
    # pid and a random part: distinct for concurrent writers, processes or threads.
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:  # leave no temporary behind; name the destination, not the temporary
        tmp.unlink(missing_ok=True)
        if exc.errno is not None and exc.filename in (None, str(tmp)):  # a full disk's write names no file
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    except BaseException:  # the caller's error, Ctrl-C: leave no temporary behind
        tmp.unlink(missing_ok=True)
        raise
