"""Sweeps of estimators over datasets and seeds, one folder per run (SPEC §8, §9).

A *run* is (dataset, estimator, training, loss, matching, segmentation, seed,
profile, the profile's training settings and split sizes, device): fit on the
seed's train split and dictionary, predict the test images, score every test
image (:func:`synthcal.eval.scoring.evaluate`).

The harness is three modules, each importing only the ones before it:

* :mod:`synthcal.eval.runs` — what a run is and which runs a sweep has: datasets,
  axes, dictionaries, split sizes, run ids (:func:`expand_runs`, :func:`plan_lines`);
* :mod:`synthcal.eval.isolation` — one run's estimator in a process of its own, on
  read-only data, under a time limit, its failures returned as results;
* this module — executing runs and sweeps (scoring, writing the results) and
  reading the results back (:func:`collect_results`, :func:`table_runs`). It
  re-exports the public names of the other two.

Results layout
--------------
::

    RESULTS/runs/<run-id>/metrics.csv   one row per test image: test_index, pool_index,
                                        iou, iou_bg, iou_weighted, iou_part, iou_whole,
                                        reproj_px, acc@5, acc@10, acc@20, corner_error
                                        (inf: a failure), failed, failure, skipped (the truth sees no
                                        field: metrics NaN), h00 … h22 (the estimate
                                        as returned, NaN if none)
    RESULTS/runs/<run-id>/run.json      the resolved run (everything that determines
                                        it, the store's path and config hash) and the
                                        outcome: status ok/failed, error, traceback,
                                        sizes (samples of each split used), device,
                                        seconds (the run's process), fit_seconds,
                                        predict_seconds, the estimator's ``history``
                                        (per-epoch losses), ``selection`` (what
                                        validation chose) and ``stage_keys`` (cache
                                        keys of its shared stages) if any, ``machine``
                                        (the processor, PyTorch's CPU instruction set
                                        and threads, library versions: what decides a
                                        trained model's last bits), summary
    RESULTS/cache/<stage>/<key>.pt      shared trained stages (:mod:`.training`)

``run-id`` is :attr:`Run.id` (:mod:`synthcal.eval.runs`, "Run ids"): readable
keys, then a hash of every setting that changes the result, and of the
estimator's code (an edited plug-in is a new run).
Both files are written atomically, ``run.json`` last: a run is *finished* when
its ``run.json`` is readable and says ``ok``, and a rerun skips it; a rerun runs
every other one again, failed runs included (a fixed plug-in, a longer
``timeout``, a device that works); ``rerun=True`` (``bench --rerun``) runs the
finished ones again too. CSV, not Parquet: pandas needs the optional
pyarrow for Parquet, and the files are small.

Failures
--------
Each run executes in a process of its own (:mod:`synthcal.eval.isolation`);
scoring happens here, on the scene and test split this process read itself.
Whatever the estimator does to its process (raises, times out, exits, crashes, is
killed) records the run with every test image failed (IoU 0, completeness 0) and
the reason, prefixed by the stage: ``predict: timed out after 5 s``. A run whose
estimates are all invalid is failed too, with the commonest reason
(``all 8 estimates invalid: non-finite entries``).
The sweep goes on; a failed run is recorded, and the next sweep
over it runs it again. ``KeyboardInterrupt`` in the sweep's process (Ctrl-C)
kills the running runs' processes (and what they started) and is raised again from
:func:`run_sweep`: finished runs stay, and the next invocation resumes with the
others. Errors in the data (a missing store or
split) stop the sweep: before anything runs where :func:`expand_runs` can see them,
else at the run that meets them. A damaged ``run.json`` (empty, truncated) is
skipped with a :class:`DamagedRecordWarning` naming it, and its run is done again.

Side by side
------------
``run_sweep(..., workers=N)`` executes N runs at once, each in its own process
started from a thread of the sweep, with ``cores // N`` torch threads, at most
``OMP_NUM_THREADS`` where the user set it (:func:`run_threads`). Runs needing the same trained stage share it through the
stage cache's lock (:mod:`synthcal.training.cache`): one trains it, the others wait
and load it.

Dask
----
``run_sweep(..., scheduler=ADDRESS)`` maps the runs over a Dask cluster
(``client.map``); workers must see ``RESULTS`` and the stores at the same paths.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import threading
import warnings
from collections.abc import Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path
from statistics import fmean
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from synthcal.config import FAILURE_SHARES, METRICS
from synthcal.data import read_scene
from synthcal.eval.isolation import (
    DEFAULT_TIMEOUT,
    RunProcesses,
    estimate_isolated,
    load_run_split,
    sweep_exchanges,
    write_text_atomic,
)
from synthcal.eval.runs import (
    AXES,
    Run,
    check_device,
    chosen_text,
    dataset_store,
    estimator_label,
    expand_runs,
    plan_lines,
    prefix_positions,
    resolve_device,
    split_sizes,
    table_label,
    trained_images,
    training_budget,
)
from synthcal.eval.scoring import evaluate, summarize
from synthcal.store import StoreError, attributes, open_store
from synthcal.utils.dispatch import dispatch, usable_cores

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
    "is_finished",
    "sweep_exchanges",
    "run_sweep",
    "run_threads",
    "recorded_machine",
    "collect_results",
    "is_finished",
    "recorded_seconds",
    "expected_seconds",
    "estimate_seconds",
    "scaled_seconds",
    "timing_key",
    "trained_images",
    "TIMING_KEYS",
    "training_budget",
    "chosen_text",
    "table_runs",
]

# The estimate's entries in metrics.csv.
_H_COLUMNS = [f"h{r}{c}" for r in range(3) for c in range(3)]


# --- one run -----------------------------------------------------------------------------


class DamagedRecordWarning(UserWarning):
    """A ``run.json`` that cannot be read (empty, truncated, not a run record): skipped."""


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


def recorded_machine(results: str | Path, runs: Iterable[Run], *keys: str) -> dict[str, dict[int | str, int]]:
    """How many of the finished ``runs`` recorded each value of each of ``keys`` in their ``machine``
    (``run.json``, read once per run): ``torch_threads``, ``cpu_capability``
    (:func:`synthcal.utils.machine.machine_record`).

    Runs without a key (NumPy estimators, records older than the field) are not counted for it.
    """
    counts: dict[str, dict[int | str, int]] = {key: {} for key in keys}
    for run in runs:
        path = run_folder(results, run) / "run.json"
        record = read_record(path) if path.is_file() else None
        machine = (record or {}).get("machine") or {}
        for key in keys:
            value = machine.get(key)
            if isinstance(value, (int, str)) and not isinstance(value, bool):
                counts[key][value] = counts[key].get(value, 0) + 1
    return counts


def with_device(run: Run, device: str | None) -> Run:
    """The run on another device (a different run: its id changes); unchanged for None or
    an estimator that takes no device."""
    if device is None or run.device is None:
        return run
    return dataclasses.replace(run, device=resolve_device(device))


def execute_run(run: Run, results: str | Path, device: str | None = None, progress: bool = False,
                timeout: float | None = DEFAULT_TIMEOUT, rerun: bool = False, threads: int | None = None,
                processes: RunProcesses | None = None) -> Path:
    """Evaluate one run unless it is finished (ok) or ``rerun``; returns its folder (module docstring).

    Args:
        run: from :func:`expand_runs`.
        results: the results folder.
        device: replaces the run's device (:func:`with_device`); None: the run's own.
        progress: the estimator's own progress bars.
        timeout: seconds the run's process may take (start-up not counted); None or 0: no limit.
        rerun: run it even if it is finished (its results are replaced).
        threads: torch threads in the run's process (None: torch's default).
        processes: the sweep's run processes (:class:`~synthcal.eval.isolation.RunProcesses`), when
            several runs execute at once; None: this run's alone.

    Raises:
        StoreError: the run's store or splits cannot be read.
        SweepStopped: ``processes`` were stopped while this run executed (it records nothing).
        OSError: the results cannot be written (names the file).
    """
    results = Path(results)
    run = with_device(run, device)
    folder = run_folder(results, run)
    if not rerun and is_finished(results, run):
        return folder
    # Scoring reads its own copy of the scene and the test split, loaded here: the
    # estimator, in its own process, cannot reach it.
    scene = read_scene(run.store)
    test = load_run_split(run, "test", scene)
    outcome = estimate_isolated(run, results, progress, timeout, threads, processes)
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
    write_text_atomic(folder / "metrics.csv", frame.to_csv(index=False))
    record = {"run": asdict(run), "id": run.id, "status": "failed" if failure else "ok", "error": failure,
              "device": run.device, **outcome, "summary": summarize(frame)}
    write_text_atomic(folder / "run.json", json.dumps(record, indent=2, default=str))
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
              progress: bool = True, timeout: float | None = DEFAULT_TIMEOUT, rerun: bool = False,
              workers: int = 1, threads: int | None = None) -> pd.DataFrame:
    """Execute every run not finished ok (every run: ``rerun``), locally or on a Dask cluster; return all results.

    Exchange folders a killed sweep left in ``results`` (:func:`sweep_exchanges`) are removed first.

    Args:
        runs: from :func:`expand_runs`.
        results: the results folder.
        device: replaces the runs' device (:func:`with_device`: other runs, other
            ids); None: each run's own.
        scheduler: a Dask scheduler address, or None to run here.
        progress: progress bars (runs; epochs inside the bundled models while one run runs at a time).
        timeout: seconds each run's process may take; None or 0: no limit.
        rerun: run the finished runs again too (their results are replaced).
        workers: runs executed side by side here, each with :func:`run_threads` torch threads.
        threads: torch threads of each run, here or on the cluster, whatever ``workers``; None:
            here, the cores shared out (:func:`run_threads`), on a cluster, torch's default.
            A run's torch thread count changes the order of its sums, not the run's identity:
            over a training the rounding can move the epoch validation keeps, so scores agree
            to the digit only between runs at the same count: a fixed ``threads`` makes a
            sweep's figures independent of ``workers`` (docs/benchmark.md).

    Returns:
        :func:`collect_results` of the folder.

    Raises:
        ValueError: ``threads`` is not a positive count, or ``results/cache`` is a link to
            nothing (a cache shared with another folder whose target is gone).
        KeyboardInterrupt: Ctrl-C; the running runs' processes are killed first, the
            finished runs stay and a rerun resumes with the others.
    """
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ValueError(f"threads: expected a positive count of torch threads per run, got {threads!r}")
    results = Path(results)
    runs = [with_device(run, device) for run in runs]
    # Now, not after the first run: a results folder that cannot be written stops the sweep at once.
    (results / "runs").mkdir(parents=True, exist_ok=True)
    check_results_cache(results)
    sweep_exchanges(results)
    todo = list(runs) if rerun else [run for run in runs if not is_finished(results, run)]
    # Position 1: a run's own epoch bars (another process, which knows nothing of this one) draw on the
    # line above, so that neither hides the other.
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), desc="runs", unit="run", disable=not progress,
               position=1 if scheduler is None else 0)
    try:
        if scheduler is not None:  # on a cluster: no estimator bars
            execute = functools.partial(execute_run, results=str(results), progress=False, timeout=timeout,
                                        rerun=rerun, threads=threads)
            for folder in dispatch(execute, todo, workers=1, scheduler=scheduler):
                bar.set_postfix_str(folder.name)
                bar.update()
        else:
            _run_here(todo, results, timeout, max(1, workers), run_threads(workers, threads), bar, progress, rerun)
    finally:  # on Ctrl-C too: the bar's line ends before whatever is printed next
        bar.close()
    return collect_results(results)


def check_results_cache(results: str | Path) -> None:
    """Raise ValueError where ``results/cache`` is a symbolic link to nothing (a cache shared with another results
    folder whose target is gone): every run would fail on it, each with a bare FileExistsError from creating the
    folder the link stands in for."""
    path = Path(results) / "cache"
    if path.is_symlink() and not path.exists():
        raise ValueError(f"{path}: a link to {os.readlink(path)}, which does not exist; "
                         "make that folder or remove the link")


def run_threads(workers: int, threads: int | None = None) -> int:
    """torch threads of each of ``workers`` runs executed side by side here: ``threads`` where given (the user's
    ``--threads``); else this machine's cores shared out, at least 1, and at most ``OMP_NUM_THREADS`` where the
    user set it to a positive count (two sweeps side by side on one machine: ``OMP_NUM_THREADS=1``; a run's
    process is given its count in its environment, so without this cap the user's setting would be overridden)."""
    if threads is not None:
        return threads
    threads = max(1, usable_cores() // max(1, workers))
    cap = os.environ.get("OMP_NUM_THREADS", "").strip()
    return min(threads, int(cap)) if cap.isdigit() and int(cap) > 0 else threads


def _run_here(todo: Sequence[Run], results: Path, timeout: float | None, workers: int, threads: int, bar: tqdm,
              progress: bool, rerun: bool) -> None:
    """Execute runs ``workers`` at a time, each in its own process (with ``threads`` torch threads) started from
    a thread of ours.

    The bar names the runs executing. The estimators draw their own bars only when one run
    executes at a time: several processes drawing on the same line would garble it.
    """
    processes = RunProcesses()
    running: list[str] = []
    lock = threading.Lock()

    def label(run_id: str, starts: bool) -> None:
        with lock:
            if starts:
                running.append(run_id)
            else:
                running.remove(run_id)
            bar.set_postfix_str(", ".join(running), refresh=True)

    def execute(run: Run) -> None:
        label(run.id, True)
        try:
            execute_run(run, results, progress=progress and workers == 1, timeout=timeout, rerun=rerun,
                        threads=threads, processes=processes)
        finally:
            label(run.id, False)

    pool = ThreadPoolExecutor(workers, thread_name_prefix="run")
    try:
        for future in as_completed([pool.submit(execute, run) for run in todo]):
            future.result()  # a data error stops the sweep
            bar.update()
    except BaseException:  # Ctrl-C, a data error: the other runs' processes are killed, not awaited
        processes.stop()
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown()


# What a run's time depends on most: the estimator, how it trains, whether a UNet is in the loop, the device
# (a proposed run took 7 min step-by-step on mixed-4 and 13 min end-to-end on intersection-1, on one core), then
# how many images it trains on (World Cup 2014 trains on 167 frames, `mixed-1` on 1,500: 4 against 9 min a sha2020
# run end to end; a sweep of intersection-3 timed by both kinds of runs was told 33 min and took 49, twenty-seventh
# session), and last the dataset. A run whose dataset has no finished run alike is timed by its settings' runs
# elsewhere on as many train images, else by those on other numbers scaled to its own (estimate_seconds).
TIMING_KEYS = ("estimator", "training", "segmentation", "device", "train_images", "dataset")


def timing_key(run: Run | dict[str, Any], train_images: int | None) -> tuple[str, ...]:
    """A run's (or a run record's ``run`` mapping's) values of :data:`TIMING_KEYS`, as strings; the
    train images (:func:`trained_images`) given, since a run's record keeps them apart from the run."""
    values = run if isinstance(run, dict) else {key: getattr(run, key, None) for key in TIMING_KEYS}
    return tuple(str(train_images if key == "train_images" else values.get(key)) for key in TIMING_KEYS)


def recorded_seconds(results: str | Path) -> dict[tuple[str, ...], list[float]]:
    """The seconds each finished (ok) run took, by :func:`timing_key`: what a sweep's preview estimates its
    runs by. A damaged record is left out (with a :class:`DamagedRecordWarning`)."""
    seconds: dict[tuple[str, ...], list[float]] = {}
    for path in sorted((Path(results) / "runs").glob("*/run.json")):
        record = read_record(path)
        if record is not None and record["status"] == "ok" and isinstance(record.get("seconds"), (int, float)):
            train = trained_images(record["run"].get("settings"), (record.get("sizes") or {}).get("train"))
            seconds.setdefault(timing_key(record["run"], train), []).append(float(record["seconds"]))
    return seconds


def expected_seconds(run: Run, seconds: dict[tuple[str, ...], list[float]],
                     train_images: int | None = None) -> float | None:
    """A run's expected seconds from :func:`recorded_seconds` (:func:`estimate_seconds` without its basis);
    None when its estimator has no finished run."""
    return estimate_seconds(run, seconds, train_images)[0]


def estimate_seconds(run: Run, seconds: dict[tuple[str, ...], list[float]],
                     train_images: int | None = None) -> tuple[float | None, str]:
    """A run's expected seconds from :func:`recorded_seconds`, and what they are based on.

    The bases, most alike first: ``"alike"`` (the mean of the finished runs with its :func:`timing_key`),
    ``"other datasets"`` (of those alike in all but the dataset, so on as many train images), ``"other
    train sizes"`` (those alike in all but the dataset and the train images, scaled to ``train_images``:
    see below), ``"estimator"`` (the mean of every finished run of its estimator, or of those alike in all
    but the dataset and the train images when there is nothing to scale by) and ``"none"`` (no finished run
    of its estimator: the seconds are None).

    Scaling, because a run's time grows with its train images and a plain mean of runs on another number
    misleads: ``sha2020-ccbv`` took 160 s a run on World Cup 2014's 167 frames and 1,278 s on 1,500 of
    intersection-3 (thirty-fourth session), ``sha2020`` end to end 4 and 9 min. Runs on two or more train
    sizes give a line through their per-size means (time = fixed + per image × images, the fixed part
    being test, dictionary and start-up), never below zero; runs on one size are scaled in proportion,
    which overestimates when the run trains on more images (its fixed part scaled too) and underestimates
    when on fewer. A run that does not train (``train_images`` None) takes the plain mean.

    Args:
        run: the run to time.
        seconds: :func:`recorded_seconds` of the results folder.
        train_images: what the run trains on (:func:`trained_images`; None: it does not train).

    Returns:
        (seconds, basis).
    """
    key = timing_key(run, train_images)

    def alike(length: int) -> dict[str, list[float]]:
        found: dict[str, list[float]] = {}
        for other, values in seconds.items():
            if other[:length] == key[:length]:
                found.setdefault(other[TIMING_KEYS.index("train_images")], []).extend(values)
        return found

    def mean(by_size: dict[str, list[float]]) -> float:  # over every run, whatever its size
        return fmean(value for sized in by_size.values() for value in sized)

    for length, basis in ((len(key), "alike"), (len(key) - 1, "other datasets")):
        if found := alike(length):
            return mean(found), basis
    if found := alike(len(key) - 2):
        sizes = {int(size): fmean(values) for size, values in found.items() if size.isdigit()}
        if train_images is None or not sizes:  # nothing to scale by: the plain mean, as for the estimator's runs
            return mean(found), "estimator"
        return scaled_seconds(sizes, train_images), "other train sizes"
    if found := alike(1):
        return mean(found), "estimator"
    return None, "none"


def scaled_seconds(seconds_by_size: dict[int, float], train_images: int) -> float:
    """Seconds on ``train_images`` from mean seconds on other train sizes: the least-squares line through
    them when there are two sizes or more (never below zero), else in proportion to the one size.

    >>> round(scaled_seconds({167: 160.0}, 1500))
    1437
    >>> round(scaled_seconds({167: 240.0, 1500: 540.0}, 500))
    315
    """
    if len(seconds_by_size) == 1:
        ((size, value),) = seconds_by_size.items()
        return value * train_images / size if size else value
    sizes = list(seconds_by_size)
    mean_size = sum(sizes) / len(sizes)
    mean_value = sum(seconds_by_size.values()) / len(sizes)
    slope = (sum((size - mean_size) * (value - mean_value) for size, value in seconds_by_size.items())
             / sum((size - mean_size) ** 2 for size in sizes))
    return max(0.0, mean_value + slope * (train_images - mean_size))


def collect_results(results: str | Path, runs: Iterable[Run] | None = None) -> pd.DataFrame:
    """One row per finished run: the table keys, seed, segmentation, profile, metrics.

    Args:
        results: the results folder.
        runs: only these runs (default: every finished run in the folder).

    Returns:
        DataFrame with ``dataset``, ``model``, ``training``, ``loss``,
        ``matching_score``, ``segmentation``, ``profile``, ``seed``, the
        metrics of :data:`synthcal.config.METRICS` (:func:`synthcal.eval.scoring.summarize`:
        means over scored test images, failures as 0, or medians of the pixel errors;
        NaN for a metric the run's record predates), the pixel errors' failure shares
        ``reproj_px_failed`` and ``corner_error_failed``, ``completeness``, ``n_images``, ``n_skipped``, ``status``, ``error`` (``""`` for a run
        that is ok), ``run_id``, ``device``, ``torch_threads`` and ``cpu_capability`` (the run process's torch
        threads and the instruction set torch's CPU kernels used, ``AVX2``, ``AVX512``, …, from its ``machine``
        record: what a bit-for-bit rerun must match; None for NumPy estimators and records older than them),
        ``chosen`` (:func:`chosen_text`: what validation chose),
        ``budget`` (:func:`training_budget`;
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
            row = {"dataset": table_label(run), "model": run["model"], "training": run["training"], "loss": run["loss"],
                   "matching_score": run["matching"], "segmentation": run["segmentation"],
                   "profile": run["profile"], "seed": run["seed"], "estimator": run["estimator"]}
            summary = record["summary"]
            row.update({k: summary[k] for k in ("iou", "completeness", "n_images")})
            # Runs recorded before a metric existed show it as missing (NaN), not as 0.
            row.update({k: summary.get(k, np.nan) for k in (*METRICS, *FAILURE_SHARES.values(), "n_skipped")})
        except KeyError as error:
            warnings.warn(f"{path}: damaged run record skipped (no {error})", DamagedRecordWarning, stacklevel=2)
            continue
        row.update(status=record["status"], error=record.get("error") or "", run_id=record["id"],
                   device=run.get("device"), **_machine_columns(record),
                   budget=training_budget(record), dictionary=run.get("dictionary", "split"), chosen=chosen_text(record))
        rows.append(row)
    columns = ["dataset", "model", "training", "loss", "matching_score", "segmentation", "profile", "seed",
               "estimator", *METRICS, *FAILURE_SHARES.values(), "completeness", "n_images", "n_skipped", "status", "error", "run_id",
               "device", "torch_threads", "cpu_capability", "budget", "dictionary", "chosen"]
    return pd.DataFrame(rows, columns=columns)


def _machine_columns(record: dict[str, Any]) -> dict[str, Any]:
    """``torch_threads`` and ``cpu_capability`` of a run's ``machine`` record (None where it names neither)."""
    machine = record.get("machine") or {}
    return {"torch_threads": machine.get("torch_threads"), "cpu_capability": machine.get("cpu_capability")}


def table_runs(frame: pd.DataFrame, keys: Sequence[str] = ("training", "loss", "matching_score")) -> pd.DataFrame:
    """Runs for the tables: an estimator a key does not apply to is shown beside each trained configuration.

    ``identity`` has no loss; beside models trained with ``top-mse`` and ``mse`` its
    row would stand apart with "–". Here each run whose keys are missing is repeated
    for every combination of those keys that the runs of its dataset with the most
    keys take *together* and that agrees with the keys the run has — so the
    reference estimators sit beside each trained configuration, and no row holds
    reference runs alone (an end-to-end × MSE row where only step-by-step ran MSE).
    A run no combination agrees with is kept once, as it is; keys missing in every
    run stay missing.
    """
    keys = list(keys)
    pieces = []
    for _, group in frame.groupby("dataset", sort=False):
        present = group[keys].notna()
        counts = present.sum(axis=1)
        full = counts == counts.max()
        combos = group.loc[full, keys].drop_duplicates()
        pieces.append(group[full])
        for pattern, rows in group[~full].groupby([present.loc[~full, k] for k in keys], sort=False):
            have = [k for k, has in zip(keys, pattern, strict=True) if has]
            lacking = [k for k in keys if k not in have]
            rows = rows.drop(columns=lacking)
            if not have:
                pieces.append(rows.merge(combos[lacking], how="cross")[group.columns])
                continue
            spread = rows.merge(combos, on=have, how="left", indicator=True)
            matched = spread["_merge"] == "both"
            pieces.append(spread.loc[matched, list(group.columns)])
            pieces.append(spread.loc[~matched, list(group.columns)])  # lacking keys NaN: kept once, as it is
    return pd.concat(pieces, ignore_index=True) if pieces else frame.copy()
