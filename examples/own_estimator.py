"""Your own estimator as a plug-in.

An estimator is any class with ``fit(train, dictionary, scene)`` and
``predict(images) -> (B, 3, 3)`` homographies mapping a bird's-eye pixel to an
image pixel (``synthcal.Estimator``). This one predicts, for every test image, the
homography of the dictionary template whose 8 × 8 grey thumbnail is nearest.
``synthcal.bench`` runs it beside the bundled ``identity`` — each run in a process
of its own, by its ``module:Class`` path (this file's folder is on ``sys.path``) —
and prints the readings.

    python examples/own_estimator.py [OUT]      # OUT: results folder (default: a temporary one)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

import synthcal


def thumbnails(images: np.ndarray) -> np.ndarray:
    """(B, H, W, 3) uint8 RGB → (B, 64) float32 grey 8 × 8 thumbnails."""
    grey = [cv2.resize(cv2.cvtColor(np.asarray(image), cv2.COLOR_RGB2GRAY), (8, 8), interpolation=cv2.INTER_AREA)
            for image in images]
    return np.asarray(grey, np.float32).reshape(len(images), -1)


class NearestThumbnail:
    """The homography of the template whose thumbnail is nearest (Euclidean)."""

    def fit(self, train, dictionary, scene) -> None:
        self.keys = thumbnails(np.asarray(dictionary.images))
        self.homographies = np.asarray(dictionary.homographies, np.float64)

    def predict(self, images: np.ndarray) -> np.ndarray:
        distances = ((thumbnails(images)[:, None] - self.keys[None]) ** 2).sum(-1)
        return self.homographies[distances.argmin(1)]


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="synthcal-"))
    assert isinstance(NearestThumbnail(), synthcal.Estimator)
    synthcal.generate_store("intersection-1", out / "data", profile="smoke")  # 48 samples at 64 × 36, splits drawn
    frame = synthcal.bench(out / "data", ["intersection-1"], ["identity", "own_estimator:NearestThumbnail"],
                           out / "results", seeds=(0, 1), profile="smoke")
    print(frame.groupby("model")[["iou", "iou_weighted", "completeness"]].mean().round(3).to_string())
    print(f"results in {out / 'results'}")
