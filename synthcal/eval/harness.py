"""Sweeps of estimators over datasets and seeds, one folder per run (SPEC §8, §9).

A *run* is (dataset, estimator, training, loss, matching, segmentation, seed,
profile): fit on the seed's train split and dictionary, predict the test images,
score every test image (:func:`synthcal.eval.metrics.evaluate`).

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
(``RESULTS/cache``), ``seed`` (the split seed) and ``progress``.
Under ``segmentation: ground-truth`` the harness calls
``predict_semantic(true test maps)`` instead of ``predict(test images)``.

Results layout
--------------
::

    RESULTS/runs/<run-id>/metrics.csv   one row per test image: test_index, pool_index,
                                        iou, iou_part, iou_whole, failed, failure,
                                        h00 … h22 (the estimate as returned, NaN if none)
    RESULTS/runs/<run-id>/run.json      the resolved run (everything that determines
                                        it, the store's path and config hash) and the
                                        outcome: status ok/failed, error, seconds, the
                                        estimator's ``history`` (per-epoch losses) if any
    RESULTS/cache/<stage>/<key>.pt      shared trained stages (:mod:`.training`)

``run-id`` is ``<dataset>_<model>[_<training>_<loss>_<matching>_<segmentation>]_s<seed>_<hash>``,
the hash over the resolved run (not the device: a run on a GPU and on a CPU is the
same run). Both files are written atomically, ``run.json`` last: a run is finished
when ``run.json`` exists, and a rerun skips it. CSV, not Parquet: pandas needs
the optional pyarrow for Parquet, and the files are small.

Failures
--------
An exception inside the estimator's construction, ``fit`` or ``predict`` records
the run with every test image failed (IoU 0, completeness 0) and the reason
(``fit: ValueError: …``); the sweep goes on. ``KeyboardInterrupt`` and
``SystemExit`` are not caught: the sweep stops, finished runs stay, and the next
invocation resumes with the others. Errors in the data (a missing store or
split) stop the sweep before anything runs.

Dask
----
``run_sweep(..., scheduler=ADDRESS)`` maps the runs over a Dask cluster
(``client.map``); workers must see ``RESULTS`` and the stores at the same paths.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import itertools
import json
import time
import traceback
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from synthcal.config import Loss, Matching, Segmentation, Training
from synthcal.data import load_split, read_scene
from synthcal.estimators import SemanticEstimator, load_estimator, resolve_estimator
from synthcal.eval.metrics import METRICS, evaluate, summarize
from synthcal.store import open_store
from synthcal.store.splits import SplitError, drawn_seeds
from synthcal.utils.atomic import atomic_write
from synthcal.utils.dispatch import dispatch

__all__ = [
    "AXES",
    "Run",
    "dataset_store",
    "estimator_label",
    "expand_runs",
    "execute_run",
    "run_sweep",
    "collect_results",
    "table_runs",
]

# Run fields an estimator may take as constructor keywords (values: synthcal.config).
AXES = ("training", "loss", "matching", "segmentation")
# Run fields that do not change the result, left out of the run's hash.
_NOT_HASHED = ("store",)
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

    @property
    def id(self) -> str:
        """Folder name: readable keys, then a hash of the whole run."""
        record = {k: v for k, v in asdict(self).items() if k not in _NOT_HASHED}
        h = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:10]
        keys = [self.dataset, self.model, *[getattr(self, a) for a in AXES if getattr(self, a)], f"s{self.seed}", h]
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
) -> list[Run]:
    """The sweep grid, with axes collapsed where they do not apply.

    Checks every store and seed first, so that a typo stops the sweep before any
    training.

    Raises:
        SplitError: a missing store, or a seed whose splits are not drawn.
        EstimatorError: an estimator that cannot be resolved.
    """
    values: dict[str, Sequence[str]] = {"training": trainings, "loss": losses, "matching": matchings,
                                        "segmentation": segmentations}
    runs: dict[str, Run] = {}
    for label in datasets:
        store, mixed = dataset_store(data_dir, label)
        if not store.is_dir():
            raise SplitError(f"{store}: no such store (dataset {label!r}); generate it with `synthcal generate`")
        group = open_store(store)
        missing = sorted(set(seeds) - set(drawn_seeds(group)))
        if missing:
            raise SplitError(f"{store}: splits not drawn for seed(s) {missing}; run `synthcal split {store}`")
        for name in estimators:
            cls = resolve_estimator(name)
            params = _parameters(cls)
            applies = {a: (hasattr(cls, "predict_semantic") if a == "segmentation" else a in params) for a in AXES}
            grid: list[Sequence[str | None]] = [values[a] if applies[a] else [None] for a in AXES]
            for seed, combo in itertools.product(seeds, itertools.product(*grid)):
                axes: dict[str, Any] = dict(zip(AXES, combo, strict=True))
                run = Run(dataset=label, store=str(store), mixed=mixed, store_hash=str(group.attrs["config_hash"]),
                          estimator=name, model=estimator_label(name, cls), seed=int(seed), profile=profile,
                          settings=settings if "settings" in params else None, **axes)
                runs.setdefault(run.id, run)
    return list(runs.values())


# --- one run -----------------------------------------------------------------------------


def _write_atomic(path: Path, text: str) -> None:
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def run_folder(results: str | Path, run: Run) -> Path:
    return Path(results) / "runs" / run.id


def is_finished(results: str | Path, run: Run) -> bool:
    return (run_folder(results, run) / "run.json").is_file()


def _options(run: Run, cls: Any, results: Path, device: str, progress: bool) -> dict[str, Any]:
    """Constructor keywords for the run: its axes and the services the class accepts."""
    params = _parameters(cls)
    offered = {a: getattr(run, a) for a in AXES if getattr(run, a) is not None}
    offered.update(settings=run.settings, device=device, cache_dir=str(results / "cache"), seed=run.seed,
                   progress=progress)
    return {k: v for k, v in offered.items() if k in params and v is not None}


def _estimate(run: Run, results: Path, device: str, progress: bool,
              splits: dict[str, Any]) -> tuple[Any, str, dict[str, Any]]:
    """Fit and predict; returns ``(estimates or None, failure reason, timings)``."""
    timings: dict[str, Any] = {}
    stage = "load"
    try:
        cls = resolve_estimator(run.estimator)
        estimator = load_estimator(run.estimator, **_options(run, cls, results, device, progress))
        stage, started = "fit", time.perf_counter()
        train = splits["train"]
        estimator.fit(train, splits["dictionary"], train.scene)
        timings["fit_seconds"] = time.perf_counter() - started
        stage, started = "predict", time.perf_counter()
        test = splits["test"]
        if run.segmentation == "ground-truth":
            if not isinstance(estimator, SemanticEstimator):  # expand_runs gives the axis only to those
                raise TypeError(f"{type(estimator).__name__} has no predict_semantic (segmentation ground-truth)")
            estimates = estimator.predict_semantic(test.semantics)
        else:
            estimates = estimator.predict(test.images)
        timings["predict_seconds"] = time.perf_counter() - started
        history = getattr(estimator, "history", None)
        if isinstance(history, dict):  # per-epoch losses of the bundled models
            timings["history"] = history
        return estimates, "", timings
    except Exception as error:  # an estimator's failure is a result, not a crash (module docstring)
        detail = "".join(traceback.format_exception_only(type(error), error)).strip()
        timings["traceback"] = traceback.format_exc()
        return None, f"{stage}: {detail}", timings


def _estimate_columns(estimates: Any, n: int) -> np.ndarray:
    """(n, 9) the estimates as returned, NaN where they are not a (n, 3, 3) number array."""
    try:
        array = np.asarray(estimates.detach().cpu() if hasattr(estimates, "detach") else estimates, np.float64)
        if array.shape == (n, 3, 3):
            return array.reshape(n, 9)
    except (TypeError, ValueError):
        pass
    return np.full((n, 9), np.nan)


def execute_run(run: Run, results: str | Path, device: str = "auto", progress: bool = False) -> Path:
    """Evaluate one run unless it is finished; returns its folder (module docstring)."""
    results = Path(results)
    folder = run_folder(results, run)
    if is_finished(results, run):
        return folder
    scene = read_scene(run.store)
    splits = {name: load_split(run.store, name, run.seed, run.mixed if name == "dictionary" else False, scene)
              for name in ("train", "test", "dictionary")}
    test = splits["test"]
    estimates, failure, timings = _estimate(run, results, device, progress, splits)
    image_size = (test.images.shape[2], test.images.shape[1])
    frame = evaluate(scene.semantic, estimates, test.homographies, image_size)
    if failure:
        frame["failure"] = failure
    frame.insert(0, "pool_index", np.asarray(test.indices))
    frame.insert(0, "test_index", np.arange(len(frame)))
    frame[_H_COLUMNS] = _estimate_columns(estimates, len(frame))
    folder.mkdir(parents=True, exist_ok=True)
    _write_atomic(folder / "metrics.csv", frame.to_csv(index=False))
    record = {"run": asdict(run), "id": run.id, "status": "failed" if failure else "ok", "error": failure,
              "device": device, **timings, "summary": summarize(frame)}
    _write_atomic(folder / "run.json", json.dumps(record, indent=2, default=str))
    return folder


# --- sweeps ------------------------------------------------------------------------------


def run_sweep(runs: Sequence[Run], results: str | Path, device: str = "auto", scheduler: str | None = None,
              progress: bool = True) -> pd.DataFrame:
    """Execute every unfinished run (locally, or on a Dask cluster); return all results.

    Args:
        runs: from :func:`expand_runs`.
        results: the results folder.
        device: torch device name for estimators that take one.
        scheduler: a Dask scheduler address, or None to run here, one after another.
        progress: progress bars (runs; epochs inside the bundled models).

    Returns:
        :func:`collect_results` of the folder.
    """
    results = Path(results)
    todo = [run for run in runs if not is_finished(results, run)]
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), desc="runs", unit="run", disable=not progress)
    # Here: one run after another, with the estimators' own progress bars; on a cluster: none.
    execute = functools.partial(execute_run, results=str(results), device=device,
                                progress=progress and scheduler is None)
    for folder in dispatch(execute, todo, workers=1, scheduler=scheduler):
        bar.set_postfix_str(folder.name)
        bar.update()
    bar.close()
    return collect_results(results)


def collect_results(results: str | Path, runs: Iterable[Run] | None = None) -> pd.DataFrame:
    """One row per finished run: the table keys, seed, segmentation, profile, metrics.

    Args:
        results: the results folder.
        runs: only these runs (default: every finished run in the folder).

    Returns:
        DataFrame with ``dataset``, ``model``, ``training``, ``loss``,
        ``matching_score``, ``segmentation``, ``profile``, ``seed``, ``iou``,
        ``iou_part``, ``iou_whole`` (means over test images, failures as 0),
        ``completeness``, ``n_images``, ``status``, ``run_id``.
    """
    folder = Path(results) / "runs"
    wanted = None if runs is None else {run.id for run in runs}
    rows = []
    for path in sorted(folder.glob("*/run.json")) if folder.is_dir() else []:
        if wanted is not None and path.parent.name not in wanted:
            continue
        record = json.loads(path.read_text())
        run = record["run"]
        row = {"dataset": run["dataset"], "model": run["model"], "training": run["training"], "loss": run["loss"],
               "matching_score": run["matching"], "segmentation": run["segmentation"], "profile": run["profile"],
               "seed": run["seed"], "estimator": run["estimator"]}
        row.update({k: record["summary"][k] for k in (*METRICS, "completeness", "n_images")})
        row.update(status=record["status"], run_id=record["id"])
        rows.append(row)
    columns = ["dataset", "model", "training", "loss", "matching_score", "segmentation", "profile", "seed",
               "estimator", *METRICS, "completeness", "n_images", "status", "run_id"]
    return pd.DataFrame(rows, columns=columns)


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
