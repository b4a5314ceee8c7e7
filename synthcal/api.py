"""The Python front door: thin typed functions over synthcal's packages (issue 21).

``import synthcal`` exposes these (and :class:`~synthcal.estimators.protocol.Estimator`,
:class:`~synthcal.data.loaders.SplitDataset`) lazily: nothing heavy is imported
until a name is used. Each function only wraps an existing one, giving it the
shape a script wants; the command line (:mod:`synthcal.cli`) is the other door.

Convention: every homography maps a **bird's-eye pixel to an image pixel**,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2). Images are
``(H, W, 3)`` uint8 RGB, semantic maps ``(H, W)`` uint8 class ids 0–3.

The examples generate a ``smoke`` store (48 samples at 64 × 36, under a second).
Like :mod:`synthcal.cli`, this module may import any package of synthcal; it does
so inside the functions, so that importing it stays cheap.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd
    import zarr

    from synthcal.config import LoadedConfig
    from synthcal.data.loaders import SplitDataset

__all__ = ["load_config", "generate_store", "open_store", "load_split", "evaluate", "evaluate_images", "bench",
           "segmentation_quality"]


def load_config(path: str | Path | None = None) -> LoadedConfig:
    """Read and validate a ``datasets.yaml`` (:func:`synthcal.config.load_config`).

    Args:
        path: the file; None: ``./datasets.yaml`` when present, else the packaged one.

    Returns:
        the configuration: ``.dataset_names``, ``.resolve(dataset, profile)`` → the
        dataset's full specification, ``.config`` (the validated file).

    Raises:
        ConfigError: unreadable file, unknown key, bad value; names file, key and value.

    Example:
        >>> import synthcal
        >>> config = synthcal.load_config()
        >>> "intersection-1" in config.dataset_names
        True
        >>> config.resolve("intersection-1", "smoke").image_size   # (width, height)
        (64, 36)
    """
    from synthcal.config import load_config as load

    return load(path)


def generate_store(dataset: str, out: str | Path, profile: str | None = None, *, config: str | Path | None = None,
             n: int | None = None, splits: bool = True, workers: int = 1, progress: bool = False) -> Path:
    """Generate (or resume, or find finished) a dataset's store ``OUT/DATASET.zarr``, then draw its splits.

    ``synthcal generate DATASET --out OUT [--profile P] [--splits]`` as a function.

    Args:
        dataset: a dataset of the configuration (``synthcal datasets`` lists them).
        out: the folder receiving ``DATASET.zarr``.
        profile: sizes from ``datasets.yaml``: ``smoke`` (48 samples at 64 × 36),
            ``demo``, ``quick``, ``paper``; None: the dataset entry as written.
        config: the ``datasets.yaml`` (default as in :func:`load_config`).
        n: the pool size, overriding the configuration's.
        splits: also draw the train / test / dictionary splits of the
            configuration's split seeds (0–4 by default), mixed dictionaries where
            their source stores exist.
        workers: local worker processes (1: this one).
        progress: a progress bar on standard error.

    Returns:
        the path of the complete store.

    Raises:
        ConfigError: unknown dataset or profile, a bad configuration, or a store at
            the destination made from another configuration.

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> store = synthcal.generate_store("intersection-1", tmp.name, profile="smoke")
        >>> store.name
        'intersection-1.zarr'
        >>> synthcal.open_store(store)["image"].shape   # (N, height, width, RGB)
        (48, 36, 64, 3)
        >>> tmp.cleanup()
    """
    from synthcal.generate.pipeline import generate_dataset
    from synthcal.generate.splits import draw_splits

    spec = load_config(config).resolve(dataset, profile, n)
    path = generate_dataset(spec, out, workers=workers, progress=progress)
    if splits:
        draw_splits(path, spec.split_seeds, spec.splits, spec.mixed_sources)
    return path


def open_store(store: str | Path) -> zarr.Group:
    """A complete store, opened read-only as a Zarr v3 group (:func:`synthcal.store.open_store`).

    Arrays (SPEC §5): ``image`` (N, H, W, 3) uint8, ``semantic`` (N, H, W) uint8,
    ``homography`` (N, 3, 3) float64 bird's-eye pixel → image pixel, the cameras'
    parameters, ``scene/image`` and ``scene/semantic``; ``attrs`` hold the dataset's
    configuration. Any Zarr v3 reader opens the same folder.

    Raises:
        StoreError: no store there, or an unfinished one.
        CorruptStore: a shard file missing or of the wrong size (names it).

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> group = synthcal.open_store(synthcal.generate_store("intersection-1", tmp.name, profile="smoke"))
        >>> group["homography"].shape, group.attrs["image_size"]
        ((48, 3, 3), [64, 36])
        >>> tmp.cleanup()
    """
    from synthcal.store import open_store as open_group

    return open_group(store)


def load_split(store: str | Path, split: str = "test", seed: int = 0, mixed: bool | None = None) -> SplitDataset:
    """One split of a store, held in memory as NumPy arrays and usable as a torch ``Dataset``.

    :func:`synthcal.data.load_split` with defaults: the test split of seed 0.

    Args:
        store: the store ``NAME.zarr``.
        split: ``train``, ``test`` or ``dictionary``.
        seed: the split seed (drawn by :func:`generate_store`, or ``synthcal split``).
        mixed: for ``dictionary``: True the mixed dictionary (templates from other
            scenes), False the store's own; None: the own one where there is one.

    Returns:
        a :class:`~synthcal.data.loaders.SplitDataset`: arrays ``.images`` (K, H, W, 3)
        uint8, ``.semantics`` (K, H, W) uint8, ``.homographies`` (K, 3, 3) float64
        (bird's-eye pixel → image pixel), ``.indices`` (K,) pool indices, ``.scene``;
        item ``k`` is ``(image (3, H, W) float32 in [0, 1], semantic (H, W) int64,
        homography (3, 3) float64)`` tensors.

    Raises:
        SplitError: unknown split or seed (names store, key and value).

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> store = synthcal.generate_store("intersection-1", tmp.name, profile="smoke")
        >>> train = synthcal.load_split(store, "train", seed=0)
        >>> train.images.shape, train.homographies.shape     # the smoke profile: 24 train samples
        ((24, 36, 64, 3), (24, 3, 3))
        >>> image, semantic, H = train[0]                     # torch tensors
        >>> tuple(image.shape), tuple(semantic.shape), tuple(H.shape)
        ((3, 36, 64), (36, 64), (3, 3))
        >>> tmp.cleanup()
    """
    from synthcal.data import load_split as load

    return load(store, split, seed, mixed)


def evaluate_images(split: SplitDataset, estimates: Any) -> pd.DataFrame:
    """Score estimates of a split's images, one row per image (SPEC §8).

    :func:`synthcal.eval.metrics.evaluate` on the split's scene, true homographies
    and image size, with the scene's field polygon as the store records it.

    Args:
        split: the split the estimates are for (usually ``load_split(store, "test")``).
        estimates: (K, 3, 3) bird's-eye pixel → image pixel homographies, any scale
            and sign (NumPy or torch); a NaN or singular one counts as a failure.

    Returns:
        DataFrame with one row per image: ``iou``, ``iou_bg``, ``iou_weighted``,
        ``iou_part``, ``iou_whole`` (in [0, 1]), ``failed``, ``failure``,
        ``skipped`` (the true view sees no field: metrics NaN).

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> test = synthcal.load_split(synthcal.generate_store("intersection-1", tmp.name, profile="smoke"), "test")
        >>> frame = synthcal.evaluate_images(test, test.homographies)   # the truth scores 1
        >>> len(frame), bool((frame.loc[~frame["skipped"], "iou_part"] == 1.0).all())
        (8, True)
        >>> tmp.cleanup()
    """
    import numpy as np

    from synthcal.eval.scoring import evaluate as score
    from synthcal.store import attributes
    from synthcal.store import open_store as open_group

    field = attributes(open_group(split.store))["scene"].get("field")  # None: the whole scene
    image_size = (split.images.shape[2], split.images.shape[1])
    return score(split.scene.semantic, estimates, split.homographies, image_size,
                 field=None if field is None else np.asarray(field, np.float64),
                 indices=np.asarray(split.indices), source=str(split.store))


def evaluate(split: SplitDataset, estimates: Any) -> dict[str, float]:
    """The readings of estimates of a split's images: means over the scored images (SPEC §8).

    :func:`evaluate_images`, then :func:`synthcal.eval.metrics.summarize`.

    Args:
        split: the split the estimates are for (usually ``load_split(store, "test")``).
        estimates: (K, 3, 3) bird's-eye pixel → image pixel homographies, any scale and sign.

    Returns:
        ``iou``, ``iou_bg``, ``iou_weighted`` (three readings of the paper's IoU),
        ``iou_part``, ``iou_whole`` (failures count 0), ``completeness`` (share of
        usable estimates), ``n_images`` (scored) and ``n_skipped``.

    Example:
        >>> import tempfile, numpy as np, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> test = synthcal.load_split(synthcal.generate_store("intersection-1", tmp.name, profile="smoke"), "test")
        >>> synthcal.evaluate(test, test.homographies)["iou_part"]          # the truth
        1.0
        >>> synthcal.evaluate(test, np.full((len(test), 3, 3), np.nan))["completeness"]   # no estimate
        0.0
        >>> tmp.cleanup()
    """
    from synthcal.eval.scoring import summarize

    return summarize(evaluate_images(split, estimates))


def bench(data: str | Path, datasets: Sequence[str], estimators: Sequence[str], results: str | Path,
          seeds: Sequence[int] = (0,), profile: str | None = None, *, config: str | Path | None = None,
          device: str = "auto", timeout: float | None = None, progress: bool = False,
          workers: int = 1, threads: int | None = None) -> pd.DataFrame:
    """Fit and score estimators over datasets and seeds, one process per run (resumable).

    ``synthcal bench`` as a function, with its defaults for the axes (step-by-step
    training, Top-MSE loss and matching, the profile's segmentation, split sizes
    and dictionary).

    Args:
        data: the folder holding the stores ``NAME.zarr`` (splits drawn).
        datasets: dataset labels: ``NAME``, or ``mixed-K`` for a mixed dictionary.
        estimators: bundled names (``identity``, ``template``, ``ecc``,
            ``baseline``, ``proposed``), entry points, or ``package.module:Class``
            paths importable from ``sys.path`` (:class:`~synthcal.estimators.protocol.Estimator`).
        results: the results folder (``runs/``, ``cache/``); finished runs are kept.
        seeds: split seeds.
        profile: training sizes and split caps of ``datasets.yaml`` (``smoke`` …).
        config: the ``datasets.yaml`` (default as in :func:`load_config`).
        device: torch device of the bundled models (``auto``: CUDA when available).
        timeout: seconds each run's process may take; None: no limit.
        progress: progress bars.
        workers: runs executed side by side, this machine's cores shared among them
            (:func:`synthcal.eval.harness.run_threads`) unless ``threads`` is given.
        threads: torch threads of each run, whatever ``workers`` (None: the cores shared
            out). torch's thread count orders its sums: scores agree to the digit only
            between runs at the same count, and a long training can grow the rounding into
            another kept epoch (docs/benchmark.md); a fixed count makes them independent of
            ``workers``. Each ``run.json`` records its threads (``machine``).

    Returns:
        one row per finished run of this call: ``dataset``, ``model``, ``seed``, the
        readings (``iou`` …), ``completeness``, ``status`` (``ok``/``failed``),
        ``error``, ``run_id``, …

    Raises:
        SplitError: a missing store or undrawn seed. EstimatorError: an unknown estimator.
        ValueError: ``threads`` is not a positive count.

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> _ = synthcal.generate_store("intersection-1", f"{tmp.name}/data", profile="smoke")
        >>> frame = synthcal.bench(f"{tmp.name}/data", ["intersection-1"], ["identity"], f"{tmp.name}/results",
        ...                        profile="smoke")
        >>> list(frame["status"]), list(frame["model"])
        (['ok'], ['identity'])
        >>> tmp.cleanup()
    """
    from synthcal.eval.harness import expand_runs, run_sweep

    loaded = load_config(config)
    limits = loaded.split_caps(profile)
    training = loaded.training(profile)
    runs = expand_runs(data, datasets, estimators, seeds, profile, training.settings(),
                       segmentations=(training.segmentation,), device=device, limits=limits,
                       dictionary={label: loaded.dictionary(label, profile) for label in datasets})
    frame = run_sweep(runs, results, progress=progress, timeout=timeout, workers=workers, threads=threads)
    return frame[frame["run_id"].isin({run.id for run in runs})].reset_index(drop=True)


def _finished_runs(results: str | Path) -> pd.DataFrame:
    """The finished runs of a results folder, one label per estimator (ValueError: no folder, or no run)."""
    from synthcal.eval.report import finished_runs, one_label

    return one_label(finished_runs(results))


def report(results: str | Path, metric: str = "iou") -> pd.DataFrame:
    """``synthcal table RESULTS --layout report``'s numbers: one row per cell, its paired difference against
    ``sha2020`` with the 95 % t interval, the paper's figure and a verdict (docs/reproduction.md, "Verdicts").

    Args:
        results: the results folder of :func:`bench`, or its runs archive (``synthcal table RESULTS --layout
            runs --format csv``; :mod:`synthcal.eval.archive`).
        metric: the reading (``iou``, ``iou_weighted``, ``reproj_px`` …).

    Returns:
        the columns of :func:`synthcal.eval.reproduction.report_frame` (the CSV's).

    Raises:
        ValueError: no such folder, no finished runs, or runs the report cannot read.

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> _ = synthcal.generate_store("intersection-1", f"{tmp.name}/data", profile="smoke")
        >>> _ = synthcal.bench(f"{tmp.name}/data", ["intersection-1"], ["identity"], f"{tmp.name}/results",
        ...                    profile="smoke")
        >>> cells = synthcal.report(f"{tmp.name}/results")
        >>> cells[["dataset", "model", "n_seeds", "verdict"]].values.tolist()  # no sha2020 run: no claim to judge
        [['intersection-1', 'identity', 1, '–']]
        >>> tmp.cleanup()
    """
    from synthcal.eval.report import report_numbers

    return report_numbers(_finished_runs(results), metric, results)


def paired_differences(results: str | Path, a: str, b: str, *, metric: str = "iou",
                       against: str | Path | None = None) -> pd.DataFrame:
    """``synthcal table RESULTS --paired A B [--against OTHER]``'s numbers: per cell, the per-seed differences
    A − B of runs on the same split seed and settings, with their 95 % t and bootstrap intervals.

    Args:
        results: the results folder of :func:`bench` (side A's, with ``against``), or its runs archive (no
            bootstrap interval: an archive keeps no per-image scores).
        a, b: model labels or estimator names (``proposed``, ``baseline``), or ``KEY=VALUE``
            for another key (``loss=top-mse``, ``segmentation=unet``).
        metric: the reading.
        against: side B's results folder, for runs kept apart (another setting or code):
            they pair with side A's on the dataset, seed and every other key. ``paper``
            compares the sides' own values where they differ (``loss=top-mse`` against
            ``loss=mse`` kept in two archives); none where they are equal.

    Returns:
        one row per cell (:func:`synthcal.eval.statistics.paired_frame`): the other keys,
        ``mean``, ``std``, ``n_pairs``, ``a_wins``, ``t_low``, ``t_high``, ``p``,
        ``boot_low``, ``boot_high``, ``paper``, ``verdict``.

    Raises:
        ValueError: no such folder, no finished runs, a side no run has, or no pair.

    Example:
        >>> import tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> _ = synthcal.generate_store("intersection-1", f"{tmp.name}/data", profile="smoke")
        >>> _ = synthcal.bench(f"{tmp.name}/data", ["intersection-1"], ["template", "identity"],
        ...                    f"{tmp.name}/results", profile="smoke")
        >>> cells = synthcal.paired_differences(f"{tmp.name}/results", "template", "identity")
        >>> cells[["dataset", "n_pairs"]].values.tolist(), bool(cells["mean"].iloc[0] > 0)
        ([['intersection-1', 1]], True)
        >>> tmp.cleanup()
    """
    from synthcal.eval.report import paired_numbers

    other = None if against is None else _finished_runs(against)
    return paired_numbers(_finished_runs(results), (a, b), metric, results, other, against)


def paired_contrast(results: str | Path, a: str, b: str, c: str, d: str, *, metric: str = "iou",
                    against: str | Path | None = None) -> pd.DataFrame:
    """``synthcal table RESULTS --paired A B --between C D [--against OTHER]``'s numbers: per cell, how much
    larger the paired difference A − B is under C than under D — per seed ``(A − B)_C − (A − B)_D``, with
    its 95 % t interval over seeds (e.g. whether a UNet's maps cost one model more than another).

    Args:
        results, a, b, metric, against: as :func:`paired_differences`.
        c, d: two values of another key than A and B's: model labels or estimator names, or ``KEY=VALUE``.

    Returns:
        one row per cell (:func:`synthcal.eval.statistics.contrast_frame`): the other keys, ``mean``,
        ``std``, ``n_pairs`` (seeds with all four runs), ``c_wins``, ``t_low``, ``t_high``, ``p``.

    Raises:
        ValueError: as :func:`paired_differences`, C or D over A and B's key, or no seed with all four runs.

    Example (a hand-made runs archive: what a UNet's maps cost each model on three seeds):
        >>> import tempfile, pandas as pd, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> iou = {("proposed", "ground-truth"): [.60, .62, .58], ("proposed", "unet"): [.55, .60, .53],
        ...        ("sha2020", "ground-truth"): [.63, .64, .62], ("sha2020", "unet"): [.62, .63, .61]}
        >>> runs = pd.DataFrame([dict(dataset="intersection-1", model=m, estimator=m, training="step-by-step",
        ...     loss="top-mse", matching_score="top-mse", segmentation=s, profile="quick", dictionary="split",
        ...     status="ok", seed=k, iou=v, run_id=f"{m}_{s}_s{k}")
        ...     for (m, s), values in iou.items() for k, v in enumerate(values)])
        >>> choices = ["learning_rate", "unet_epochs", "stn_epochs", "unet_missed", "seconds"]
        >>> runs.reindex(columns=[*runs, *choices]).to_csv(f"{tmp.name}/runs.csv", index=False)
        >>> cell = synthcal.paired_contrast(f"{tmp.name}/runs.csv", "segmentation=ground-truth",
        ...                                 "segmentation=unet", "proposed", "sha2020").iloc[0]
        >>> round(float(cell["mean"]), 2), int(cell["c_wins"]), int(cell["n_pairs"])
        (3.0, 3, 3)
        >>> tmp.cleanup()
    """
    from synthcal.eval.report import contrast_numbers

    other = None if against is None else _finished_runs(against)
    return contrast_numbers(_finished_runs(results), (a, b), (c, d), metric, results, other, against)


def segmentation_quality(results: str | Path, data: str | Path | None = None, *, device: str = "cpu",
                         batch_size: int = 64) -> pd.DataFrame:
    """The UNets a results folder caches, scored on the test split of their seed (issue 27).

    Each finished run of a bundled paper model trained ``step-by-step`` under
    ``segmentation: unet`` (:func:`synthcal.eval.segmentation.unet_records`) names
    its UNet by the key its estimator gave it, as the run recorded it (``stage_keys``;
    for runs from before it was recorded, recomputed: :mod:`synthcal.estimators.paper`,
    ``cache_dir``: the train split's arrays, sizes and code hash, the UNet's
    settings, the learning rate validation chose, the seed); runs sharing a UNet
    (every model and loss of one seed, unless validation chose them different
    rates) are scored once. The UNet segments the run's test
    split at the working resolution, as the pipeline reads it, against the true
    maps reduced to it as the UNet was trained.

    Args:
        results: the results folder of :func:`bench` (``runs/``, ``cache/unet/``).
        data: the folder holding the stores ``NAME.zarr``; None: where each run
            recorded its store.
        device: torch device for the UNet.
        batch_size: test images per forward pass.

    Returns:
        one row per UNet: ``dataset``, ``seed``, ``models`` (the labels of the runs
        that read it, comma-separated), ``learning_rate`` (it trained at), ``unet``
        (its cache key), ``n_images``, ``work_size``, then :func:`synthcal.eval.segmentation.quality_row`'s
        columns (fractions; class names from the store's scene).

    Raises:
        FileNotFoundError: no such results folder, or a run's UNet absent from its cache (names the file).
        ValueError: no run in it reads a cached UNet.

    Example:
        >>> import pathlib, tempfile, synthcal
        >>> tmp = tempfile.TemporaryDirectory()
        >>> layer = pathlib.Path(tmp.name, "unet.yaml")  # the packaged smoke profile, with a UNet
        >>> _ = layer.write_text("profiles: {smoke: {training: {segmentation: unet}}}")
        >>> _ = synthcal.generate_store("intersection-1", f"{tmp.name}/data", profile="smoke")
        >>> _ = synthcal.bench(f"{tmp.name}/data", ["intersection-1"], ["proposed"], f"{tmp.name}/results",
        ...                    profile="smoke", config=layer, device="cpu")
        >>> quality = synthcal.segmentation_quality(f"{tmp.name}/results")
        >>> list(quality[["dataset", "seed", "n_images"]].itertuples(index=False, name=None))
        [('intersection-1', 0, 8)]
        >>> bool(0 <= quality["mean iou"][0] <= 1)
        True
        >>> tmp.cleanup()
    """
    import dataclasses
    import json

    import numpy as np
    import pandas as pd
    import torch

    from synthcal.config import TrainingSettings
    from synthcal.data import read_scene
    from synthcal.eval.harness import Run
    from synthcal.eval.isolation import load_run_split
    from synthcal.eval.segmentation import chosen_learning_rate, confusion_matrix, quality_row, unet_records
    from synthcal.models import UNet, device_from_name
    from synthcal.training import (
        NUM_CLASSES,
        StageCache,
        reduce_class_maps,
        reduce_images,
        train_cache_key,
        unet_cache_key,
    )

    if not Path(results).is_dir():
        raise FileNotFoundError(f"{results}: no such results folder")
    records = unet_records(results)
    if not records:
        raise ValueError(f"{results}: no finished step-by-step run of a bundled model with segmentation 'unet'")
    cache, torch_device = StageCache(Path(results) / "cache"), device_from_name(device)
    rows: dict[str, dict[str, Any]] = {}
    train_keys: dict[tuple[Any, ...], tuple[tuple[int, int], str]] = {}
    for record in records:
        run = Run(**record["run"])
        if data is not None:
            run = dataclasses.replace(run, store=str(Path(data) / Path(run.store).name))
        s = TrainingSettings(**(run.settings or {}))
        rate = s.unet_learning_rate or chosen_learning_rate(record) or s.learning_rate  # the rate its UNet trained at
        scene = read_scene(run.store)
        # The UNet's key as PaperEstimator makes it (train_cache_key, unet_cache_key), from the run's recorded code;
        # the train split's digest is the slow part, and every model and loss of a seed shares it.
        split = (run.store, run.seed, json.dumps(run.limits, sort_keys=True), s.max_train, s.work_size, run.code)
        if split not in train_keys:
            train = load_run_split(run, "train", scene)
            semantics = np.asarray(train.semantics)[: s.max_train]
            full_size = (semantics.shape[2], semantics.shape[1])
            width, height = s.work_size or full_size
            work_size = (int(width), int(height))
            train_keys[split] = work_size, train_cache_key(run.code.removeprefix("synthcal:"), semantics,
                                                           np.asarray(train.images)[: len(semantics)], full_size,
                                                           work_size)
        work_size, train_key = train_keys[split]
        # Recorded since the UNet may stop early on validation (its key then holds the split); runs from
        # before had none, and their UNets trained every epoch.
        key = (record.get("stage_keys") or {}).get("unet") or unet_cache_key(
            train_key, s.unet_width, s.unet_depth, s.unet_epochs, s.batch_size, rate, run.seed)
        if key in rows:  # another model (or loss) of the same seed, on the same UNet
            rows[key]["models"] = ", ".join(sorted({*rows[key]["models"].split(", "), run.model}))
            continue
        state = cache.load("unet", key)
        if state is None:
            raise FileNotFoundError(f"{cache.path('unet', key)}: no UNet for run {run.id} in its results' cache")
        unet = UNet(num_classes=NUM_CLASSES, width=s.unet_width, depth=s.unet_depth)
        unet.load_state_dict(state)
        unet.to(torch_device).eval()
        test = load_run_split(run, "test", scene)
        confusion = np.zeros((NUM_CLASSES, NUM_CLASSES), np.int64)
        for start in range(0, len(test), batch_size):
            rgb = reduce_images(test.images[start:start + batch_size], work_size)
            with torch.no_grad():
                predicted = unet(rgb.to(torch_device).float().div_(255.0)).argmax(dim=1).cpu().numpy()
            truth = reduce_class_maps(test.semantics[start:start + batch_size], work_size).numpy()
            confusion += confusion_matrix(truth, predicted, NUM_CLASSES)
        rows[key] = {"dataset": Path(run.store).name.removesuffix(".zarr"), "seed": run.seed, "models": run.model,
                     "learning_rate": rate, "unet": key, "n_images": len(test),
                     "work_size": "×".join(map(str, work_size)), **quality_row(confusion, scene.classes)}
    return pd.DataFrame(list(rows.values())).sort_values(["dataset", "seed"], kind="stable", ignore_index=True)
