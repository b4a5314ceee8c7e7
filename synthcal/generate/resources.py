"""Will a store fit? Memory and disk estimates that ``generate`` checks before writing anything.

A configuration can be valid and still impossible on this machine: 64 samples of
16,384 × 9,216 px hold 145 GiB in one worker. :func:`check_resources` refuses such a
run with one line naming the figure and the knob that lowers it, before the output
folder is created, rather than dying in the middle with a half-written store.

The figures are upper bounds from what the code holds (:mod:`synthcal.generate.pipeline`):

* a worker renders one shard at a time and holds, for all of its ``shard_size``
  samples, the RGB images (3 bytes a pixel), the semantic maps (1) and the
  on-scene masks (1), then the shard's encoded bytes (at most the raw 4 bytes a
  pixel); for one sample at a time, the supersampled frame (``3·s²`` bytes a pixel
  and its reduction); and the scene's bird's-eye image and map (4 bytes a scene pixel);
* the planning process holds every sample's homography, camera and grid index;
* the store holds every sample's image and map uncompressed at most (4 bytes a
  pixel; for ``images: splits``, images only for as many samples as the splits draw).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from synthcal.config import ConfigError, DatasetSpec

__all__ = ["ResourceError", "shard_memory", "planning_memory", "store_bytes", "physical_memory", "check_resources"]

# Bytes a sample costs the planning process: its 3×3 float64 homography (72), seven
# camera fields (56) and the sampling's temporaries (a generous 128).
_PLAN_BYTES = 256


class ResourceError(ConfigError):
    """The run would need more memory or disk than there is; nothing was written."""


def shard_memory(spec: DatasetSpec, scene_pixels: int) -> int:
    """Peak bytes one worker holds while it renders a shard (the module docstring lists them)."""
    width, height = spec.image_size
    pixels = width * height
    shard = min(spec.shard_size, spec.pool_size)
    return shard * pixels * (3 + 1 + 1 + 4) + pixels * 3 * (spec.supersample**2 + 1) + scene_pixels * 4


def planning_memory(spec: DatasetSpec) -> int:
    """Bytes the planning process holds for the pool's cameras and homographies."""
    return spec.pool_size * _PLAN_BYTES


def store_bytes(spec: DatasetSpec, scene_pixels: int) -> int:
    """Upper bound of a finished store's size on disk (uncompressed samples)."""
    width, height = spec.image_size
    with_images = spec.pool_size if spec.images == "all" else min(
        spec.pool_size, spec.splits.total * len(spec.split_seeds))
    return (spec.pool_size + 3 * with_images) * width * height + spec.pool_size * _PLAN_BYTES + scene_pixels * 4


def physical_memory() -> int | None:
    """This machine's physical memory in bytes (None where the system does not say)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows) or no such name
        return None


def _free_space(folder: Path) -> int:
    """Free bytes where ``folder`` is (or will be created: its nearest existing parent)."""
    folder = folder.absolute()
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    return shutil.disk_usage(folder).free


def _gib(size: int) -> str:
    """``12.3 GiB`` (or ``45.6 MiB`` below a GiB)."""
    return f"{size / 2**30:.1f} GiB" if size >= 2**30 else f"{size / 2**20:.1f} MiB"


def check_resources(spec: DatasetSpec, scene_pixels: int, out_dir: Path, workers: int,
                    max_memory: int | None = None, fresh: bool = True) -> None:
    """Refuse a run whose memory or disk estimate exceeds what there is.

    Args:
        spec: the resolved dataset.
        scene_pixels: the scene's bird's-eye pixel count (height × width).
        out_dir: the folder receiving the store.
        workers: local worker processes rendering at the same time.
        max_memory: the memory budget in bytes (None: this machine's physical memory).
        fresh: a new store (False: a resumed one, whose disk is partly spent: not checked).

    Raises:
        ResourceError: one line naming the estimate, what there is and the knob that lowers it.
    """
    per_worker = shard_memory(spec, scene_pixels)
    memory = workers * per_worker + planning_memory(spec) + scene_pixels * 4
    budget = max_memory if max_memory is not None else physical_memory()
    if budget is not None and memory > budget:
        have = "--max-memory" if max_memory is not None else "this machine's memory"
        raise ResourceError(
            f"datasets.{spec.name}: generating needs about {_gib(memory)} of memory ({workers} worker(s) × "
            f"{_gib(per_worker)} for a shard of {spec.shard_size} samples of {spec.image_size[0]} × "
            f"{spec.image_size[1]} px, supersample {spec.supersample}), more than {have} ({_gib(budget)}); "
            "lower --workers, shard_size, image_size or supersample")
    if not fresh:
        return
    disk, free = store_bytes(spec, scene_pixels), _free_space(out_dir)
    if disk > free:
        raise ResourceError(
            f"datasets.{spec.name}: the store may take up to {_gib(disk)} ({spec.pool_size} samples of "
            f"{spec.image_size[0]} × {spec.image_size[1]} px), more than the {_gib(free)} free in {out_dir}; "
            "lower pool_size (--n) or image_size, or choose another --out")
