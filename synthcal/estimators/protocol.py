"""The estimator plug-in interface (SPEC §9): what ``fit`` and ``predict`` receive and return.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).

The interface
-------------
An estimator is any class with

* ``fit(train, dictionary, scene) -> None`` — called once per (dataset, seed).
  ``train`` and ``dictionary`` are split objects (:class:`SplitLike`) exposing ``.images`` (K, H, W, 3)
  uint8 RGB, ``.semantics`` (K, H, W) uint8 class ids, ``.homographies``
  (K, 3, 3) float64, ``.indices`` (K,) int64 positions in the store and ``.store``
  (the store's path); the arrays may be NumPy or lazy array-likes that support
  slicing and ``numpy.asarray``. ``scene`` (:class:`SceneLike`) exposes ``.image`` (Hs, Ws, 3) uint8,
  ``.semantic`` (Hs, Ws) uint8, ``.palette`` (4 RGB triples) and ``.classes``
  (4 names). The objects come from ``synthcal.data.load_split``; an estimator
  should use these attributes only. When the run's training settings choose
  something on held-out data (``patience``, ``select``), the harness also passes
  ``validation=`` (the seed's validation split, the same kind of object): training
  choices read it, never the test split (SPEC §6).
* ``predict(images) -> (B, 3, 3)`` — ``images`` (B, H, W, 3) uint8 RGB; returns
  bird's-eye → image homographies as float64, any positive or negative scale
  (the harness fixes the sign, SPEC §2). A row may be NaN where the estimator
  gives up: the image is then counted as a failure (SPEC §8).
* optional ``predict_semantic(semantics) -> (B, 3, 3)`` — the same from the
  images' (B, H, W) uint8 class maps instead of their pixels
  (:class:`SemanticEstimator`). Under ``segmentation: ground-truth`` (SPEC §7) the
  harness calls it with the *true* class maps of the test images, so that the
  segmentation is the same, perfect, for every compared estimator; estimators
  without it are unaffected by that setting.

Under the harness (SPEC §9) each run executes in a process of its own, under a
time limit, and every array handed to ``fit``, ``predict`` and
``predict_semantic`` is read-only (NumPy ``writeable=False``): an estimator that
needs to modify one takes a copy (``np.array(x)``). Scoring uses the harness's own
copy of the scene and test split. Raising, hanging, exiting or crashing records
the run as failed with its reason; it never stops the sweep.
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["SplitLike", "SceneLike", "Estimator", "SemanticEstimator", "Segmenter", "EstimatorError"]


class SplitLike(Protocol):
    """What ``fit`` may read of a split (train or dictionary): ``synthcal.data.SplitDataset`` or a stand-in.

    Read-only: the harness hands out arrays with ``writeable=False``. The arrays may
    also be lazy array-likes that support slicing and ``numpy.asarray``: the pool
    dictionary (``bench --dictionary pool``, :mod:`synthcal.data.pool`) is one, the
    whole pool outside train and test, to be read in slices rather than whole.
    """

    @property
    def images(self) -> np.ndarray:
        """(K, H, W, 3) uint8 RGB."""

    @property
    def semantics(self) -> np.ndarray:
        """(K, H, W) uint8 class ids."""

    @property
    def homographies(self) -> np.ndarray:
        """(K, 3, 3) float64 bird's-eye → image homographies."""

    @property
    def indices(self) -> np.ndarray:
        """(K,) int64 positions in the store's pool."""

    @property
    def store(self) -> str | PathLike[str]:
        """The store's path (for plug-ins that read more of it)."""


class SceneLike(Protocol):
    """What ``fit`` may read of the bird's-eye scene: ``synthcal.data.StoreScene`` or a stand-in.

    Read-only, like the splits.
    """

    @property
    def image(self) -> np.ndarray:
        """(Hs, Ws, 3) uint8 RGB."""

    @property
    def semantic(self) -> np.ndarray:
        """(Hs, Ws) uint8 class ids."""

    @property
    def palette(self) -> np.ndarray:
        """(4, 3) uint8 display colours, index = class id."""

    @property
    def classes(self) -> Sequence[str]:
        """The 4 class names, index = class id."""


@runtime_checkable
class Estimator(Protocol):
    """A homography estimator (SPEC §9); see the module docstring for argument types.

    Any class with these two methods is one (``synthcal.Estimator`` is this
    protocol; no subclassing needed). ``predict`` returns homographies mapping a
    bird's-eye pixel to an image pixel.

    Example:
        >>> import numpy as np, synthcal
        >>> class FirstTrainPose:   # every image gets the first train sample's homography
        ...     def fit(self, train, dictionary, scene):
        ...         self.H = np.asarray(train.homographies[0], np.float64)
        ...     def predict(self, images):
        ...         return np.repeat(self.H[None], len(images), axis=0)   # (B, 3, 3)
        >>> isinstance(FirstTrainPose(), synthcal.Estimator)
        True
    """

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        """Learn from the train split, the template dictionary and the scene."""

    def predict(self, images: np.ndarray) -> np.ndarray:
        """(B, H, W, 3) uint8 RGB → (B, 3, 3) float64 bird's-eye → image homographies."""


@runtime_checkable
class SemanticEstimator(Estimator, Protocol):
    """An estimator that can also work from class maps (``segmentation: ground-truth``)."""

    def predict_semantic(self, semantics: np.ndarray) -> np.ndarray:
        """(B, H, W) uint8 class ids → (B, 3, 3) float64 bird's-eye → image homographies."""


@runtime_checkable
class Segmenter(Protocol):
    """RGB → class map, the replaceable first stage of the template estimators."""

    def fit(self, images: np.ndarray, semantics: np.ndarray) -> None:
        """Learn from (K, H, W, 3) uint8 images and their (K, H, W) uint8 class maps."""

    def __call__(self, images: np.ndarray) -> np.ndarray:
        """(B, H, W, 3) uint8 RGB → (B, H, W) uint8 class ids."""


class EstimatorError(ValueError):
    """An estimator name or path that cannot be resolved, or an object that is no estimator."""
