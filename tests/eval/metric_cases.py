"""The views and cameras the metric tests share (tests/eval/test_metrics.py, test_polygon.py, test_evaluate.py)."""

import cv2
import numpy as np

from synthcal.config import METRICS, PIXEL_METRICS
from synthcal.generate.camera import homography

SIZE = (48, 24)
STRIPE = 8  # bird's-eye pixels per stripe; classes 1, 2, 3 repeat every 24 columns


def stripes(height: int = 200, width: int = 400) -> np.ndarray:
    """Vertical stripes of classes 1, 2, 3, each STRIPE columns wide, starting at u = 0."""
    return np.broadcast_to((np.arange(width) // STRIPE % 3 + 1).astype(np.uint8), (height, width)).copy()


def top_down(u0: float, v0: float) -> np.ndarray:
    """A camera looking straight down at scale 1: image pixel (x, y) sees ground (x + u0, y + v0)."""
    return np.array([[1.0, 0, -u0], [0, 1.0, -v0], [0, 0, 1.0]])


def blobs(seed: int = 0, shape=(400, 300)) -> np.ndarray:
    coarse = np.random.default_rng(seed).integers(0, 4, (shape[0] // 20, shape[1] // 20)).astype(np.uint8)
    return cv2.resize(coarse, shape[::-1], interpolation=cv2.INTER_NEAREST)


def perspective(pan, tilt, focal, position=(150.0, 200.0, 40.0), size=SIZE):
    return homography([pan], [tilt], [focal], [position], size)[0]


# What every metric gives an estimate equal to the truth, and a failed estimate.
PERFECT = [0.0 if name in PIXEL_METRICS else 1.0 for name in METRICS]
FAILED = [np.inf if name in PIXEL_METRICS else 0.0 for name in METRICS]
