"""What a ``generate`` will cost, measured before it starts: samples, disk and time.

A few samples are rendered and compressed in memory (nothing is written), as the
shard workers would; the per-sample bytes and seconds, times the samples still to
render, give the estimate. The scene is the one :func:`synthcal.generate.pipeline.load_scene`
caches, so the generation that follows does not load it again.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numcodecs import Blosc

from synthcal.config import DatasetSpec
from synthcal.generate.pipeline import anchored_spec, load_scene, plan_cameras, render_samples, store_path

__all__ = ["GenerationEstimate", "estimate_generation"]

# Samples rendered to measure: enough to average out one sample's variance, quick at paper size.
CALIBRATION_SAMPLES = 8
# The stores' inner compressor (synthcal.store.format), as numcodecs spells it.
_COMPRESSOR = Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE)


@dataclass(frozen=True)
class GenerationEstimate:
    """A generation's cost: ``samples`` in the pool, ``remaining`` of them still to render (a
    resumed store has fewer), ``bytes`` on disk when complete (samples and scene), ``seconds``
    to render the rest."""

    samples: int
    remaining: int
    bytes: float
    seconds: float


def _remaining(spec: DatasetSpec, out_dir: Path) -> int:
    """Samples not yet rendered: all, less the finished shards of an interrupted run."""
    final = store_path(out_dir, spec.name)
    done = len(list(final.with_name(f".{final.name}.progress").glob("shard-*.done")))
    return max(0, spec.pool_size - done * spec.shard_size)


def estimate_generation(spec: DatasetSpec, out_dir: str | Path, workers: int = 1) -> GenerationEstimate:
    """Render :data:`CALIBRATION_SAMPLES` samples in memory and scale up (module docstring).

    Args:
        spec: the resolved dataset configuration.
        out_dir: the folder ``generate`` writes to (a resumed run renders only what is missing).
        workers: local processes sharing the rendering.

    Raises:
        ConfigError: the scene cannot be loaded (as ``generate`` would raise).
    """
    scene = load_scene(spec)
    spec = anchored_spec(spec, scene)
    count = min(CALIBRATION_SAMPLES, spec.pool_size)
    # A grid's first cameras, planned for a pool of `count`; given poses are few: plan them all.
    small = spec.model_copy(update={"pool_size": count}) if spec.poses is None else spec
    started = time.perf_counter()
    homographies = plan_cameras(small, scene)[1][:count]
    images, semantics = render_samples(scene, homographies, 0, spec, images=spec.images == "all")
    encoded = sum(len(_COMPRESSOR.encode(np.ascontiguousarray(sample))) for sample in (*images, *semantics))
    per_sample = (time.perf_counter() - started) / count
    # The store keeps the scene too: at small pool sizes it is most of the store.
    scene_bytes = sum(len(_COMPRESSOR.encode(np.ascontiguousarray(a))) for a in (scene.image, scene.semantic))
    remaining = _remaining(spec, Path(out_dir))
    return GenerationEstimate(spec.pool_size, remaining, scene_bytes + encoded / count * spec.pool_size,
                              per_sample * remaining / max(1, workers))
