"""Trained stages cached on disk, so shared stages (UNet, Siamese) train once.

:class:`StageCache` keeps ``state_dict``\\ s under ``<root>/<stage>/<key>.pt``, the
key a hash of everything that determines the stage (the data's bytes, sizes,
epochs, seed), written atomically (:func:`synthcal.utils.atomic.atomic_write`), so
a reader sees a whole file or none. A process about to train a stage holds an
exclusive lock on ``<root>/<stage>/.<key>.lock`` (:class:`filelock.FileLock`:
``flock`` on POSIX, ``msvcrt`` locking on Windows); another process (or thread)
that needs the same stage waits for it and then loads its file instead of training
again. Where locks are not honoured (some network file systems), both train and
the last rename wins; both files are valid.
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any

import numpy as np
import torch
from filelock import FileLock
from torch import Tensor

from synthcal.utils.atomic import atomic_write

__all__ = ["digest", "train_cache_key", "held_out_cache_key", "unet_cache_key", "StageCache"]


def digest(*parts: Any) -> str:
    """Hex digest of arrays (shape, dtype and bytes) and JSON-able values, in order."""
    h = hashlib.blake2b(digest_size=16)
    for part in parts:
        if isinstance(part, (np.ndarray, Tensor)):
            array = np.ascontiguousarray(part.cpu().numpy() if isinstance(part, Tensor) else part)
            h.update(f"{array.shape}{array.dtype}".encode())
            h.update(array.data.cast("B"))  # contiguous: its buffer, no copy
        else:
            h.update(json.dumps(part, sort_keys=True, default=str).encode())
    return h.hexdigest()


def train_cache_key(code: str, semantics: np.ndarray, images: np.ndarray | None, full_size: tuple[int, int],
                    work_size: tuple[int, int]) -> str:
    """Key of a train split as the bundled models read it; every stage's key derives from it.

    Args:
        code: the bundled models' code version (:func:`synthcal.estimators.bundled_code_version`,
            or the one a run recorded): edited models retrain.
        semantics: (K, H, W) the class maps trained on (after ``max_train``).
        images: (K, H, W, 3) their RGB images, None when no UNet reads them.
        full_size, work_size: ``(w, h)`` of the store and of the networks.
    """
    return digest(code, semantics, images if images is not None else 0, full_size, work_size)


def held_out_cache_key(semantics: np.ndarray, images: np.ndarray | None) -> str:
    """Key of a validation split as a stage's early stopping reads it: (K, H, W) class maps, (K, H, W, 3)
    images (None when no UNet reads them)."""
    return digest("validation", semantics, images if images is not None else 0)


def unet_cache_key(train_key: str, width: int, depth: int, epochs: int, batch_size: int, learning_rate: float,
                   seed: int, held_out_key: str | None = None, patience: int | None = None,
                   class_weights: str | None = None) -> str:
    """Key of the UNet trained on the split ``train_key`` with these settings (:class:`StageCache` ``unet``).

    With ``patience``, the UNet kept its best epoch on the validation split ``held_out_key``
    (:func:`held_out_cache_key`), and both are in the key; with ``class_weights`` (the
    setting ``unet_class_weights``), its loss was weighted. Without either, the key is as it
    always was.
    """
    key = digest("unet", train_key, width, depth, epochs, batch_size, learning_rate, seed,
                 *(() if patience is None else (held_out_key, patience)))
    return key if class_weights is None else digest(key, class_weights)


class StageCache:
    """Trained stages on disk, ``<root>/<stage>/<key>.pt`` (module docstring).

    Args:
        root: the cache folder (created on first write); None disables caching.
    """

    def __init__(self, root: str | Path | None) -> None:
        self.root = None if root is None else Path(root)

    def path(self, stage: str, key: str) -> Path | None:
        return None if self.root is None else self.root / stage / f"{key}.pt"

    def load(self, stage: str, key: str) -> Any | None:
        """The stored object, or None when absent (or caching is off)."""
        path = self.path(stage, key)
        if path is None or not path.is_file():
            return None
        return torch.load(path, map_location="cpu", weights_only=True)

    def save(self, stage: str, key: str, obj: Any) -> None:
        """Store ``obj`` (tensors, state dicts) atomically."""
        path = self.path(stage, key)
        if path is None:
            return
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(path) as tmp:
            torch.save(obj, tmp)

    def cached(self, stage: str, key: str, build: Callable[[], Any]) -> tuple[Any, bool]:
        """``(obj, trained)``: the stored object, or ``build()`` stored then returned.

        While one caller builds, others asking for the same stage and key wait, then
        load what it stored.
        """
        obj = self.load(stage, key)
        if obj is not None:
            return obj, False
        with self._building(stage, key):
            obj = self.load(stage, key)  # built by whoever held the lock before us
            if obj is not None:
                return obj, False
            obj = build()
            self.save(stage, key, obj)
        return obj, True

    def _building(self, stage: str, key: str) -> AbstractContextManager[object]:
        """The lock held while building a stage (nothing when caching is off).

        The lock file is created if missing and left in place: removing it would race
        with a waiter that has just opened it.
        """
        path = self.path(stage, key)
        if path is None:
            return nullcontext()
        path.parent.mkdir(parents=True, exist_ok=True)
        return FileLock(path.with_name(f".{key}.lock"))
