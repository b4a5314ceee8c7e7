"""Reading a store with zarr-python directly, without synthcal.

A store is a plain Zarr v3 group (SPEC §5): ``image`` (N, H, W, 3) uint8,
``semantic`` (N, H, W) uint8, ``homography`` (N, 3, 3) float64 mapping a
bird's-eye pixel ``(u, v)`` of ``scene/image`` to an image pixel, and the
splits as index arrays under ``splits/seed-S/``. This script generates a smoke
store, reads it back with ``zarr`` only and checks one homography against the
store's own scene: the scene's class map warped through ``H`` is the sample's
semantic map (pixels whose ground point is behind the camera are class 0).

    python examples/read_with_zarr.py [OUT]     # OUT: where the store goes (default: a temporary folder)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
import zarr

import synthcal

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="synthcal-"))
store = synthcal.generate_store("intersection-1", out, profile="smoke")

group = zarr.open_group(store, mode="r")
print(f"{store}: {dict(group.attrs)['dataset']}, arrays {sorted(name for name, _ in group.arrays())}")
train = group["splits/seed-0/train"][:]  # pool indices, ascending
k = int(train[0])
image, semantic, H = group["image"][k], group["semantic"][k], group["homography"][k]
print(f"train[0] = sample {k}: image {image.shape} {image.dtype}, semantic {semantic.shape}, H\n{H.round(3)}")

# H maps bird's-eye → image, so the image is the scene warped by H; nearest keeps class ids.
scene = group["scene/semantic"][:]
height, width = semantic.shape
warped = cv2.warpPerspective(scene, H, (width, height), flags=cv2.INTER_NEAREST, borderValue=0)
pixels = np.stack([*np.meshgrid(np.arange(width), np.arange(height)), np.ones((height, width))])
ground = np.einsum("ij,jhw->ihw", np.linalg.inv(H), pixels)
depth = np.einsum("i,ihw->hw", H[2], ground / ground[2])  # H's third output at the ground point: > 0 in front
warped[depth <= 0] = 0
print(f"scene warped through H agrees with the stored semantic map on {(warped == semantic).mean():.1%} of pixels")
