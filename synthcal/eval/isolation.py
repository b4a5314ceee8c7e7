"""One run's estimator in a process of its own (SPEC §9).

:func:`synthcal.eval.harness.execute_run` calls :func:`estimate_isolated`, which
starts ``python -c … run_child`` (this module's entry point, in a session of its
own). That process loads the scene and splits as the run uses them
(:func:`load_run_split`: capped by the run's split sizes), makes every array
read-only (``writeable=False``, views that cannot be made writeable again),
constructs the estimator (:func:`_options`: its axes and the services its
constructor takes), fits and predicts, and hands back the estimates as plain JSON
data (:func:`_plain_estimates`). Under ``segmentation: ground-truth`` it calls
``predict_semantic(true test maps)`` instead of ``predict(test images)``.
Scoring happens in the sweep's process, on the scene and test split that process
read itself: an estimator can change neither its data nor its score.

Whatever the estimator does to its process is a result, not a crash: an
exception in construction, ``fit``, ``predict`` or in reading what ``predict``
returned, a time limit exceeded (``timeout`` seconds, counted from the end of the
process's start-up), an exit, a crash or a kill (e.g. out of memory) comes back
as the outcome's ``error``, prefixed by the stage (``load``, ``fit``,
``predict``): ``fit: ValueError: …``, ``predict: timed out after 5 s``,
``predict: killed by signal 11 (SIGSEGV)``, ``fit: exited with status 1``.
A store or split the process cannot read comes back as ``data_error``: an error
in the data, which stops the sweep. Exchange with the process goes through a
folder beside the results (``request.json`` in; ``stage``, ``crash.log`` and
``result.json`` out), removed afterwards; those a killed sweep left behind are
removed by the next sweep (:func:`sweep_exchanges`).

The process runs in a session (and process group) of its own: when it ends, by
itself or killed, the group is killed too, so nothing it started (a data loader, a
server) outlives the run. A process that leaves the group (its own ``setsid``)
escapes this. A crash dump (:mod:`faulthandler`'s Python stack of a segmentation
fault) goes to ``RESULTS/runs/<run-id>/crash.log``, recorded as the outcome's
``log``; the terminal gets one line naming it.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any, cast

import numpy as np

from synthcal.data import SplitDataset, StoreScene, load_pool_dictionary, load_split, read_scene
from synthcal.estimators import SemanticEstimator, load_estimator, resolve_estimator
from synthcal.eval.runs import AXES, Run, constructor_parameters, prefix_positions
from synthcal.store import StoreError
from synthcal.utils.atomic import atomic_write
from synthcal.utils.dispatch import die_with_parent, thread_environment
from synthcal.utils.machine import machine_record

__all__ = ["DEFAULT_TIMEOUT", "RunProcesses", "SweepStopped", "estimate_in_process", "estimate_isolated", "takes_validation",
           "load_run_split", "run_child",
           "write_text_atomic"]

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
# An exchange folder without a readable request older than this is a sweep's killed between
# creating it and writing the request (seconds); younger, it may be being written.
_UNWRITTEN_SECONDS = 60.0


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically: a reader sees the old file or the whole new one."""
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _options(run: Run, cls: Any, results: Path, progress: bool) -> dict[str, Any]:
    """Constructor keywords for the run: its axes, the services the class accepts and its options."""
    params = constructor_parameters(cls)
    offered = {a: getattr(run, a) for a in AXES if getattr(run, a) is not None}
    offered.update(settings=run.settings, device=run.device, cache_dir=str(results / "cache"), seed=run.seed,
                   progress=progress)
    # The user's options last: expand_runs refused any that would replace one of these.
    return {**{k: v for k, v in offered.items() if k in params and v is not None}, **(run.options or {})}


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


def _reads_validation(run: Run) -> bool:
    """Whether the run's settings choose anything on the validation split (``patience``, ``select``)."""
    settings = run.settings or {}
    return settings.get("patience") is not None or settings.get("select") is not None


def takes_validation(estimator: Any) -> bool:
    """Whether ``fit`` takes the protocol's optional ``validation`` keyword (an estimator that
    takes training settings without choosing anything on held-out data need not)."""
    try:
        return "validation" in inspect.signature(estimator.fit).parameters
    except (TypeError, ValueError):  # a builtin or C-implemented fit: no such keyword known
        return False


def load_run_split(run: Run, split: str, scene: StoreScene) -> SplitDataset:
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


def estimate_in_process(run: Run, results: Path, progress: bool, stage: Callable[[str], None]) -> dict[str, Any]:
    """Load the run's data read-only, fit and predict; the outcome as JSON-ready data.

    Returns:
        dict with ``estimates`` (:func:`_plain_estimates`, None on failure), ``error``
        (``""`` or ``"<stage>: <exception>"``), ``data_error`` (a store or split that
        cannot be read: the sweep stops), ``sizes`` (samples of each split used),
        ``fit_seconds``, ``predict_seconds``, ``history``, ``selection``, ``stage_keys``, ``traceback`` where
        they apply, and ``machine`` (:func:`synthcal.utils.machine.machine_record`: the processor, PyTorch's
        instruction set and threads in this process, the library versions).
    """
    outcome: dict[str, Any] = {"estimates": None, "error": ""}
    name = "load"
    stage(name)
    try:
        scene = _read_only_scene(read_scene(run.store))
        names = ["train", "test", "dictionary", *(["validation"] if _reads_validation(run) else [])]
        splits = {split: _read_only_split(load_run_split(run, split, scene), scene) for split in names}
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
        if "validation" in splits and takes_validation(estimator):  # what training choices read; never test
            cast(Any, estimator).fit(train, splits["dictionary"], scene, validation=splits["validation"])
        else:
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
        # Per-epoch losses, what validation chose, the cache keys of the shared stages (bundled models).
        for name in ("history", "selection", "stage_keys"):
            value = getattr(estimator, name, None)
            if isinstance(value, dict):
                outcome[name] = json.loads(json.dumps(value, default=float))
    except Exception as error:  # an estimator's failure is a result, not a crash (module docstring)
        detail = "".join(traceback.format_exception_only(type(error), error)).strip()
        outcome.update(estimates=None, error=f"{name}: {detail}", traceback=traceback.format_exc())
    outcome["machine"] = machine_record()  # after the estimator: torch's part only if it imported torch
    return outcome


def run_child(exchange: str) -> None:
    """Entry point of a run's own process: ``request.json`` in, ``stage``, ``result.json`` out."""
    import faulthandler

    folder = Path(exchange)
    request = json.loads((folder / "request.json").read_text(encoding="utf-8"))
    die_with_parent(request["parent"])  # a kill -9 of the sweep leaves no run behind
    # A crash writes the plug-in's Python stack here; the sweep moves it to the run's folder.
    crash_log = (folder / "crash.log").open("w", encoding="utf-8")
    faulthandler.enable(crash_log, all_threads=False)
    # The read-only arrays reach torch.from_numpy in SplitDataset.__getitem__, which
    # warns that writing through the tensor is undefined; nothing here writes.
    warnings.filterwarnings("ignore", message="The given NumPy array is not writable")
    sys.path[:0] = [entry for entry in request["sys_path"] if entry not in sys.path]  # the parent's plug-ins

    def stage(name: str) -> None:
        (folder / "stage").write_text(name, encoding="utf-8")

    run = Run(**request["run"])
    outcome = estimate_in_process(run, Path(request["results"]), request["progress"], stage)
    write_text_atomic(folder / "result.json", json.dumps(outcome))
    # Skip the interpreter's teardown: threads or atexit hooks a plug-in left behind
    # must not hang or crash a run whose result is already written.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


# --- in the sweep's process --------------------------------------------------------------


def _kill(process: subprocess.Popen[bytes]) -> None:
    """SIGKILL the run's process and everything it started (its own session), also once it has ended.

    The group outlives its leader while a member lives, and its id cannot be reused
    until the last member is gone, so killing it after the wait reaches only what
    the run started.
    """
    for _ in range(2):  # before the wait, then once more for what it started meanwhile
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except ProcessLookupError:  # the group is empty
            break
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


class SweepStopped(Exception):
    """The sweep stopped (Ctrl-C, another run's data error) while this run's process ran: no result."""


class RunProcesses:
    """The run processes of one sweep, which may run several at once from threads: stopping the
    sweep kills them all, and none starts afterwards."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._processes: set[subprocess.Popen[bytes]] = set()
        self.stopped = False

    def start(self, command: list[str], env: dict[str, str]) -> subprocess.Popen[bytes]:
        """Start a run's process (its own session, no standard input).

        Raises:
            SweepStopped: the sweep has stopped.
        """
        with self._lock:  # so that stop() cannot miss a process started meanwhile
            if self.stopped:
                raise SweepStopped
            # Its own session: a kill reaches the processes it starts (data loaders), and a
            # Ctrl-C at the terminal reaches only the sweep, which then kills it.
            process = subprocess.Popen(command, stdin=subprocess.DEVNULL, start_new_session=True, env=env)
            self._processes.add(process)
        return process

    def finish(self, process: subprocess.Popen[bytes]) -> None:
        """Kill the process and its group (what it started, also once it has ended), and forget it."""
        _kill(process)
        with self._lock:
            self._processes.discard(process)

    def stop(self) -> None:
        """Kill every running run's process; later :meth:`start` calls raise :class:`SweepStopped`."""
        with self._lock:
            self.stopped = True
            processes = list(self._processes)
        for process in processes:
            _kill(process)


def _child_environment(threads: int | None) -> dict[str, str]:
    """This process's environment, with the run's thread count for torch and the BLAS libraries."""
    env = dict(os.environ)
    if threads is not None:  # torch reads OMP_NUM_THREADS when it is imported
        env.update(thread_environment(threads))
    return env


def estimate_isolated(run: Run, results: Path, progress: bool, timeout: float | None, threads: int | None = None,
                      processes: RunProcesses | None = None) -> dict[str, Any]:
    """:func:`estimate_in_process` in a process of its own, under the time limit (module docstring).

    Args:
        run: the run to fit and predict.
        results: the results folder; the exchange folder with the process lives beside it.
        progress: whether the process shows progress bars.
        timeout: seconds the process may take after its start-up; None: no limit.
        threads: torch's (and BLAS's) threads in the process; None: their defaults.
        processes: the sweep's run processes (several runs at once); None: this run's alone.

    Returns:
        The outcome as plain JSON data: ``estimates`` (or None), ``error``, ``traceback``,
        timings, and ``data_error`` when the process could not read the store.
    """
    # Beside the results, not in /tmp: a temp-folder cleaner cannot pull it from under a
    # running child, and a folder left by a kill -9 stays where the user looks.
    exchange = Path(tempfile.mkdtemp(prefix=".exchange-", dir=results))
    try:
        request = {"run": asdict(run), "results": str(results), "progress": progress, "sys_path": sys.path,
                   "parent": os.getpid()}
        (exchange / "request.json").write_text(json.dumps(request), encoding="utf-8")
        command = [sys.executable, "-c",
                   "import sys; from synthcal.eval.isolation import run_child; run_child(sys.argv[1])",
                   str(exchange)]
        started = time.monotonic()
        processes = RunProcesses() if processes is None else processes
        process = processes.start(command, _child_environment(threads))
        try:
            status = _wait(process, exchange / "stage", timeout)
        finally:  # Ctrl-C here: kill it before going on
            processes.finish(process)
        if processes.stopped and not (exchange / "result.json").exists():  # killed by the sweep, not the estimator
            raise SweepStopped
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
        _keep_crash_log(exchange / "crash.log", results / "runs" / run.id, outcome)
        return outcome
    finally:
        shutil.rmtree(exchange, ignore_errors=True)


def _keep_crash_log(dump: Path, folder: Path, outcome: dict[str, Any]) -> None:
    """Move a crash dump to the run's folder (``outcome["log"]``) with one line on the terminal; else
    remove an older run's."""
    log = folder / "crash.log"
    if not (dump.is_file() and dump.stat().st_size):
        log.unlink(missing_ok=True)
        return
    folder.mkdir(parents=True, exist_ok=True)
    shutil.move(dump, log)
    outcome["log"] = str(log)
    print(f"synthcal: run {folder.name}: {outcome.get('error') or 'crashed'}; crash dump in {log}",
          file=sys.stderr, flush=True)


def _parent_alive(request: Path) -> bool | None:
    """Whether the sweep that wrote ``request.json`` still runs (None: no readable request)."""
    try:
        parent = int(json.loads(request.read_text(encoding="utf-8"))["parent"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    try:
        os.kill(parent, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: alive
        pass
    return True


def sweep_exchanges(results: str | Path) -> list[Path]:
    """Remove the exchange folders a killed sweep left in ``results`` (module docstring).

    A folder is left behind when its sweep is gone (``kill -9``): its request names
    a process that no longer exists, or it has no readable request and is older than
    a minute. Folders of a sweep still running (another ``bench`` on the same
    results) are kept.

    Returns:
        the folders removed, sorted.
    """
    removed = []
    for folder in sorted(Path(results).glob(".exchange-*")):
        alive = _parent_alive(folder / "request.json")
        if alive is None:
            try:
                alive = time.time() - folder.stat().st_mtime < _UNWRITTEN_SECONDS
            except FileNotFoundError:  # its sweep removed it meanwhile
                continue
        if not alive:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed

