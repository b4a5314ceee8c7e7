"""The store's errors: every one names the store or file it is about.

Subclasses of :class:`StoreError` (a :class:`ValueError`), which the command line
reports as ``synthcal: error: …`` with exit status 2.
"""

from __future__ import annotations

__all__ = ["StoreError", "StoreLocked", "CorruptStore"]


class StoreError(ValueError):
    """A store that is missing, incomplete or not a synthcal store."""


class StoreLocked(StoreError):
    """Another process is writing the store (generating it or drawing its splits)."""


class CorruptStore(StoreError):
    """A damaged file: a chunk or shard index whose checksum does not match, a shard
    file missing or of another size than the store's manifest records."""
