"""Sweeps of estimators over datasets and seeds, one folder per run (SPEC §8, §9).

A *run* is (dataset, estimator, training, loss, matching, segmentation, seed,
profile, the profile's training settings and split sizes, device): fit on the
seed's train split and dictionary, predict the test images, score every test
image (:func:`synthcal.eval.metrics.evaluate`).

Datasets
--------
A dataset label names a store ``<data>/<label>.zarr`` (its own dictionary, or the
mixed one for a dataset without its own, e.g. ``worldcup2014``), or
``mixed-<k>`` / ``mixed-<name>``: target ``intersection-<k>`` / ``<name>`` with
its mixed dictionary (SPEC §6), labelled as in the paper's tables.

Axes
----
An axis applies to an estimator when its constructor takes a keyword of that name
(``training``, ``loss``, ``matching``); ``segmentation`` applies when the
estimator also has ``predict_semantic``. Axes that do not apply collapse: an
``identity`` run is one run per (dataset, seed), its keys recorded as None.
Constructors that take them also get ``settings`` (the profile's
:class:`synthcal.config.TrainingSettings`), ``device``, ``cache_dir``
(``RESULTS/cache``), ``seed`` (the split seed) and ``progress``. ``device`` is
resolved when the runs are expanded (``auto``: ``cuda`` where this process sees
CUDA, else ``cpu``) and recorded only for estimators that take it.

Dictionaries
------------
``Run.dictionary`` is ``split`` (the seed's drawn dictionary: the store's own, or
the mixed one) or ``pool``: every pool sample outside the seed's stored train and
test sets (:func:`synthcal.store.splits.pool_dictionary_indices`), handed to ``fit``
as a lazy :func:`synthcal.data.load_pool_dictionary` and never capped by
``limits``. A mixed dictionary has no pool dictionary: :func:`expand_runs` refuses
one. ``pool`` is in the run's hash and id; ``split`` is left out of the hash, so
runs recorded before the field existed keep their ids. Tables label pool runs
``NAME (pool)``.

Split sizes
-----------
``limits`` (a profile's ``splits:``) caps what a run uses of the seed's stored
splits: the first ``train`` / ``test`` / ``dictionary`` entries of each (the
splits hold ascending pool indices of a pool drawn in random camera order, so a
prefix is a random subset, the same one for every estimator and seed run). A
mixed dictionary is cut round-robin over its sources, so that each source keeps
an equal share. Train and test of a dataset of given poses (``worldcup2014``) are
never cut: they are the poses' own partition. A split smaller than its cap is used
whole. :func:`split_sizes` says what a run will use.
Under ``segmentation: ground-truth`` the harness calls
``predict_semantic(true test maps)`` instead of ``predict(test images)``.

Results layout
--------------
::

    RESULTS/runs/<run-id>/metrics.csv   one row per test image: test_index, pool_index,
                                        iou, iou_bg, iou_weighted, iou_part, iou_whole,
                                        failed, failure, skipped (the truth sees no
                                        field: metrics NaN), h00 … h22 (the estimate
                                        as returned, NaN if none)
    RESULTS/runs/<run-id>/run.json      the resolved run (everything that determines
                                        it, the store's path and config hash) and the
                                        outcome: status ok/failed, error, traceback,
                                        sizes (samples of each split used), device,
                                        seconds (the run's process), fit_seconds,
                                        predict_seconds, the estimator's ``history``
                                        (per-epoch losses) if any, summary
    RESULTS/cache/<stage>/<key>.pt      shared trained stages (:mod:`.training`)

``run-id`` is ``<dataset>_<model>[_<training>_<loss>_<matching>_<segmentation>]_s<seed>_<hash>``,
the hash over the whole resolved run but the store's path (its config hash
stands for its content): every setting that changes the result is in it —
the profile's training settings, the split sizes it caps (``limits``) and the
device. The device is in it because a result depends on it: floating-point
reductions differ between CPU and GPU kernels, so the trained weights differ,
and a run asked of a device that cannot run it (``cuda`` without CUDA) fails;
under the old identity, which left the device out, that failure was reused by a
rerun on the CPU. The time limit, the progress bars and the scheduler are not in
it: they decide whether a run ends, never what an ended run scores.
Both files are written atomically, ``run.json`` last: a run is *finished* when
its ``run.json`` is readable and says ``ok``, and a rerun skips it; a rerun runs
every other one again, failed runs included (a fixed plug-in, a longer
``timeout``, a device that works). CSV, not Parquet: pandas needs the optional
pyarrow for Parquet, and the files are small.

Isolation and failures
----------------------
Each run executes in a process of its own (``python -c … _run_child``, its own
session), which loads the scene and splits, makes every array read-only
(``writeable=False``, views that cannot be made writeable again), constructs the
estimator, fits and predicts, and hands back the estimates as plain JSON data.
Scoring happens here, on the scene and test split this process read itself: an
estimator can change neither its data nor its score.

Whatever the estimator does to its process is a result, not a crash: an
exception in construction, ``fit``, ``predict`` or in reading what ``predict``
returned, a time limit exceeded (``timeout`` seconds, counted from the end of the
process's start-up), an exit, a crash or a kill (e.g. out of memory) records the
run with every test image failed (IoU 0, completeness 0) and the reason, prefixed
by the stage (``load``, ``fit``, ``predict``): ``fit: ValueError: …``,
``predict: timed out after 5 s``, ``predict: killed by signal 11 (SIGSEGV)``,
``fit: exited with status 1``. A run whose estimates are all invalid is failed
too, with the commonest reason (``all 8 estimates invalid: non-finite entries``).
The sweep goes on; a failed run is recorded, and the next sweep
over it runs it again. ``KeyboardInterrupt`` in the sweep's process (Ctrl-C)
kills the running run's process (and what it started) and is raised again from
:func:`run_sweep`: finished runs stay, and the next invocation resumes with the
others. Errors in the data (a missing store or
split) stop the sweep: before anything runs where :func:`expand_runs` can see them,
else at the run that meets them. A damaged ``run.json`` (empty, truncated) is
skipped with a :class:`DamagedRecordWarning` naming it, and its run is done again.

Dask
----
``run_sweep(..., scheduler=ADDRESS)`` maps the runs over a Dask cluster
(``client.map``); workers must see ``RESULTS`` and the stores at the same paths.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from synthcal.config import DICTIONARIES, Dictionary, Loss, Matching, Segmentation, Training
from synthcal.data import SplitDataset, StoreScene, load_pool_dictionary, load_split, read_scene
from synthcal.estimators import SemanticEstimator, load_estimator, resolve_estimator
from synthcal.eval.metrics import METRICS, evaluate, summarize
from synthcal.store import StoreError, attributes, open_store
from synthcal.store.splits import (
    SplitError,
    drawn_seeds,
    pool_dictionary_indices,
    read_mixed_dictionary,
    read_split_indices,
    store_spec,
)
from synthcal.utils.atomic import atomic_write
from synthcal.utils.dispatch import die_with_parent, dispatch

__all__ = [
    "AXES",
    "Run",
    "dataset_store",
    "estimator_label",
    "resolve_device",
    "check_device",
    "expand_runs",
    "split_sizes",
    "plan_lines",
    "prefix_positions",
    "execute_run",
    "DEFAULT_TIMEOUT",
    "DamagedRecordWarning",
    "run_sweep",
    "collect_results",
    "training_budget",
    "table_runs",
]

# Run fields an estimator may take as constructor keywords (values: synthcal.config).
AXES = ("training", "loss", "matching", "segmentation")
# Run fields that do not change the result, left out of the run's hash.
_NOT_HASHED = ("store",)
# Run fields added after the first results were recorded: left out of the hash while None.
_HASHED_WHEN_SET = ("device", "limits")
# Run fields added later with a default: left out of the hash at that default (the runs recorded
# before them were exactly those runs).
_HASHED_UNLESS = {"dictionary": "split"}
_H_COLUMNS = [f"h{r}{c}" for r in range(3) for c in range(3)]


@dataclass(frozen=True)
class Run:
    """One (dataset, estimator, axes, seed, profile) evaluation.

    Attributes:
        dataset: table label (``intersection-1``, ``mixed-4``, ``worldcup2014``).
        store: the target store's path.
        mixed: load the mixed dictionary (None: the store's default).
        store_hash: the store's ``config_hash`` (a regenerated store is a new run).
        estimator: the name or dotted path as given.
        model: table label (the estimator's ``label`` or its name).
        seed: split seed.
        profile: the training profile's name (None: defaults).
        training, loss, matching, segmentation: axes, None where they do not apply.
        settings: the profile's training settings (only for estimators taking them).
        device: torch device name, resolved (``cpu``, ``cuda``; only for estimators
            taking one, else None).
        limits: the most ``train`` / ``test`` / ``dictionary`` samples used of the
            stored splits (module docstring, "Split sizes"); None: all.
        dictionary: ``split`` (the seed's dictionary split, or the mixed one) or
            ``pool`` (every pool sample outside the seed's train and test sets;
            module docstring, "Dictionaries").
    """

    dataset: str
    store: str
    mixed: bool | None
    store_hash: str
    estimator: str
    model: str
    seed: int
    profile: str | None = None
    training: Training | None = None
    loss: Loss | None = None
    matching: Matching | None = None
    segmentation: Segmentation | None = None
    settings: dict[str, Any] | None = field(default=None, hash=False)
    device: str | None = None
    limits: dict[str, int] | None = field(default=None, hash=False)
    dictionary: Dictionary = "split"

    @property
    def id(self) -> str:
        """Folder name: readable keys, then a hash of the whole run."""
        # Fields added later hash only when set, so that the runs they do not concern keep their ids.
        record = {k: v for k, v in asdict(self).items()
                  if k not in _NOT_HASHED and not (k in _HASHED_WHEN_SET and v is None)
                  and not (k in _HASHED_UNLESS and v == _HASHED_UNLESS[k])}
        h = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:10]
        pool = ["pool"] if self.dictionary == "pool" else []
        keys = [self.dataset, self.model, *[getattr(self, a) for a in AXES if getattr(self, a)], *pool,
                f"s{self.seed}", h]
        return "_".join(k.replace("/", "-").replace(":", "-") for k in keys)


def dataset_store(data_dir: str | Path, label: str) -> tuple[Path, bool | None]:
    """``(store, mixed)`` of a dataset label (module docstring)."""
    data_dir = Path(data_dir)
    if label.startswith("mixed-"):
        target = label.removeprefix("mixed-")
        if target.isdigit():
            target = f"intersection-{target}"
        return data_dir / f"{target}.zarr", True
    return data_dir / f"{label}.zarr", None


def _parameters(cls: Any) -> set[str]:
    """Keyword names the estimator's constructor takes (none if it cannot be inspected)."""
    try:
        return set(inspect.signature(cls).parameters)
    except (TypeError, ValueError):
        return set()


def estimator_label(name: str, cls: Any) -> str:
    """Table label: the class's ``label``, else the short name, else the class name."""
    label = getattr(cls, "label", None)
    if isinstance(label, str):
        return label
    return name.rpartition(":")[2].rpartition(".")[2] if ":" in name else name


def resolve_device(name: str) -> str:
    """The device a run gets: ``auto`` → ``cuda`` where this process sees CUDA, else ``cpu``; others as given."""
    if name != "auto":
        return name
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


def check_device(name: str) -> None:
    """Refuse a device name torch does not know, or CUDA where there is none.

    Raises:
        ValueError: naming the device and why.
    """
    import torch

    try:
        device = torch.device(resolve_device(name))
    except RuntimeError as error:
        raise ValueError(f"--device: not a torch device: {error} (value {name!r})") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"--device: CUDA is not available on this machine (value {name!r}); "
                         f"use --device cpu or auto")


def _store_limits(store: Path, group: Any, limits: dict[str, int] | None) -> dict[str, int] | None:
    """The caps that apply to a store: all of them, but not train/test of a dataset of given poses."""
    if not limits:
        return None
    if store_spec(group, store).poses is not None:
        limits = {k: v for k, v in limits.items() if k not in ("train", "test")}
    return dict(sorted(limits.items())) or None


def expand_runs(
    data_dir: str | Path,
    datasets: Sequence[str],
    estimators: Sequence[str],
    seeds: Sequence[int],
    profile: str | None = None,
    settings: dict[str, Any] | None = None,
    trainings: Sequence[Training] = ("step-by-step",),
    losses: Sequence[Loss] = ("top-mse",),
    matchings: Sequence[Matching] = ("top-mse",),
    segmentations: Sequence[Segmentation] = ("unet",),
    device: str = "auto",
    limits: dict[str, int] | None = None,
    dictionary: Dictionary | dict[str, Dictionary] = "split",
) -> list[Run]:
    """The sweep grid, with axes collapsed where they do not apply.

    Checks every store and seed first, so that a typo stops the sweep before any
    training.

    Args:
        device: torch device name (``auto`` resolved here, :func:`resolve_device`).
        limits: a profile's split sizes, capping the stored splits (module
            docstring, "Split sizes"); None: the splits as stored.
        dictionary: ``split`` or ``pool`` for every dataset, or per dataset label
            (labels not in the dict: ``split``); module docstring, "Dictionaries".
        others: the sweep's values (module docstring).

    Raises:
        SplitError: a missing store, a seed whose splits are not drawn, or the pool
            dictionary asked of a dataset with a mixed dictionary.
        EstimatorError: an estimator that cannot be resolved.
    """
    values: dict[str, Sequence[str]] = {"training": trainings, "loss": losses, "matching": matchings,
                                        "segmentation": segmentations}
    shared: dict[str, Any] = {"seeds": seeds, "profile": profile, "settings": settings,
                              "device": resolve_device(device)}
    runs: dict[str, Run] = {}
    for label in datasets:
        store, mixed = dataset_store(data_dir, label)
        if not store.is_dir():
            raise SplitError(f"{store}: no such store (dataset {label!r}); generate it with `synthcal generate`")
        group = open_store(store)
        missing = sorted(set(seeds) - set(drawn_seeds(group)))
        if missing:
            raise SplitError(f"{store}: splits not drawn for seed(s) {', '.join(map(str, missing))}; run "
                             f"`synthcal split {store} --seeds {','.join(map(str, missing))}`")
        base = {"dataset": label, "store": str(store), "mixed": mixed, "store_hash": str(group.attrs["config_hash"]),
                "limits": _store_limits(store, group, limits),
                "dictionary": _dataset_dictionary(label, store, mixed, dictionary)}
        for name in estimators:
            for run in _estimator_runs(name, base, values, **shared):
                runs.setdefault(run.id, run)
    return list(runs.values())


def _dataset_dictionary(label: str, store: Path, mixed: bool | None,
                        dictionary: Dictionary | dict[str, Dictionary]) -> Dictionary:
    """The dictionary a dataset label's runs search; refuses ``pool`` where the dictionary is mixed.

    Raises:
        SplitError: ``pool`` for a ``mixed-*`` label or a dataset without an own pool dictionary.
    """
    value = dictionary.get(label, "split") if isinstance(dictionary, dict) else dictionary
    if value not in DICTIONARIES:
        raise SplitError(f"--dictionary: unknown dictionary {value!r} (dataset {label!r}); "
                         f"one of {', '.join(DICTIONARIES)}")
    if value == "pool" and (mixed or not store_spec(open_store(store), store).own_dictionary):
        raise SplitError(f"{store}: dictionary pool: dataset {label!r} uses a mixed dictionary (templates from "
                         f"other datasets' pools); the pool dictionary is a store's own pool outside the seed's "
                         f"train and test sets: bench {label!r} with --dictionary split, or the target's own "
                         f"label with --dictionary pool")
    return value


def _estimator_runs(name: str, base: dict[str, Any], values: dict[str, Sequence[str]], seeds: Sequence[int],
                    profile: str | None, settings: dict[str, Any] | None, device: str) -> list[Run]:
    """One estimator's runs on one dataset: its applicable axes × seeds."""
    cls = resolve_estimator(name)
    params = _parameters(cls)
    applies = {a: (hasattr(cls, "predict_semantic") if a == "segmentation" else a in params) for a in AXES}
    grid: list[Sequence[str | None]] = [values[a] if applies[a] else [None] for a in AXES]
    runs = []
    for seed, combo in itertools.product(seeds, itertools.product(*grid)):
        axes: dict[str, Any] = dict(zip(AXES, combo, strict=True))
        runs.append(Run(**base, estimator=name, model=estimator_label(name, cls), seed=int(seed), profile=profile,
                        settings=settings if "settings" in params else None,
                        device=device if "device" in params else None, **axes))
    return runs


def prefix_positions(n: int, cap: int | None, source: np.ndarray | None = None) -> np.ndarray:
    """Positions kept of a split of ``n`` entries under a cap (module docstring, "Split sizes").

    Args:
        n: the split's length.
        cap: the most entries kept (None: all).
        source: a mixed dictionary's (n,) source of each entry: kept round-robin
            over the sources, first entries of each first.

    Returns:
        Ascending positions, ``min(n, cap)`` of them.

    >>> prefix_positions(5, 3).tolist()
    [0, 1, 2]
    >>> prefix_positions(6, 3, np.array([0, 0, 0, 1, 1, 1])).tolist()
    [0, 1, 3]
    """
    if cap is None or cap >= n:
        return np.arange(n)
    if source is None:
        return np.arange(cap)
    source = np.asarray(source)
    rank = np.empty(n, np.int64)
    for value in np.unique(source):
        where = np.flatnonzero(source == value)
        rank[where] = np.arange(len(where))
    order = np.lexsort((source, rank))  # by rank within its source, then by source
    return np.sort(order[:cap])


def _mixed_dictionary(run: Run) -> bool:
    """Whether the run's dictionary is a mixed one (as :func:`synthcal.data.load_split` decides)."""
    if run.mixed is not None:
        return run.mixed
    return not store_spec(open_store(run.store), Path(run.store)).own_dictionary


def split_sizes(run: Run) -> dict[str, tuple[int, int]]:
    """What the run uses of each split: ``{split: (used, stored)}``, from the indices alone.

    Raises:
        SplitError: a split or mixed dictionary that is not drawn.
    """
    sizes: dict[str, tuple[int, int]] = {}
    for split in ("train", "test", "dictionary"):
        if split == "dictionary" and run.dictionary == "pool":  # never capped: the whole pool is the point
            stored = len(pool_dictionary_indices(run.store, run.seed))
            sizes[split] = (stored, stored)
            continue
        if split == "dictionary" and _mixed_dictionary(run):
            stored = len(read_mixed_dictionary(run.store, run.seed).index)
        else:
            stored = len(read_split_indices(run.store, split, run.seed))
        cap = (run.limits or {}).get(split)
        sizes[split] = (stored if cap is None else min(cap, stored), stored)
    return sizes


def _span(values: Iterable[int]) -> str:
    """``128`` or ``120–128`` (several seeds with different sizes)."""
    values = sorted(set(values))
    return f"{values[0]:,}" if len(values) == 1 else f"{values[0]:,}–{values[-1]:,}"


def plan_lines(runs: Sequence[Run]) -> list[str]:
    """What a sweep will train and test on, for the console before it starts.

    One line per dataset (the samples of each split used, of those stored, over
    the runs' seeds; what the bundled models train on under ``max_train``), then
    one per training kind of the bundled models (:func:`training_budget`).

    Raises:
        SplitError: a split that is not drawn.
    """
    datasets: dict[str, dict[int, dict[str, tuple[int, int]]]] = {}
    for run in runs:
        seeds = datasets.setdefault(_table_label(asdict(run)), {})
        if run.seed not in seeds:
            seeds[run.seed] = split_sizes(run)
    settings = next((run.settings for run in runs if run.settings), None)
    cap = (settings or {}).get("max_train")
    lines = []
    for dataset, seeds in datasets.items():
        parts = [f"{split} {_span(s[split][0] for s in seeds.values())} "
                 f"of {_span(s[split][1] for s in seeds.values())}" for split in ("train", "test", "dictionary")]
        line = f"  {dataset} (seeds {', '.join(map(str, seeds))}): {', '.join(parts)}"
        if settings is not None:
            used = (min(s["train"][0], cap) if cap else s["train"][0] for s in seeds.values())
            line += f"; the bundled models train on {_span(used)}" + (f" (max_train {cap:,})" if cap else "")
        lines.append(line)
    kinds = dict.fromkeys((run.training, run.segmentation) for run in runs if run.settings is not None)
    for training, segmentation in kinds:
        budget = training_budget({"run": {"training": training, "segmentation": segmentation, "settings": settings}})
        if budget:
            batch = (settings or {}).get("batch_size")
            lines.append(f"  training ({segmentation or 'no'} segmentation): {budget}; batch {batch}")
    return lines


# --- one run -----------------------------------------------------------------------------


# Per-run time limit of ``synthcal bench --timeout`` (seconds): generous, it only
# catches an estimator that hangs; the paper-size runs take minutes to an hour.
DEFAULT_TIMEOUT = 6 * 3600.0
# A run's process must reach its first stage within this much more than the limit
# (its start-up, imports of torch and synthcal, is not counted in the limit itself).
_STARTUP_SECONDS = 300.0
# How often the parent looks at a run's process: the latency of a time limit.
_POLL_SECONDS = 0.05
# Stands for an estimate numpy cannot read as numbers: metrics judges it "not numeric".
_NOT_NUMERIC = "not numeric"


class DamagedRecordWarning(UserWarning):
    """A ``run.json`` that cannot be read (empty, truncated, not a run record): skipped."""


def _write_atomic(path: Path, text: str) -> None:
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def run_folder(results: str | Path, run: Run) -> Path:
    return Path(results) / "runs" / run.id


def read_record(path: Path, consequence: str = "skipped") -> dict[str, Any] | None:
    """A run record, or None with a :class:`DamagedRecordWarning` naming the file.

    Args:
        path: ``RESULTS/runs/<run-id>/run.json``.
        consequence: what happens to a damaged one, for the warning's text.
    """
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        if not (isinstance(record, dict) and isinstance(record.get("run"), dict)
                and isinstance(record.get("summary"), dict) and {"status", "id"} <= record.keys()):
            raise ValueError("not a run record")
    except (OSError, UnicodeDecodeError, ValueError) as error:  # JSONDecodeError is a ValueError
        warnings.warn(f"{path}: damaged run record {consequence} ({type(error).__name__}: {error})",
                      DamagedRecordWarning, stacklevel=2)
        return None
    return record


def is_finished(results: str | Path, run: Run) -> bool:
    """Whether the run has a readable ``run.json`` that says ``ok``.

    A failed run is not finished: the next sweep runs it again. A damaged record
    is run again too, with a :class:`DamagedRecordWarning`.
    """
    path = run_folder(results, run) / "run.json"
    if not path.is_file():
        return False
    record = read_record(path, "ignored; the run is done again")
    return record is not None and record["status"] == "ok"


def _options(run: Run, cls: Any, results: Path, progress: bool) -> dict[str, Any]:
    """Constructor keywords for the run: its axes and the services the class accepts."""
    params = _parameters(cls)
    offered = {a: getattr(run, a) for a in AXES if getattr(run, a) is not None}
    offered.update(settings=run.settings, device=run.device, cache_dir=str(results / "cache"), seed=run.seed,
                   progress=progress)
    return {k: v for k, v in offered.items() if k in params and v is not None}


# --- inside a run's own process ----------------------------------------------------------


def _read_only(array: np.ndarray) -> np.ndarray:
    """A read-only view of a read-only array: ``setflags(write=True)`` on it raises too."""
    base = np.asarray(array)
    base.flags.writeable = False
    view = base.view()
    view.flags.writeable = False
    return view


def _read_only_scene(scene: StoreScene) -> StoreScene:
    arrays: dict[str, Any] = {f.name: _read_only(getattr(scene, f.name)) for f in dataclasses.fields(scene)
              if isinstance(getattr(scene, f.name), np.ndarray)}
    return dataclasses.replace(scene, **arrays)


def _read_only_split(split: SplitDataset, scene: StoreScene) -> SplitDataset:
    for name, value in vars(split).items():
        if isinstance(value, np.ndarray):
            setattr(split, name, _read_only(value))
    split.scene = scene
    return split


def _load_split(run: Run, split: str, scene: StoreScene) -> SplitDataset:
    """One split of the run as it uses it: capped by ``run.limits`` (:func:`prefix_positions`).

    Raises:
        StoreError: the store or split cannot be read.
    """
    if split == "dictionary" and run.dictionary == "pool":  # lazy, and never capped
        return load_pool_dictionary(run.store, run.seed, scene)
    data = load_split(run.store, split, run.seed, run.mixed if split == "dictionary" else False, scene)
    keep = prefix_positions(len(data), (run.limits or {}).get(split), data.source)
    if len(keep) == len(data):
        return data
    arrays = {"image": data.images[keep], "semantic": data.semantics[keep], "homography": data.homographies[keep]}
    return SplitDataset(arrays, np.asarray(data.indices)[keep], data.store, data.split, data.seed, data.scene,
                        data.sources, None if data.source is None else data.source[keep], data.source_stores)


def _plain_estimates(estimates: Any, n: int) -> Any:
    """What ``predict`` returned as JSON-ready data that metrics judges as it would the original.

    A number array becomes nested lists (any shape: a wrong one is judged by
    metrics); a length-``n`` list or tuple that numpy cannot stack is converted item
    by item (None stays, an item that is not numbers becomes :data:`_NOT_NUMERIC`);
    anything else numpy cannot read becomes :data:`_NOT_NUMERIC` (a wrong batch).

    Raises:
        whatever the conversion raises besides TypeError/ValueError (an ``__array__``
        that fails): the run fails, as metrics would have crashed on it.
    """
    if estimates is None:
        return None
    if hasattr(estimates, "detach"):  # a torch tensor, possibly on a GPU
        estimates = estimates.detach().cpu().numpy()
    try:
        return np.array(estimates, dtype=np.float64).tolist()
    except (TypeError, ValueError):  # ragged or mixed with None: judged item by item
        pass
    if isinstance(estimates, (list, tuple)) and len(estimates) == n:
        items = []
        for item in estimates:
            try:
                items.append(None if item is None else np.array(item, dtype=np.float64).tolist())
            except (TypeError, ValueError):
                items.append(_NOT_NUMERIC)
        return items
    return _NOT_NUMERIC


def _estimate(run: Run, results: Path, progress: bool, stage: Callable[[str], None]) -> dict[str, Any]:
    """Load the run's data read-only, fit and predict; the outcome as JSON-ready data.

    Returns:
        dict with ``estimates`` (:func:`_plain_estimates`, None on failure), ``error``
        (``""`` or ``"<stage>: <exception>"``), ``data_error`` (a store or split that
        cannot be read: the sweep stops), ``sizes`` (samples of each split used),
        ``fit_seconds``, ``predict_seconds``, ``history``, ``traceback`` where they apply.
    """
    outcome: dict[str, Any] = {"estimates": None, "error": ""}
    name = "load"
    stage(name)
    try:
        scene = _read_only_scene(read_scene(run.store))
        splits = {split: _read_only_split(_load_split(run, split, scene), scene)
                  for split in ("train", "test", "dictionary")}
        outcome["sizes"] = {split: len(data) for split, data in splits.items()}
    except StoreError as error:  # the data, not the estimator: stops the sweep (module docstring)
        outcome["data_error"] = str(error)
        return outcome
    try:
        cls = resolve_estimator(run.estimator)
        estimator = load_estimator(run.estimator, **_options(run, cls, results, progress))
        name, started = "fit", time.perf_counter()
        stage(name)
        train = splits["train"]
        estimator.fit(train, splits["dictionary"], scene)
        outcome["fit_seconds"] = time.perf_counter() - started
        name, started = "predict", time.perf_counter()
        stage(name)
        test = splits["test"]
        if run.segmentation == "ground-truth":
            if not isinstance(estimator, SemanticEstimator):  # expand_runs gives the axis only to those
                raise TypeError(f"{type(estimator).__name__} has no predict_semantic (segmentation ground-truth)")
            estimates = estimator.predict_semantic(test.semantics)
        else:
            estimates = estimator.predict(test.images)
        outcome["predict_seconds"] = time.perf_counter() - started
        name = "predict: result not readable"
        outcome["estimates"] = _plain_estimates(estimates, len(test.indices))
        history = getattr(estimator, "history", None)
        if isinstance(history, dict):  # per-epoch losses of the bundled models
            outcome["history"] = json.loads(json.dumps(history, default=float))
    except Exception as error:  # an estimator's failure is a result, not a crash (module docstring)
        detail = "".join(traceback.format_exception_only(type(error), error)).strip()
        outcome.update(estimates=None, error=f"{name}: {detail}", traceback=traceback.format_exc())
    return outcome


def _run_child(exchange: str) -> None:
    """Entry point of a run's own process: ``request.json`` in, ``stage``, ``result.json`` out."""
    import faulthandler

    folder = Path(exchange)
    request = json.loads((folder / "request.json").read_text(encoding="utf-8"))
    die_with_parent(request["parent"])  # a kill -9 of the sweep leaves no run behind
    faulthandler.enable(all_threads=False)  # a crash prints the plug-in's Python stack to stderr
    # The read-only arrays reach torch.from_numpy in SplitDataset.__getitem__, which
    # warns that writing through the tensor is undefined; nothing here writes.
    warnings.filterwarnings("ignore", message="The given NumPy array is not writable")
    sys.path[:0] = [entry for entry in request["sys_path"] if entry not in sys.path]  # the parent's plug-ins

    def stage(name: str) -> None:
        (folder / "stage").write_text(name, encoding="utf-8")

    run = Run(**request["run"])
    outcome = _estimate(run, Path(request["results"]), request["progress"], stage)
    _write_atomic(folder / "result.json", json.dumps(outcome))
    # Skip the interpreter's teardown: threads or atexit hooks a plug-in left behind
    # must not hang or crash a run whose result is already written.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


# --- in the sweep's process --------------------------------------------------------------


def _kill(process: subprocess.Popen[bytes]) -> None:
    """SIGKILL the run's process and everything it started (its own session)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    process.wait()


def _wait(process: subprocess.Popen[bytes], stage: Path, timeout: float | None) -> int | None:
    """The exit status, or None when the run's process exceeded its time limit (then killed).

    The limit counts from the first stage the process reports, so that its start-up
    (a second or two of imports) is not charged to the estimator.
    """
    launched = time.monotonic()
    deadline = None
    while True:
        try:
            return process.wait(timeout=_POLL_SECONDS)
        except subprocess.TimeoutExpired:
            pass
        if not timeout:
            continue
        now = time.monotonic()
        if deadline is None and stage.exists():
            deadline = now + timeout
        if now > (deadline if deadline is not None else launched + _STARTUP_SECONDS + timeout):
            _kill(process)
            return None


def _signal_name(number: int) -> str:
    """``SIGSEGV`` for 11; real-time signals have no name of their own."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return "unnamed"


def _estimate_isolated(run: Run, results: Path, progress: bool, timeout: float | None) -> dict[str, Any]:
    """:func:`_estimate` in a process of its own, under the time limit (module docstring)."""
    # Beside the results, not in /tmp: a temp-folder cleaner cannot pull it from under a
    # running child, and a folder left by a kill -9 stays where the user looks.
    exchange = Path(tempfile.mkdtemp(prefix=".exchange-", dir=results))
    try:
        request = {"run": asdict(run), "results": str(results), "progress": progress, "sys_path": sys.path,
                   "parent": os.getpid()}
        (exchange / "request.json").write_text(json.dumps(request), encoding="utf-8")
        command = [sys.executable, "-c",
                   "import sys; from synthcal.eval.harness import _run_child; _run_child(sys.argv[1])",
                   str(exchange)]
        started = time.monotonic()
        # Its own session: a kill reaches the processes it starts (data loaders), and a
        # Ctrl-C at the terminal reaches only the sweep, which then kills it (finally).
        process = subprocess.Popen(command, stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            status = _wait(process, exchange / "stage", timeout)
        finally:
            if process.poll() is None:
                _kill(process)
        seconds = time.monotonic() - started
        stage = (exchange / "stage").read_text(encoding="utf-8") if (exchange / "stage").exists() else "start"
        try:
            outcome: dict[str, Any] = json.loads((exchange / "result.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):  # no result: the process ended before reporting one
            if status is None:
                why = f"timed out after {timeout:g} s"
            elif status < 0:
                why = f"killed by signal {-status} ({_signal_name(-status)})"
            else:
                why = f"exited with status {status}" + (" before reporting its estimates" if status == 0 else "")
            outcome = {"estimates": None, "error": f"{stage}: {why}"}
        outcome["seconds"] = seconds
        return outcome
    finally:
        shutil.rmtree(exchange, ignore_errors=True)


def with_device(run: Run, device: str | None) -> Run:
    """The run on another device (a different run: its id changes); unchanged for None or
    an estimator that takes no device."""
    if device is None or run.device is None:
        return run
    return dataclasses.replace(run, device=resolve_device(device))


def execute_run(run: Run, results: str | Path, device: str | None = None, progress: bool = False,
                timeout: float | None = DEFAULT_TIMEOUT) -> Path:
    """Evaluate one run unless it is finished (ok); returns its folder (module docstring).

    Args:
        run: from :func:`expand_runs`.
        results: the results folder.
        device: replaces the run's device (:func:`with_device`); None: the run's own.
        progress: the estimator's own progress bars.
        timeout: seconds the run's process may take (start-up not counted); None or 0: no limit.

    Raises:
        StoreError: the run's store or splits cannot be read.
        OSError: the results cannot be written (names the file).
    """
    results = Path(results)
    run = with_device(run, device)
    folder = run_folder(results, run)
    if is_finished(results, run):
        return folder
    # Scoring reads its own copy of the scene and the test split, loaded here: the
    # estimator, in its own process, cannot reach it.
    scene = read_scene(run.store)
    test = _load_split(run, "test", scene)
    outcome = _estimate_isolated(run, results, progress, timeout)
    if "data_error" in outcome:
        raise StoreError(outcome["data_error"])
    estimates, failure = outcome.pop("estimates"), outcome.pop("error")
    image_size = (test.images.shape[2], test.images.shape[1])
    frame = evaluate(scene.semantic, estimates, test.homographies, image_size, field=_scene_field(run.store),
                     indices=np.asarray(test.indices), source=str(run.store))
    scored = frame[~frame["skipped"]]
    if failure:
        frame["failure"] = failure
    elif len(scored) and scored["failed"].all():  # nothing usable came back: a failed run, with the commonest why
        failure = f"all {len(scored)} estimates invalid: {scored['failure'].value_counts().index[0]}"
    frame.insert(0, "pool_index", np.asarray(test.indices))
    frame.insert(0, "test_index", np.arange(len(frame)))
    frame[_H_COLUMNS] = _estimate_columns(estimates, len(frame))
    folder.mkdir(parents=True, exist_ok=True)
    _write_atomic(folder / "metrics.csv", frame.to_csv(index=False))
    record = {"run": asdict(run), "id": run.id, "status": "failed" if failure else "ok", "error": failure,
              "device": run.device, **outcome, "summary": summarize(frame)}
    _write_atomic(folder / "run.json", json.dumps(record, indent=2, default=str))
    return folder


def _scene_field(store: str | Path) -> np.ndarray | None:
    """The scene's field polygon from the store's attributes (None, the whole scene, for stores without one)."""
    field = attributes(open_store(store))["scene"].get("field")
    return None if field is None else np.asarray(field, np.float64)


def _estimate_columns(estimates: Any, n: int) -> np.ndarray:
    """(n, 9) the estimates as returned, NaN where they are not a (n, 3, 3) number array."""
    try:
        array = np.asarray(estimates, np.float64)
        if array.shape == (n, 3, 3):
            return array.reshape(n, 9)
    except (TypeError, ValueError):
        pass
    return np.full((n, 9), np.nan)


# --- sweeps ------------------------------------------------------------------------------


def run_sweep(runs: Sequence[Run], results: str | Path, device: str | None = None, scheduler: str | None = None,
              progress: bool = True, timeout: float | None = DEFAULT_TIMEOUT) -> pd.DataFrame:
    """Execute every run not finished ok (locally, or on a Dask cluster); return all results.

    Args:
        runs: from :func:`expand_runs`.
        results: the results folder.
        device: replaces the runs' device (:func:`with_device`: other runs, other
            ids); None: each run's own.
        scheduler: a Dask scheduler address, or None to run here, one after another.
        progress: progress bars (runs; epochs inside the bundled models).
        timeout: seconds each run's process may take; None or 0: no limit.

    Returns:
        :func:`collect_results` of the folder.

    Raises:
        KeyboardInterrupt: Ctrl-C; the running run's process is killed first, the
            finished runs stay and a rerun resumes with the others.
    """
    results = Path(results)
    runs = [with_device(run, device) for run in runs]
    # Now, not after the first run: a results folder that cannot be written stops the sweep at once.
    (results / "runs").mkdir(parents=True, exist_ok=True)
    todo = [run for run in runs if not is_finished(results, run)]
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), desc="runs", unit="run", disable=not progress)
    # Here: one run after another, with the estimators' own progress bars; on a cluster: none.
    execute = functools.partial(execute_run, results=str(results), progress=progress and scheduler is None,
                                timeout=timeout)
    try:
        for folder in dispatch(execute, todo, workers=1, scheduler=scheduler):
            bar.set_postfix_str(folder.name)
            bar.update()
    finally:  # on Ctrl-C too: the bar's line ends before whatever is printed next
        bar.close()
    return collect_results(results)


def collect_results(results: str | Path, runs: Iterable[Run] | None = None) -> pd.DataFrame:
    """One row per finished run: the table keys, seed, segmentation, profile, metrics.

    Args:
        results: the results folder.
        runs: only these runs (default: every finished run in the folder).

    Returns:
        DataFrame with ``dataset``, ``model``, ``training``, ``loss``,
        ``matching_score``, ``segmentation``, ``profile``, ``seed``, the
        metrics ``iou``, ``iou_bg``, ``iou_weighted``, ``iou_part``, ``iou_whole``
        (means over scored test images, failures as 0; NaN for a metric the run's
        record predates), ``completeness``, ``n_images``, ``n_skipped``, ``status``, ``error`` (``""`` for a run
        that is ok), ``run_id``, ``device``, ``budget`` (:func:`training_budget`;
        None for estimators that do not train) and ``dictionary`` (``split``, or ``pool``:
        then ``dataset`` reads ``NAME (pool)``). A damaged ``run.json`` is skipped with a
        :class:`DamagedRecordWarning` naming it.
    """
    folder = Path(results) / "runs"
    wanted = None if runs is None else {run.id for run in runs}
    rows = []
    for path in sorted(folder.glob("*/run.json")) if folder.is_dir() else []:
        if wanted is not None and path.parent.name not in wanted:
            continue
        record = read_record(path)
        if record is None:
            continue
        run = record["run"]
        try:
            row = {"dataset": _table_label(run), "model": run["model"], "training": run["training"], "loss": run["loss"],
                   "matching_score": run["matching"], "segmentation": run["segmentation"],
                   "profile": run["profile"], "seed": run["seed"], "estimator": run["estimator"]}
            summary = record["summary"]
            row.update({k: summary[k] for k in ("iou", "completeness", "n_images")})
            # Runs recorded before a metric existed show it as missing (NaN), not as 0.
            row.update({k: summary.get(k, np.nan) for k in (*METRICS, "n_skipped")})
        except KeyError as error:
            warnings.warn(f"{path}: damaged run record skipped (no {error})", DamagedRecordWarning, stacklevel=2)
            continue
        row.update(status=record["status"], error=record.get("error") or "", run_id=record["id"],
                   device=run.get("device"), budget=training_budget(record), dictionary=run.get("dictionary", "split"))
        rows.append(row)
    columns = ["dataset", "model", "training", "loss", "matching_score", "segmentation", "profile", "seed",
               "estimator", *METRICS, "completeness", "n_images", "n_skipped", "status", "error", "run_id",
               "device", "budget", "dictionary"]
    return pd.DataFrame(rows, columns=columns)


def _table_label(run: dict[str, Any]) -> str:
    """A run's dataset label in tables: ``NAME (pool)`` for a pool-dictionary run, so that it
    sits in a row of its own beside the same dataset's split-dictionary runs."""
    return f"{run['dataset']} (pool)" if run.get("dictionary") == "pool" else str(run["dataset"])


def training_budget(record: dict[str, Any]) -> str | None:
    """What a run of a bundled model was trained with, in words (None: no training settings).

    From the record's resolved settings: the epochs of the stages its training
    trains (the UNet's only under ``segmentation: unet``), the train images used
    (``max_train`` of the split's size, where the record has it), the working
    resolution and, where the settings carry them, ``stn_template`` and
    ``class_reduction``.

    >>> training_budget({"run": {"training": "end-to-end", "segmentation": "unet",
    ...                          "settings": {"end_to_end_epochs": 24, "work_size": [128, 72]}}})
    'end-to-end 24 epochs; at 128 × 72'
    """
    run = record.get("run", {})
    settings = run.get("settings")
    if not isinstance(settings, dict) or run.get("training") is None:
        return None
    if run["training"] == "end-to-end":
        parts = [f"end-to-end {settings.get('end_to_end_epochs')} epochs"]
    else:
        stages = ([("UNet", "unet_epochs")] if run.get("segmentation") == "unet" else []) + \
                 [("Siamese", "siamese_epochs"), ("STN", "stn_epochs")]
        parts = ["step-by-step " + ", ".join(f"{name} {settings.get(key)}" for name, key in stages) + " epochs"]
    train = (record.get("sizes") or {}).get("train")
    cap = settings.get("max_train")
    if train is not None:
        parts.append(f"{min(train, cap) if cap else train} train images")
    if settings.get("work_size"):
        width, height = settings["work_size"]
        parts.append(f"at {width} × {height}")
    parts += [f"{key.replace('_', ' ')} {settings[key]}" for key in ("stn_template", "class_reduction")
              if settings.get(key) is not None]
    return "; ".join(parts)


def table_runs(frame: pd.DataFrame, keys: Sequence[str] = ("training", "loss", "matching_score")) -> pd.DataFrame:
    """Runs for the tables: an estimator a key does not apply to is shown in every row of it.

    ``identity`` has no loss; beside models trained with ``top-mse`` and ``mse`` its
    row would stand apart with "–". Here each run whose key is missing is repeated
    for every value that key takes among the other runs of its dataset, so the
    reference estimators sit beside each trained configuration. Keys missing in
    every run stay missing.
    """
    out = frame.copy()
    for key in keys:
        pieces = []
        for _, group in out.groupby("dataset", sort=False):
            present = group[key].dropna().unique()
            missing = group[key].isna()
            if len(present) == 0 or not missing.any():
                pieces.append(group)
                continue
            pieces.append(group[~missing])
            for value in present:
                pieces.append(group[missing].assign(**{key: value}))
        out = pd.concat(pieces, ignore_index=True) if pieces else out
    return out
