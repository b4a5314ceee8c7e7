"""A user scene from two PNGs: a bird's-eye RGB image and its semantic map.

Draws a small crossing (500 × 500 px at 10 px/m: roads, grass, a bicycle path),
writes ``crossing.png`` and ``crossing-labels.png`` (class ids 0..3 as grey
levels), adds the scene and a dataset over the paper's ``intersection`` grid (its
X/Y relative to the scene centre) to a copy of the packaged ``datasets.yaml``, and
generates a smoke store from it: the README's "Configuration" section, in code.

    python examples/user_scene.py [OUT]         # OUT: PNGs, YAML and store (default: a temporary folder)
"""

from __future__ import annotations

import sys
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

import synthcal

CLASSES = ["background", "road", "terrain", "bicycle path"]
COLOURS = np.array([[40, 40, 40], [110, 110, 115], [70, 150, 60], [190, 60, 60]], np.uint8)  # RGB per class


def config_with(out: Path, scenes: dict[str, Any], datasets: dict[str, Any]) -> Path:
    """``OUT/datasets.yaml``: the packaged configuration plus these scenes and datasets (paths relative to OUT)."""
    config = yaml.safe_load((resources.files("synthcal") / "datasets.yaml").read_text())
    config["scenes"] = {**(config.get("scenes") or {}), **scenes}
    config["datasets"].update(datasets)
    path = out / "datasets.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def crossing(size: int = 500) -> np.ndarray:
    """(size, size) uint8 class ids: two 12 m roads crossing, a 3 m bicycle path beside one, grass elsewhere."""
    semantic = np.full((size, size), 2, np.uint8)
    middle = size // 2
    semantic[:, middle + 60:middle + 90] = 3
    semantic[middle - 60:middle + 60, :] = 1
    semantic[:, middle - 60:middle + 60] = 1
    return semantic


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="synthcal-"))
    out.mkdir(parents=True, exist_ok=True)
    semantic = crossing()
    noise = np.random.default_rng(0).integers(-12, 13, semantic.shape + (3,))
    image = np.clip(COLOURS[semantic].astype(int) + noise, 0, 255).astype(np.uint8)
    cv2.imwrite(str(out / "crossing.png"), image[..., ::-1])  # OpenCV writes BGR
    cv2.imwrite(str(out / "crossing-labels.png"), semantic)
    scene = {"image": "crossing.png", "semantic": "crossing-labels.png", "classes": CLASSES, "pixels_per_metre": 10}
    config = config_with(out, {"my-crossing": scene},
                         {"my-crossing": {"scene": "my-crossing", "grid": "intersection", "pool_size": 10000}})
    store = synthcal.generate_store("my-crossing", out / "data", profile="smoke", config=config)
    test = synthcal.load_split(store, "test", seed=0)
    shares = np.bincount(test.semantics.ravel(), minlength=4) / test.semantics.size
    print(f"{store}: {len(test)} test images; classes seen: "
          + ", ".join(f"{name} {share:.0%}" for name, share in zip(CLASSES, shares, strict=True)))
