"""``synthcal generate``: one dataset spec → one complete sharded store.

The run is planned entirely in the parent process — cameras, homographies and
per-sample seeds — and only rendering is farmed out, shard by shard, to a local
process pool or a Dask cluster. A sample's bytes therefore depend on the
configuration alone, never on the number of workers or the order shards finish in.

Resuming: the store grows under ``NAME.zarr.partial``; each finished shard leaves a
marker in ``.NAME.zarr.progress/``; a rerun with the same configuration renders only
the shards without a marker. The last steps sweep away temporary files a killed
writer left, mark the store complete, record the sealed manifest of every file
(:func:`synthcal.store.write_manifest`) and rename it to ``NAME.zarr``; any later run removes a progress folder
left behind. The whole run holds the store's lock (:func:`synthcal.store.store_lock`),
so a second ``generate`` of the same store fails at once and touches nothing.

Cameras come from a grid (sampled, SPEC §3) or, for a dataset of given ``poses``,
from real homographies (:mod:`synthcal.generate.worldcup`); :func:`plan_cameras`
is the one place that tells them apart.

Local workers import this module as they start, so at its top it imports of the
store only what writes shards (:mod:`synthcal.store.shards`): zarr, which only the
parent needs to create, open and seal the store, would add ≈ 0.1–0.4 s to every
worker's start-up. The functions that do so import :mod:`synthcal.store.format`
where they run (``tests/test_imports.py`` checks a worker's imports).
"""

from __future__ import annotations

import dataclasses
import json
import os
import pickle
import shutil
from collections.abc import Callable, Generator
from concurrent.futures import ProcessPoolExecutor
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm.auto import tqdm

from synthcal.config import ConfigError, DatasetSpec, check_dataset_name
from synthcal.generate.camera import homography as camera_homography
from synthcal.generate.grid import CameraSamples, redraw_cameras, sample_cameras
from synthcal.generate.render import (
    Appearance,
    apply_appearance_on_ground,
    foreground_fraction,
    render_image,
    render_semantic,
    render_semantic_and_mask,
)
from synthcal.generate.resources import check_resources
from synthcal.scenes import Scene, build_scene, freeze, load_user_scene
from synthcal.store import store_lock, write_manifest
from synthcal.store.shards import ShardLayout, write_samples, write_shard
from synthcal.utils.atomic import atomic_write, remove_temporaries
from synthcal.utils.dispatch import check_main_guarded, check_scheduler, dispatch, worker_pool
from synthcal.utils.progress import show_progress

__all__ = ["load_scene", "anchored_spec", "plan_homographies", "plan_cameras", "render_samples", "generate_dataset",
           "store_path", "store_attributes", "foreground_attribute", "seal_store"]


def load_scene(spec: DatasetSpec) -> Scene:
    """The spec's scene: built in, or read from the user's PNG files (cached per process)."""
    key = spec.config_hash()
    if key not in _SCENES:
        _SCENES.clear()  # one scene per worker at a time: they are large
        _SCENES[key] = _read_scene(spec)
    return _SCENES[key]


_SCENES: dict[str, Scene] = {}


def _read_scene(spec: DatasetSpec) -> Scene:
    if spec.user_scene is None:
        return build_scene(spec.scene)
    user = spec.user_scene
    if user.osm is not None:
        return _osm_scene(spec)
    assert user.image is not None and user.semantic is not None  # config: PNG files or osm
    return load_user_scene(
        spec.scene, user.image, user.semantic, palette=user.palette, classes=user.classes,
        heading_deg=user.heading_deg, camera_position=user.camera_position,
        pixels_per_metre=user.pixels_per_metre,
    )


def _osm_scene(spec: DatasetSpec) -> Scene:
    """An OpenStreetMap scene (built once per content, cached), with the entry's camera and heading."""
    from synthcal.scenes.osm import build_osm_scene

    assert spec.user_scene is not None and spec.user_scene.osm is not None
    user, osm = spec.user_scene, spec.user_scene.osm
    scene = build_osm_scene(osm.file, osm.center, osm.size_m, osm.pixels_per_metre, name=spec.scene, seed=osm.seed,
                            classes=osm.classes, rotation_deg=osm.rotation_deg)
    if user.camera_position is None and user.heading_deg == 0.0:
        return scene
    return dataclasses.replace(scene, heading_deg=user.heading_deg,
                               camera_position=user.camera_position or scene.camera_position)


def _source_attributes(spec: DatasetSpec) -> dict:
    """``{"source": …}`` for an OpenStreetMap scene (file hash, centre, size, licence); empty for others."""
    if spec.user_scene is None or spec.user_scene.osm is None:
        return {}
    from synthcal.scenes.osm import osm_attributes

    osm = spec.user_scene.osm
    return {"source": osm_attributes(osm.file, osm.center, osm.size_m, osm.pixels_per_metre, osm.classes, osm.seed,
                                     osm.rotation_deg)}


def anchored_spec(spec: DatasetSpec, scene: Scene) -> DatasetSpec:
    """``spec`` with a relative grid (``xy_relative``) made absolute at the scene's anchor.

    What a store records and hashes is the absolute grid, so a relative grid and
    its absolute spelling give byte-identical stores.
    """
    if spec.grid is None or not spec.grid.xy_relative:
        return spec
    return spec.model_copy(update={"grid": spec.grid.anchored(scene.anchor)})


def _check_grid_inside_scene(spec: DatasetSpec, scene: Scene) -> None:
    if spec.grid is None:
        return
    height, width = scene.semantic.shape
    grid = spec.grid.anchored(scene.anchor)
    for axis, limit in (("x", width - 1), ("y", height - 1)):
        values, given = getattr(grid, axis), getattr(spec.grid, axis)
        if values is not None and (values.start < 0 or values.stop > limit):
            relative = (f" (offsets {given.start:g}..{given.stop:g} from the scene's anchor "
                        f"{scene.anchor[0]:g}, {scene.anchor[1]:g})") if spec.grid.xy_relative else ""
            raise ConfigError(
                f"datasets.{spec.name}: grid {axis} range {values.start:g}..{values.stop:g}{relative} leaves scene "
                f"{scene.name!r} ({width} × {height} px; {axis} must lie in 0..{limit})"
            )


def plan_homographies(spec: DatasetSpec, scene: Scene, cameras: CameraSamples) -> np.ndarray:
    """(N, 3, 3) homographies of the sampled cameras at the output size.

    The scene's heading is added to every pan, and grid focals are scaled from
    ``focal_reference_width`` to the output width (SPEC §2).
    """
    pan, tilt, focal, x, y, z = cameras.values.T
    scale = spec.image_size[0] / spec.focal_reference_width
    return camera_homography(pan + scene.heading_deg, tilt, focal * scale, np.stack([x, y, z], -1), spec.image_size)


def plan_cameras(spec: DatasetSpec, scene: Scene) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The pool's cameras: sampled from the grid, or the dataset's given poses.

    Returns:
        camera fields (``CAMERA_FIELDS`` as (N,) float64, ``grid_index`` (N,)
        int64; −1 for given poses) and (N, 3, 3) homographies at the output size.
    """
    from synthcal.store.format import CAMERA_FIELDS

    if spec.poses is not None:
        from synthcal.generate.worldcup import plan_poses

        return plan_poses(spec, scene)
    if spec.grid is None:  # DatasetConfig gives exactly one of grid: and poses:
        raise ConfigError(f"dataset {spec.name!r}: neither grid nor poses")
    cameras = sample_cameras(spec.grid, spec.pool_size, spec.pool_entropy, scene.camera_position, scene.anchor)
    if spec.min_field_fraction > 0:
        cameras = _redraw_sparse(spec, scene, cameras)
    camera = {name: cameras.values[:, i] for i, name in enumerate(CAMERA_FIELDS)}
    camera["grid_index"] = cameras.grid_index
    return camera, plan_homographies(spec, scene, cameras)


def _redraw_sparse(spec: DatasetSpec, scene: Scene, cameras: CameraSamples) -> CameraSamples:
    """Redraw the cameras whose semantic map has a non-background share below ``min_field_fraction``.

    Every camera's map is rendered here, in the planning process, at the output
    size (≈ 0.3 ms each at 256 × 144), and :func:`~synthcal.generate.grid.redraw_cameras`
    replaces the rejected ones from per-sample streams: the same configuration
    gives the same pool whatever the number of workers.
    """
    assert spec.grid is not None  # plan_cameras calls it for grid datasets only

    def keep(values: np.ndarray) -> np.ndarray:
        homographies = plan_homographies(spec, scene, CameraSamples(np.zeros(len(values), np.int64), values))
        maps = np.stack([render_semantic(scene.semantic, H, spec.image_size) for H in homographies])
        return foreground_fraction(maps) >= spec.min_field_fraction

    try:
        redrawn, _ = redraw_cameras(spec.grid, cameras, keep, spec.pool_entropy, scene.camera_position, scene.anchor)
    except ValueError as exc:
        raise ConfigError(f"datasets.{spec.name}.min_field_fraction: {exc}; lower it "
                          f"(value {spec.min_field_fraction:g})") from None
    return redrawn


def sample_rng(seed: int | tuple[int, ...], index: int) -> np.random.Generator:
    """The generator of sample ``index``'s appearance: one stream per sample.

    ``seed`` is the pool's :attr:`~synthcal.config.DatasetSpec.pool_entropy`.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1, index)))


def render_samples(
    scene: Scene, homographies: np.ndarray, first_index: int, spec: DatasetSpec,
    indices: np.ndarray | None = None, images: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Render consecutive samples ``first_index, first_index + 1, …`` (or the pool samples ``indices``).

    A sample's bytes depend only on the spec, its homography and its index (its
    appearance stream :func:`sample_rng`), so rendering it alone, later, gives the
    bytes a full render gives (``images: splits`` stores rely on it).

    Args:
        indices: (K,) the samples' pool indices (default: consecutive from ``first_index``).
        images: False: semantic maps only (the returned images are then (0, H, W, 3)).

    Returns:
        images (K, H, W, 3) uint8 and semantic maps (K, H, W) uint8.
    """
    width, height = spec.image_size
    numbers = first_index + np.arange(len(homographies)) if indices is None else np.asarray(indices, np.int64)
    appearance = Appearance(**spec.appearance.model_dump())
    rgb = np.empty((len(homographies) if images else 0, height, width, 3), np.uint8)
    semantics = np.empty((len(homographies), height, width), np.uint8)
    # Stage by stage rather than sample by sample: each loop keeps one bird's-eye
    # array hot in the cache (≈ 10 % faster than interleaving them).
    for k in range(len(rgb)):
        rgb[k] = render_image(scene.image, homographies[k], spec.image_size, spec.supersample)
    on_scene = np.empty((len(homographies), height, width), bool)
    for k, H in enumerate(homographies):
        semantics[k], on_scene[k] = render_semantic_and_mask(scene.semantic, H, spec.image_size)
    for k in range(len(rgb)):  # off-scene pixels end black, as in the semantic map
        apply_appearance_on_ground(rgb[k], homographies[k], appearance, sample_rng(spec.pool_entropy, int(numbers[k])),
                                   on_scene[k])
    return rgb, semantics


@dataclass(frozen=True)
class ShardTask:
    """One shard's worth of work, small enough to ship to any worker."""

    spec: DatasetSpec
    layouts: dict[str, ShardLayout]
    progress: Path
    shard: int
    start: int
    homographies: np.ndarray
    scene_file: Path | None = None

    def done_marker(self) -> Path:
        return self.progress / f"shard-{self.shard:07d}.done"


SCENE_FILE = "scene.pickle"
"""The scene as the parent built it, in the progress folder, for the workers (:func:`_task_scene`)."""


def _save_scene(scene: Scene, progress: Path) -> Path:
    """Write ``scene`` for the workers: unpickling it (≈ 10 ms) replaces building it (0.2–0.8 s) in each."""
    path = progress / SCENE_FILE
    with atomic_write(path) as tmp, open(tmp, "wb") as file:
        pickle.dump(scene, file, protocol=pickle.HIGHEST_PROTOCOL)
    return path


def _task_scene(task: ShardTask) -> Scene:
    """The task's scene: this process's cached one, else the parent's file, else built here."""
    key = task.spec.config_hash()
    if key not in _SCENES and task.scene_file is not None and task.scene_file.is_file():
        with open(task.scene_file, "rb") as file:
            scene = pickle.load(file)  # our own file, written by this run's parent (_save_scene)
        _SCENES.clear()
        _SCENES[key] = dataclasses.replace(scene, image=freeze(scene.image), semantic=freeze(scene.semantic))
    return load_scene(task.spec)


def run_shard(task: ShardTask) -> int:
    """Render and write one shard, then mark it done; returns its sample count."""
    cv2.setNumThreads(1)  # one process per core: OpenCV's own threads would oversubscribe
    scene = _task_scene(task)
    with_images = task.spec.images == "all"  # images: splits renders images when splits are drawn
    images, semantics = render_samples(scene, task.homographies, task.start, task.spec, images=with_images)
    if with_images:
        write_samples(task.layouts, task.shard, images, semantics)
    else:
        write_shard(task.layouts["semantic"], task.shard, semantics)
    # The marker holds each sample's non-background pixel count: the store's "foreground" attribute.
    counts = np.count_nonzero(semantics.reshape(len(semantics), -1), axis=1)
    with atomic_write(task.done_marker()) as marker:
        marker.write_text(json.dumps(counts.tolist()))
    return len(semantics)


def _foreground(tasks: list[ShardTask], spec: DatasetSpec) -> dict | None:
    """The ``foreground`` attribute from the shards' done markers (None if one cannot be read).

    ``empty_samples``: samples whose semantic map is all background (class 0);
    ``min_fraction`` / ``mean_fraction``: the non-background share of the maps.
    """
    try:
        counts = np.concatenate([np.asarray(json.loads(task.done_marker().read_text()), np.int64) for task in tasks])
    except (OSError, ValueError):
        return None
    if len(counts) != spec.pool_size:
        return None
    return foreground_attribute(counts, spec.image_size)


def foreground_attribute(counts: np.ndarray, image_size: tuple[int, int]) -> dict:
    """The ``foreground`` attribute of a store from each sample's (N,) non-background pixel count."""
    fractions = counts / float(image_size[0] * image_size[1])
    return {"empty_samples": int(np.count_nonzero(counts == 0)), "min_fraction": float(fractions.min()),
            "mean_fraction": float(fractions.mean())}


def store_path(out_dir: Path, dataset: str) -> Path:
    """Where ``dataset``'s finished store lives under ``out_dir``.

    Raises:
        ConfigError: not a plain name (a path separator, ``.`` or ``..``): it would leave ``out_dir``.
    """
    check_dataset_name(dataset)
    return Path(out_dir) / f"{dataset}.zarr"


def store_attributes(spec: DatasetSpec, scene: Scene, poses: dict | None = None) -> dict:
    """A new store's group attributes (provenance, SPEC §5), ``complete`` False.

    Args:
        poses: the ``poses`` attribute of given cameras (default: the spec's pose
            set's, :func:`~synthcal.generate.worldcup.pose_attributes`; None for a grid).
    """
    from synthcal.generate.worldcup import pose_attributes
    from synthcal.store.format import FORMAT_VERSION, software_versions
    from synthcal.store.images import IMAGES_ATTR, images_attribute

    if poses is None and spec.poses is not None:
        poses = pose_attributes(spec.poses)
    return {
        "format_version": FORMAT_VERSION,
        "dataset": spec.name,
        "scene": {
            "name": scene.name, "classes": list(scene.classes), "palette": [list(c) for c in scene.palette],
            "heading_deg": scene.heading_deg, "pixels_per_metre": scene.pixels_per_metre,
            "camera_position": None if scene.camera_position is None else list(scene.camera_position),
            "field": scene.field_polygon(),  # iou_part's clip polygon (SPEC §4, §8)
            "description": scene.description,
            **_source_attributes(spec),
        },
        "grid": None if spec.grid is None else spec.grid.model_dump(mode="json"),
        "poses": poses,
        "N": spec.pool_size,
        "seed": spec.seed,
        "pool_seed": spec.pool_seed_attributes(),
        "image_size": list(spec.image_size),
        "focal_reference_width": spec.focal_reference_width,
        "shard_size": spec.shard_size,
        "software": software_versions(),
        "config_hash": spec.config_hash(),
        "config": spec.stored_config(),
        **({IMAGES_ATTR: images_attribute(0)} if spec.images == "splits" else {}),
        "complete": False,
    }


def _prepare_partial(spec: DatasetSpec, scene: Scene, partial: Path, progress: Path) -> np.ndarray:
    """Create (or check, when resuming) the partial store; return the homographies."""
    from synthcal.store.format import array_at, create_store, open_group

    if partial.exists():
        group = open_group(partial)
        if group.attrs.get("config_hash") != spec.config_hash():
            raise ConfigError(
                f"{partial}: an unfinished store made with a different configuration "
                f"(config_hash {group.attrs.get('config_hash')!r}); delete it or choose another output folder"
            )
        return np.asarray(array_at(group, "homography")[:])
    camera, homographies = plan_cameras(spec, scene)
    # Build the skeleton under a scratch name so a crash here leaves nothing to resume from.
    scratch = partial.with_name(partial.name + ".creating")
    shutil.rmtree(scratch, ignore_errors=True)
    try:
        create_store(scratch, store_attributes(spec, scene), spec.image_size, spec.shard_size,
                     homographies, camera, scene.image, scene.semantic, images_splits=spec.images == "splits")
    except BaseException:  # disk full, Ctrl-C: leave no skeleton behind
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    shutil.rmtree(progress, ignore_errors=True)
    progress.mkdir(parents=True)
    os.replace(scratch, partial)
    return homographies


@dataclass(frozen=True)
class _Workers:
    """Where shards render: ``count`` local processes (``pool``, already started, if more than one),
    or the Dask cluster at ``scheduler``."""

    count: int
    scheduler: str | None
    pool: ProcessPoolExecutor | None


def _execute(tasks: list[ShardTask], workers: _Workers) -> Generator[int, None, None]:
    """Run shard tasks in-process, on a process pool or on a Dask cluster; yields sample counts."""
    previous = cv2.getNumThreads()
    try:
        yield from dispatch(run_shard, tasks, workers.count, workers.scheduler, workers.pool)
    finally:
        cv2.setNumThreads(previous)  # run_shard sets one thread; undo it where it ran in this process


def generate_dataset(
    spec: DatasetSpec,
    out_dir: str | Path,
    workers: int = 1,
    scheduler: str | None = None,
    progress: bool | None = None,
    on_shard: Callable[[int], None] | None = None,
    max_memory: int | None = None,
) -> Path:
    """Generate (or resume, or find finished) the store of one dataset.

    Args:
        spec: the resolved dataset configuration.
        out_dir: folder that receives ``NAME.zarr``.
        workers: local worker processes (1: in this process).
        scheduler: a Dask scheduler address; overrides ``workers``.
        progress: show a progress bar (None: when standard error is a terminal).
        on_shard: called after each finished shard with its sample count.
        max_memory: the memory budget in bytes (None: this machine's memory;
            :func:`~synthcal.generate.resources.check_resources`).

    Returns:
        the path of the complete store.

    Raises:
        ConfigError: a scene that cannot be loaded, a grid leaving the scene, or
            a store at the destination made from another configuration; a
            :class:`~synthcal.generate.resources.ResourceError` when the run needs
            more memory or disk than there is. Nothing is written in those cases.
        StoreLocked: another process is generating this store (or drawing its
            splits); nothing is touched.
        UnguardedScript: ``workers`` > 1 from a script without ``if __name__ == "__main__":``
            (its workers would run its calls again); nothing is written.
    """
    out_dir = Path(out_dir)
    final = store_path(out_dir, spec.name)
    # Local workers start first: their start-up (≈ 0.3 s of imports each, no zarr) overlaps building
    # the scene and the store's skeleton here.
    local = workers if scheduler is None and not final.exists() else 1
    if local > 1:
        check_main_guarded()  # before any worker starts: each would re-run an unguarded script's calls
    with worker_pool(local, preload=(__name__,)) as pool:
        scene = load_scene(spec)
        _check_grid_inside_scene(spec, scene)
        spec = anchored_spec(spec, scene)
        if not final.exists():
            partial = final.with_name(final.name + ".partial")
            check_resources(spec, scene.semantic.size, out_dir, 1 if scheduler is not None else workers, max_memory,
                            fresh=not partial.exists())
        if scheduler is not None and not final.exists():
            check_scheduler(scheduler)  # before anything is written: an unreachable one leaves nothing behind
        out_dir.mkdir(parents=True, exist_ok=True)
        with store_lock(final):
            try:
                return _generate_locked(spec, scene, final, _Workers(workers, scheduler, pool),
                                        show_progress(progress), on_shard)
            except OSError as exc:
                if exc.filename is None and exc.errno is not None:  # Zarr's writes into a full disk name no file
                    raise OSError(exc.errno, exc.strerror, str(final.with_name(final.name + ".partial"))) from exc
                raise


def _generate_locked(spec: DatasetSpec, scene: Scene, final: Path, workers: _Workers,
                     progress: bool, on_shard: Callable[[int], None] | None) -> Path:
    """:func:`generate_dataset`'s work, under the store's lock."""
    from synthcal.store.format import image_layouts, open_group

    partial = final.with_name(final.name + ".partial")
    progress_dir = final.with_name(f".{final.name}.progress")
    if final.exists():
        group = open_group(final)
        if group.attrs.get("config_hash") != spec.config_hash():
            raise ConfigError(f"{final}: exists and was made with a different configuration; "
                              "delete it or choose another output folder")
        shutil.rmtree(progress_dir, ignore_errors=True)  # a run killed just after its final rename
        return final
    homographies = _prepare_partial(spec, scene, partial, progress_dir)
    layouts = image_layouts(partial)
    size = spec.shard_size
    tasks = [
        ShardTask(spec, layouts, progress_dir, shard, start, homographies[start:start + size])
        for shard, start in enumerate(range(0, spec.pool_size, size))
    ]
    pending = [task for task in tasks if not task.done_marker().exists()]
    if pending and (workers.count > 1 or workers.scheduler is not None):  # here the scene is at hand already
        scene_file = _save_scene(scene, progress_dir)
        pending = [dataclasses.replace(task, scene_file=scene_file) for task in pending]
    done = spec.pool_size - sum(len(task.homographies) for task in pending)
    with tqdm(total=spec.pool_size, initial=done, unit="sample", desc=spec.name, disable=not progress) as bar:
        try:
            with closing(_execute(pending, workers)) as counts:  # closing it stops the workers
                for count in counts:
                    bar.update(count)
                    if on_shard is not None:
                        on_shard(count)
        except BaseException:  # Ctrl-C, disk full: local workers are gone now; sweep what they left half-written
            if workers.scheduler is None:
                remove_temporaries(partial)
            raise
    # Killed writers (this run's or an earlier one's) may have left temporaries; under
    # the lock none is at work, so whatever matches is debris.
    remove_temporaries(partial)
    seal_store(partial, final, _foreground(tasks, spec))
    shutil.rmtree(progress_dir, ignore_errors=True)
    return final


def seal_store(partial: Path, final: Path, foreground: dict | None) -> None:
    """Mark a fully written ``partial`` store complete, record its manifest and rename it ``final``.

    The caller holds the store's lock and has swept temporaries of killed writers.
    """
    from synthcal.store.format import open_group

    group = open_group(partial, mode="r+")
    group.attrs.update({"foreground": foreground, "complete": True})
    remove_temporaries(partial)  # zarr writes zarr.json through a temporary too
    write_manifest(partial)  # last: it lists every file, the root zarr.json just written included
    os.replace(partial, final)
