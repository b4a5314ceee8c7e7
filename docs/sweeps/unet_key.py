"""Which store a cached UNet was trained on: its cache key, recomputed from a run's record and a data folder.

    python docs/sweeps/unet_key.py RESULTS/runs/RUN_ID/run.json DATA LEARNING_RATE

prints the key a UNet run (``--segmentation unet``, step by step, patience on validation) would give its UNet at
``LEARNING_RATE`` if it read the store ``DATA/<its store's name>``, as PaperEstimator makes it (the train split's
class maps and RGB at ``max_train``, the validation split's, the UNet's settings and the seed), then the key the run
recorded for the rate it kept. Two stores of the same configuration rendered under two OpenCV versions give two keys
(their RGB differ; reproduction.md, "How it was run", "The renderer under the UNet cells"); the key a cached UNet's
file name holds (``RESULTS/cache/unet/<key>.pt``, or the ``unet`` column of ``synthcal segmentation --format csv``)
then says which store it was trained on. Run it with the python of the clone that made the run.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

from synthcal.config import TrainingSettings
from synthcal.data import read_scene
from synthcal.eval.harness import Run
from synthcal.eval.isolation import load_run_split
from synthcal.training.cache import held_out_cache_key, train_cache_key, unet_cache_key


def unet_key(record: dict, data: Path, learning_rate: float) -> str:
    """The UNet cache key of ``record``'s run at ``learning_rate`` on the store of the same name in ``data``."""
    run = Run(**record["run"])
    run = dataclasses.replace(run, store=str(data / Path(run.store).name))
    settings = TrainingSettings(**(run.settings or {}))
    scene = read_scene(run.store)
    train = load_run_split(run, "train", scene)
    semantics = np.asarray(train.semantics)[: settings.max_train]
    full_size = (semantics.shape[2], semantics.shape[1])
    width, height = settings.work_size or full_size
    train_key = train_cache_key(run.code.removeprefix("synthcal:"), semantics,
                                np.asarray(train.images)[: len(semantics)], full_size, (int(width), int(height)))
    validation = load_run_split(run, "validation", scene)
    held_out = held_out_cache_key(np.asarray(validation.semantics), np.asarray(validation.images))
    return unet_cache_key(train_key, settings.unet_width, settings.unet_depth, settings.unet_epochs,
                          settings.batch_size, learning_rate, run.seed, held_out_key=held_out,
                          patience=settings.patience, class_weights=settings.unet_class_weights)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    record = json.loads(Path(sys.argv[1]).read_text(encoding="utf-8"))
    print(unet_key(record, Path(sys.argv[2]), float(sys.argv[3])))
    print("recorded:", (record.get("stage_keys") or {}).get("unet"))
