"""An example synthcal estimator plug-in: nearest train image by thumbnail.

The estimator shrinks every image to a small grey thumbnail, finds the train
image whose thumbnail is closest (sum of squared differences) and returns that
image's homography. It is deliberately simple: it shows the interface (SPEC §9),
not a good method.

Convention: homographies map a bird's-eye pixel to an image pixel (SPEC §2).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

__all__ = ["NearestThumbnailEstimator"]


def thumbnails(images: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(B, H, W, 3) uint8 RGB → (B, w·h) float32 zero-mean, unit-norm grey thumbnails."""
    grey = [cv2.resize(cv2.cvtColor(np.ascontiguousarray(im), cv2.COLOR_RGB2GRAY), size,
                       interpolation=cv2.INTER_AREA) for im in images]
    flat = np.asarray(grey, np.float32).reshape(len(grey), -1)
    flat -= flat.mean(1, keepdims=True)
    return flat / np.maximum(np.linalg.norm(flat, axis=1, keepdims=True), 1e-6)


class NearestThumbnailEstimator:
    """Predicts the homography of the most similar train image.

    Args:
        width, height: the thumbnail's size; small sizes ignore detail (and noise). Plain
            ``int`` keywords, so that ``bench`` can set and check them
            (``--option nearest-thumbnail.width=24``).
    """

    def __init__(self, width: int = 32, height: int = 18) -> None:
        self.size = (width, height)
        self.keys: np.ndarray | None = None
        self.homographies: np.ndarray | None = None

    def fit(self, train: Any, dictionary: Any, scene: Any) -> None:
        """Remember the train thumbnails and homographies (``dictionary`` and ``scene`` unused)."""
        self.keys = thumbnails(np.asarray(train.images), self.size)
        self.homographies = np.asarray(train.homographies, np.float64)

    def predict(self, images: np.ndarray) -> np.ndarray:
        """(B, H, W, 3) uint8 RGB → (B, 3, 3) bird's-eye → image homographies."""
        if self.keys is None:
            raise RuntimeError("NearestThumbnailEstimator: call fit() first")
        # Unit-norm rows: the smallest distance is the largest dot product.
        nearest = np.argmax(thumbnails(np.asarray(images), self.size) @ self.keys.T, axis=1)
        return self.homographies[nearest].copy()
