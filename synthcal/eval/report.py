"""The text of ``synthcal table``: the results tables, or the paired differences of two sides (and their contrasts).

:func:`results_tables` splits a results frame by segmentation and profile and
formats one table per part and layout (:func:`synthcal.eval.tables.format_table`),
the legend once after the last; under ``iou_weighted`` each table states the
all-background floor of its datasets (:func:`background_floors`); under each mixed
table, the template diagnostics of its mixed-dictionary runs
(:func:`synthcal.eval.templates.diagnostics_text`). Layout ``report`` is
:func:`reproduction_report` (:mod:`synthcal.eval.reproduction`).
:func:`paired_report` reads the two sides of ``--paired A B`` (:func:`paired_sides`)
and formats their per-seed differences with confidence intervals
(:func:`synthcal.eval.statistics.format_paired`), the bootstrap's from each run's
``metrics.csv`` (:func:`per_image_reader`); with ``--between C D``, :func:`contrast_report`
compares that difference between two values of another key
(:func:`synthcal.eval.statistics.format_contrast`). All first give each estimator one
label (:func:`one_label`). A request the results cannot answer raises
:class:`ReportError`, one line for the user.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from synthcal.config import PIXEL_METRICS
from synthcal.eval.archive import ArchiveError, is_archive, read_archive, runs_archive
from synthcal.eval.harness import collect_results, table_runs
from synthcal.eval.reproduction import format_report, report_frame
from synthcal.eval.runs import estimator_label
from synthcal.eval.statistics import (
    background_floor,
    contrast_frame,
    format_contrast,
    format_paired,
    paired_frame,
    paired_runs,
)
from synthcal.eval.tables import LAYOUTS, MISSING, PAIR_KEYS, format_table, legend, text_table, wrap_caption
from synthcal.eval.templates import diagnostics_text, format_diagnostics, oracle_cells, template_diagnostics

__all__ = ["ReportError", "finished_runs", "run_folders", "results_tables", "reproduction_report", "runs_layout",
           "split_by", "one_label", "background_floors", "per_image_reader",
           "paired_sides", "paired_report", "paired_numbers", "contrast_report", "contrast_numbers", "report_numbers",
           "budget_differences"]

# The reading whose tables state the all-background floor: the one that rewards predicting background.
FLOOR_READINGS = ("iou_weighted",)

# Tables name the soccer dataset as the paper does.
_ALIASES = {"soccer": "worldcup2014"}


class ReportError(ValueError):
    """The results cannot answer the request (no runs, a side absent, a layout without rows)."""


def finished_runs(results: str | Path) -> pd.DataFrame:
    """The finished runs of a results folder (:func:`synthcal.eval.harness.collect_results`), or of a runs
    archive (a ``.csv`` file: :func:`synthcal.eval.archive.read_archive`).

    Raises:
        ReportError: no such folder, or no finished run in it (naming the folder); an archive that cannot be
            read (naming the file, and the row and column where one is wrong).
    """
    if is_archive(results):
        try:
            return read_archive(results)
        except ArchiveError as error:
            raise ReportError(str(error)) from None
    if not Path(results).is_dir():
        raise ReportError(f"{results}: no such results folder")
    frame = collect_results(results)
    if frame.empty:
        raise ReportError(f"{results}: no finished runs")
    return frame


def run_folders(results: str | Path | None) -> str | Path | None:
    """The results folder whose run folders the estimates and per-image scores are read from; None for a runs
    archive (it keeps neither: no template diagnostics, no all-background floor, no bootstrap) or no source."""
    return None if results is None or is_archive(results) else results


def split_by(frame: pd.DataFrame, keys: Sequence[str]) -> list[tuple[str, pd.DataFrame]]:
    """Parts of ``frame`` with one value of each key; rows where a key is missing join every part.

    Returns:
        (title, part) pairs; the title names the values (``"segmentation: unet; profile: quick"``),
        empty when no key varies.
    """
    parts = [("", frame)]
    for key in keys:
        values = sorted(frame[key].dropna().unique())
        if len(values) <= 1:
            continue
        parts = [(f"{title}; {key}: {value}".lstrip("; "), part[(part[key] == value) | part[key].isna()])
                 for title, part in parts for value in values]
    return parts


def results_tables(frame: pd.DataFrame, layout: str | None, fmt: str, compare_paper: bool,
                   metric: str, results: str | Path | None = None) -> Iterator[str]:
    """The tables of a results frame, one per segmentation / profile in it, each after its title (one block each),
    then the legend they share (not in CSV).

    A generator: the blocks before a failing layout come out before the error.

    Args:
        frame: the results (:func:`synthcal.eval.harness.collect_results`).
        layout: a layout of :func:`format_table`, or ``report`` (:func:`reproduction_report`); None picks ``models`` for own-dictionary
            datasets and ``mixed`` for mixed ones, each where there are results.
        fmt: ``md``, ``latex`` or ``csv`` (no titles in CSV).
        compare_paper: add the published figures.
        metric: the column shown.
        results: the results folder (its runs' records and stores give the
            all-background floor under ``iou_weighted``); None: no floor.

    Raises:
        ReportError: no finished runs, or a layout the results cannot fill.
    """
    if frame.empty:
        raise ReportError("no finished runs in the results folder")
    frame = one_label(frame)
    if layout in _WHOLE_LAYOUTS:
        yield _WHOLE_LAYOUTS[layout](frame, fmt, metric, results)
        return
    folder = run_folders(results)
    floors = background_floors(folder, frame, metric) if folder is not None and metric in FLOOR_READINGS else {}
    frame = table_runs(frame)
    if layout in LAYOUTS:  # only the layout's rows decide its parts (UNet runs on no mixed dictionary: no UNet part)
        rows = frame["dataset"].str.startswith("mixed-") == LAYOUTS[layout].mixed
        frame = frame[rows] if rows.any() else frame  # none at all: the layout's own error below
    for title, part in split_by(frame, ("segmentation", "profile")):
        mixed = part["dataset"].str.startswith("mixed-")
        layouts = [layout] if layout else [name for name, rows in (("models", ~mixed), ("mixed", mixed)) if rows.any()]
        for name in layouts:
            if title and fmt != "csv":
                yield f"{'%' if fmt == 'latex' else '###'} {title}\n"
            try:
                table = format_table(part, name, fmt, value=metric, compare_paper=compare_paper, aliases=_ALIASES,
                                     floors=floors, with_legend=False)
            except ValueError as error:
                raise ReportError(f"table {name!r}: {error}") from None
            yield table
            if name == "mixed":
                diagnostics = diagnostics_text(part, folder, metric, fmt)
                if diagnostics:
                    yield diagnostics
    if fmt != "csv":
        yield wrap_caption(legend(metric, compare_paper), fmt) + "\n"


def diagnostics_layout(frame: pd.DataFrame, fmt: str, metric: str, results: str | Path | None) -> str:
    """``table --layout diagnostics``: the template diagnostics (:mod:`synthcal.eval.templates`) of every
    dataset, own dictionaries included — lines in md/LaTeX, one row per dataset, settings and picker in CSV.

    Raises:
        ReportError: no results folder, or no run whose template picks can be identified.
    """
    folder = run_folders(results)
    if folder is None:
        raise ReportError(f"table 'diagnostics' reads the runs' estimates: give the results folder"
                          f"{'' if results is None else f' ({results} is a runs archive)'}")
    diagnostics = template_diagnostics(frame, folder, mixed_only=False)
    if diagnostics.empty:
        raise ReportError("table 'diagnostics': no finished run of retrieved, template or oracle-template whose "
                          "templates can be identified")
    if fmt == "csv":
        return diagnostics.to_csv(index=False)
    return format_diagnostics(diagnostics, oracle_cells(frame, metric), fmt)


# ``--layout runs`` in Markdown / LaTeX: the keys that vary, then these (the CSV holds every column).
_RUN_COLUMNS = (("learning_rate", "lr"), ("unet_epochs", "UNet epochs"), ("stn_epochs", "STN epochs"),
                ("seconds", "s"), ("run_id", "run"))


def runs_layout(frame: pd.DataFrame, fmt: str, metric: str, results: str | Path | None) -> str:
    """``table --layout runs``: one row per run. CSV: the runs archive (:mod:`synthcal.eval.archive`), which
    ``synthcal table`` reads back in place of the folder; Markdown / LaTeX: the keys that vary, the seed, the
    reading and what validation chose."""
    archive = runs_archive(frame, results)
    if fmt == "csv":
        return archive.to_csv(index=False)
    keys = [k for k in PAIR_KEYS if k in archive and (k in ("dataset", "model") or archive[k].nunique() > 1)]
    archive = archive.sort_values([*keys, "seed"], kind="stable", key=lambda c: c.astype(str))
    scale = 1.0 if metric in PIXEL_METRICS else 100.0
    header = [*keys, "seed", metric, *(name for _, name in _RUN_COLUMNS)]
    body = [[*(MISSING if pd.isna(row[k]) else str(row[k]) for k in keys), str(row["seed"]),
             f"{scale * row[metric]:.2f}", *(_run_cell(row[c], c) for c, _ in _RUN_COLUMNS)]
            for row in archive.to_dict("records")]
    caption = (f"{metric}: the run's summary over its test images{'' if scale == 1 else ' (percent)'}; lr, UNet / "
               f"STN epochs: what validation chose; s: the run's seconds. `--format csv` writes every column: the "
               f"runs archive, which `synthcal table ARCHIVE.csv` reads in place of the results folder.")
    return text_table(header, body, "l" * len(keys) + "r" * (len(header) - len(keys) - 1) + "l",
                      wrap_caption(caption, fmt), fmt)


def _run_cell(value: object, column: str) -> str:
    """A cell of ``--layout runs`` in Markdown / LaTeX: seconds whole, other numbers as short as they are."""
    if pd.isna(value):
        return MISSING
    if isinstance(value, float):
        return f"{value:.0f}" if column == "seconds" else f"{value:g}"
    return str(value)


def report_numbers(frame: pd.DataFrame, metric: str, results: str | Path | None = None) -> pd.DataFrame:
    """:func:`reproduction_report`'s numbers (:func:`synthcal.eval.reproduction.report_frame`), references spread
    over the training keys.

    Raises:
        ReportError: results the report cannot read (as :func:`synthcal.eval.tables.validate_results`).
    """
    try:
        return report_frame(table_runs(frame, ("training", "loss", "matching_score", "segmentation")), metric,
                            results, _ALIASES)
    except ValueError as error:
        raise ReportError(f"table 'report': {error}") from None


def reproduction_report(frame: pd.DataFrame, fmt: str, metric: str, results: str | Path | None = None) -> str:
    """``table --layout report``: :mod:`synthcal.eval.reproduction`'s report of the runs (one label per
    estimator already given), references spread over the training keys as in ``--paired``.

    Raises:
        ReportError: results the report cannot read (as :func:`synthcal.eval.tables.validate_results`).
    """
    report = report_numbers(frame, metric, results)
    mixed = frame[frame["dataset"].astype(str).str.startswith("mixed-")]
    return format_report(report, fmt) + ("\n" + diagnostics_text(mixed, run_folders(results), metric, fmt)
                                         if len(mixed) else "")


# Layouts that are one block for all the runs (not one table per segmentation and profile).
_WHOLE_LAYOUTS: dict[str, Callable[[pd.DataFrame, str, str, str | Path | None], str]] = {
    "report": reproduction_report, "diagnostics": diagnostics_layout, "runs": runs_layout}


def one_label(frame: pd.DataFrame) -> pd.DataFrame:
    """One label per estimator: a run named by a dotted path to a class that an installed entry point
    also names gets the entry point's name and label (``pkg.mod:SiftEstimator`` → ``sift``).

    Where the same runs were made under both names, the entry point's are kept (they compute the
    same thing). A path that no longer imports keeps its label.
    """
    if "estimator" not in frame or frame.empty:
        return frame
    from synthcal.estimators.registry import known_estimators, resolve_estimator

    names: dict[str, tuple[str, str]] = {}  # dotted path → (entry point name, its label)
    entry_points = known_estimators()
    for path in {str(e) for e in frame["estimator"].dropna() if ":" in str(e)}:
        try:
            cls = resolve_estimator(path)
            # The entry point naming the same path, else one whose class is the same object (a re-export).
            found = [n for n, v in entry_points.items() if v == path] or [
                n for n, v in entry_points.items()
                if v.rpartition(":")[2] == path.rpartition(":")[2] and resolve_estimator(n) is cls]
        except Exception:  # a plug-in gone or broken: its rows keep their label
            continue
        if found:
            names[path] = (found[0], estimator_label(found[0], cls))
    if not names:
        return frame
    out = frame.copy()
    renamed = out["estimator"].isin(list(names))
    old_labels = out.loc[renamed, "estimator"].map(lambda p: estimator_label(p, resolve_estimator(p)))
    # Only rows labelled by the path's fallback (a variant label, a class label: already one per estimator).
    relabel = renamed & (out["model"] == old_labels.reindex(out.index))
    out.loc[relabel, "model"] = out.loc[relabel, "estimator"].map(lambda p: names[p][1])
    out.loc[renamed, "estimator"] = out.loc[renamed, "estimator"].map(lambda p: names[p][0])
    keys = [k for k in (*PAIR_KEYS, "seed", "dictionary") if k in out]
    # The entry point's runs first, so that a renamed run that repeats one is the copy dropped.
    ordered = out.assign(_renamed=renamed).sort_values("_renamed", kind="stable")
    repeated = ordered[keys].astype(str).duplicated() & ordered["_renamed"]
    return ordered[~repeated].drop(columns="_renamed").sort_index()


def _scored_pool_indices(folder: Path, metric: str) -> np.ndarray | None:
    """The pool indices of the test images a run scored (its ``metrics.csv``; None if unreadable)."""
    try:
        per_image = pd.read_csv(folder / "metrics.csv", usecols=["pool_index", metric])
    except (OSError, ValueError):
        return None
    return per_image.loc[per_image[metric].notna(), "pool_index"].to_numpy()


def background_floors(results: str | Path, frame: pd.DataFrame, metric: str) -> dict[str, float]:
    """Dataset label → the all-background floor of ``metric`` in percent, mean over the seeds' test sets.

    Each run's record names its store and seed; its ``metrics.csv`` the test images
    it scored; :func:`synthcal.eval.statistics.background_floor` scores an all-zero
    estimate against their stored true class maps. Runs whose store, split or
    records cannot be read are left out (a dataset without any: no floor).
    """
    from synthcal.data import load_split

    per_seed: dict[tuple[str, int], float] = {}
    cache: dict[tuple[str, int, bytes], float] = {}
    for run_id, dataset, seed in frame[["run_id", "dataset", "seed"]].itertuples(index=False):
        if (dataset, seed) in per_seed:
            continue
        folder = Path(results) / "runs" / str(run_id)
        indices = _scored_pool_indices(folder, metric)
        if indices is None:
            continue
        try:
            store = str(json.loads((folder / "run.json").read_text(encoding="utf-8"))["run"]["store"])
            key = (store, int(seed), indices.tobytes())
            if key not in cache:
                test = load_split(store, "test", int(seed), False)
                keep = np.isin(np.asarray(test.indices), indices)
                cache[key] = background_floor(test.semantics[keep], metric) if keep.any() else np.nan
        except (OSError, ValueError, KeyError, TypeError):  # StoreError is a ValueError
            continue
        if not np.isnan(cache[key]):
            per_seed[(dataset, seed)] = cache[key]
    floors: dict[str, list[float]] = {}
    for (dataset, _), floor in per_seed.items():
        floors.setdefault(dataset, []).append(floor)
    return {dataset: 100.0 * float(np.mean(values)) for dataset, values in floors.items()}


def per_image_reader(results: str | Path, metric: str) -> Callable[[str], pd.Series | None]:
    """A run id → its per-image ``metric`` (fractions indexed by pool index, NaN where not scored), read from
    ``RESULTS/runs/<run-id>/metrics.csv``; None where the file or column is missing, or for every run of a runs
    archive (which keeps no per-image scores)."""
    if is_archive(results):
        return lambda run_id: None

    @functools.cache
    def read(run_id: str) -> pd.Series | None:
        try:
            per_image = pd.read_csv(Path(results) / "runs" / run_id / "metrics.csv", usecols=["pool_index", metric])
        except (OSError, ValueError):
            return None
        return per_image.set_index("pool_index")[metric]
    return read


def paired_sides(frame: pd.DataFrame, sides: Sequence[str]) -> tuple[str, str, str]:
    """``--paired A B`` → ``(key, a, b)``: model labels or estimator names (``baseline`` is ``sha2020``),
    or ``KEY=VALUE`` for another key (``loss=top-mse loss=mse``).

    Raises:
        ReportError: a key that cannot be paired over, a value no run has, or two different keys.
    """
    keys, values = [], []
    for side in sides:
        key, _, value = side.rpartition("=")
        key = key or "model"
        if key not in PAIR_KEYS or key == "dataset":
            raise ReportError(f"cannot pair over {key!r} (value {side!r}); a model, or KEY=VALUE with KEY "
                              f"one of {', '.join(k for k in PAIR_KEYS if k != 'dataset')}")
        if key == "model":  # an estimator's name stands for its table label
            names = list(frame.loc[frame["estimator"] == value, "model"]) if "estimator" in frame else []
            value = str(names[0]) if names else value
        present = set(frame[key].dropna().astype(str)) if key in frame else set()
        if value not in present:
            raise ReportError(f"no runs with {key} {value!r}; present: {', '.join(sorted(present)) or 'none'}")
        keys.append(key)
        values.append(value)
    if keys[0] != keys[1]:
        raise ReportError(f"both sides must vary the same key (value {' '.join(sides)!r})")
    return keys[0], values[0], values[1]


class _Paired(NamedTuple):
    """What :func:`synthcal.eval.statistics.paired_frame` reads for one ``--paired A B [--against OTHER]``."""

    frame: pd.DataFrame
    key: str
    a: str  # side A's value of ``key``; across two folders a label naming its folder
    b: str
    per_image: Callable[[str], pd.Series | None] | None  # a run id → its per-image scores; None: no bootstrap
    claim: tuple[str, str] | None  # across two folders, the sides' own values; None within one folder


def _across_folders(frame: pd.DataFrame, sides: Sequence[str], metric: str, results: Path, other: pd.DataFrame,
                    other_results: Path) -> _Paired:
    """Side A's runs from ``results``, side B's from ``other_results``, as one frame in which the compared
    key's values name their folder (``unet (results-unet2)``), so that the same cell in both folders pairs.

    Returns:
        :class:`_Paired`, its run ids prefixed ``a:`` / ``b:`` (plain names hold no ``:``), which
        ``per_image`` reads from the side's folder.
    """
    if results.resolve() == other_results.resolve():
        raise ReportError(f"--against {other_results} is the results folder itself: pair within one folder with "
                          f"--paired alone")
    try:
        key, a, _ = paired_sides(frame, [sides[0], sides[0]])
    except ReportError as error:
        raise ReportError(f"A, in {results}: {error}") from None
    try:
        other_key, b, _ = paired_sides(other, [sides[1], sides[1]])
    except ReportError as error:
        raise ReportError(f"B, in {other_results}: {error}") from None
    if key != other_key:
        raise ReportError(f"both sides must vary the same key (value {' '.join(sides)!r})")
    names = (results.name, other_results.name) if results.name != other_results.name else (results, other_results)
    labels = (f"{a} ({names[0]})", f"{b} ({names[1]})")
    parts = [part.loc[part[key] == value].assign(**{key: label, "run_id": prefix + part["run_id"].astype(str)})
             for part, value, label, prefix in ((frame, a, labels[0], "a:"), (other, b, labels[1], "b:"))]
    readers = {"a": per_image_reader(results, metric), "b": per_image_reader(other_results, metric)}
    return _Paired(pd.concat(parts, ignore_index=True), key, *labels,
                   lambda run_id: readers[run_id[0]](run_id[2:]), (a, b))


def _paired_inputs(frame: pd.DataFrame, sides: Sequence[str], metric: str, results: str | Path | None,
                   other: pd.DataFrame | None, other_results: str | Path | None) -> _Paired:
    """:class:`_Paired` for ``--paired A B [--against OTHER]``, references spread over the training keys."""
    frame = one_label(frame)
    if other is not None:
        if results is None or other_results is None:
            raise ReportError("--against: both results folders are needed (their runs' per-image scores)")
        frame, key, a, b, per_image, claim = _across_folders(frame, sides, metric, Path(results),
                                                             one_label(other), Path(other_results))
    else:
        key, a, b = paired_sides(frame, sides)
        per_image, claim = None if results is None else per_image_reader(results, metric), None
    # A reference estimator (no loss, no segmentation) pairs with each trained configuration;
    # not over the key compared (its one value would be paired with itself).
    frame = table_runs(frame, tuple(k for k in ("training", "loss", "matching_score", "segmentation") if k != key))
    return _Paired(frame, key, a, b, per_image, claim)


def paired_numbers(frame: pd.DataFrame, sides: Sequence[str], metric: str, results: str | Path | None = None,
                   other: pd.DataFrame | None = None, other_results: str | Path | None = None) -> pd.DataFrame:
    """:func:`paired_report`'s numbers: :func:`synthcal.eval.statistics.paired_frame`, one row per cell.

    Raises:
        ReportError: as :func:`paired_report`.
    """
    frame, key, a, b, per_image, claim = _paired_inputs(frame, sides, metric, results, other, other_results)
    try:
        return paired_frame(frame, a, b, key, metric, _ALIASES, per_image, claim=claim)
    except ValueError as error:
        raise ReportError(str(error)) from None


def paired_report(frame: pd.DataFrame, sides: Sequence[str], fmt: str, metric: str,
                  results: str | Path | None = None, other: pd.DataFrame | None = None,
                  other_results: str | Path | None = None) -> str:
    """``table --paired A B [--against OTHER]``: per-seed differences A − B per cell with their confidence
    intervals, beside the paper's difference.

    Args:
        results: the results folder, whose ``metrics.csv`` files give the bootstrap
            interval; None: no bootstrap interval.
        other, other_results: ``--against``: side B's runs and their folder (a change of
            settings or code kept in a folder of its own); side A's are read from ``frame``.
            Runs pair on every other key and the seed; the compared key's values name
            their folder, and the paper's figure is that of the sides' own values where
            they differ (``loss=top-mse loss=mse``), none where they are equal.

    Raises:
        ReportError: as :func:`paired_sides`, or no pairs to compare.
    """
    paired = _paired_inputs(frame, sides, metric, results, other, other_results)
    try:
        text = format_paired(paired.frame, paired.a, paired.b, paired.key, fmt, metric, aliases=_ALIASES,
                             per_image=paired.per_image, claim=paired.claim)
    except ValueError as error:
        raise ReportError(str(error)) from None
    return _with_across_note(text, paired, fmt, results, other_results)


def _with_across_note(text: str, paired: _Paired, fmt: str, results: str | Path | None,
                      other_results: str | Path | None) -> str:
    """``text`` with :func:`_across_note` appended to its caption where the sides come from two folders."""
    if paired.claim is None or fmt == "csv":
        return text
    note = _across_note(paired.frame, paired.key, paired.a, paired.b, results, other_results)
    return text.rstrip("\n") + "\n" + wrap_caption(note, fmt) + "\n"


def _across_note(frame: pd.DataFrame, key: str, a: str, b: str, results: str | Path | None,
                 other_results: str | Path | None) -> str:
    """The caption's note on two sides read from two results folders: what else than ``key`` they may differ in."""
    note = (f"Across two results folders: A, {a}, the runs of {results}; B, {b}, the runs of {other_results}. "
            f"Paired on the dataset, seed and the other keys above, A and B also differ in whatever settings "
            f"or code the two folders' runs differ in (each run's run.json records them).")
    only_a, only_b = budget_differences(frame, key, a, b)
    if only_a or only_b:
        def quoted(clauses: list[str]) -> str:
            return ", ".join(f'"{clause}"' for clause in clauses) or "nothing"

        note += (f" The paired runs' recorded training budgets differ: only A's record {quoted(only_a)}; only B's "
                 f"{quoted(only_b)}.")
    return note


def _contrast_inputs(frame: pd.DataFrame, sides: Sequence[str], between: Sequence[str], metric: str,
                     results: str | Path | None, other: pd.DataFrame | None,
                     other_results: str | Path | None) -> tuple[_Paired, str, str, str]:
    """``--paired A B --between C D [--against OTHER]``: :class:`_Paired` for A and B, then ``(between key,
    c, d)``, C and D resolved as ``--paired``'s sides are (model names, ``KEY=VALUE``)."""
    paired = _paired_inputs(frame, sides, metric, results, other, other_results)
    if paired.key in {side.rpartition("=")[0] or "model" for side in between}:
        raise ReportError(f"--between must vary another key than --paired's {paired.key!r} (value "
                          f"{' '.join(between)!r}); e.g. --paired segmentation=ground-truth segmentation=unet "
                          f"--between proposed sha2020")
    try:
        between_key, c, d = paired_sides(paired.frame, between)
    except ReportError as error:
        raise ReportError(f"--between: {error}") from None
    return paired, between_key, c, d


def contrast_numbers(frame: pd.DataFrame, sides: Sequence[str], between: Sequence[str], metric: str,
                     results: str | Path | None = None, other: pd.DataFrame | None = None,
                     other_results: str | Path | None = None) -> pd.DataFrame:
    """:func:`contrast_report`'s numbers: :func:`synthcal.eval.statistics.contrast_frame`, one row per cell.

    Raises:
        ReportError: as :func:`contrast_report`.
    """
    paired, between_key, c, d = _contrast_inputs(frame, sides, between, metric, results, other, other_results)
    try:
        return contrast_frame(paired.frame, paired.a, paired.b, paired.key, c, d, between_key, metric)
    except ValueError as error:
        raise ReportError(str(error)) from None


def contrast_report(frame: pd.DataFrame, sides: Sequence[str], between: Sequence[str], fmt: str, metric: str,
                    results: str | Path | None = None, other: pd.DataFrame | None = None,
                    other_results: str | Path | None = None) -> str:
    """``table --paired A B --between C D [--against OTHER]``: per cell, how much larger the paired difference
    A − B is under C than under D (per seed, then the t interval over seeds) — e.g. whether a UNet's maps cost
    the proposed model more than ``sha2020``.

    Raises:
        ReportError: as :func:`paired_report`, a ``--between`` side no run has, ``--between`` over ``--paired``'s
            key, or no seed with all four runs.
    """
    paired, between_key, c, d = _contrast_inputs(frame, sides, between, metric, results, other, other_results)
    try:
        text = format_contrast(paired.frame, paired.a, paired.b, paired.key, c, d, between_key, fmt, metric)
    except ValueError as error:
        raise ReportError(str(error)) from None
    return _with_across_note(text, paired, fmt, results, other_results)


def budget_differences(frame: pd.DataFrame, key: str, a: str, b: str) -> tuple[list[str], list[str]]:
    """The clauses of the training budgets (:func:`synthcal.eval.runs.training_budget`) that only side A's, or
    only side B's, paired runs record: what else than ``key`` two folders' pairs differ in, as far as the runs
    say (another selection score, train-set cap or resolution — which no pair key shows).

    Args:
        frame: the runs of both sides, ``key`` holding ``a`` or ``b`` (:func:`_across_folders`), with a
            ``budget`` column where the runs recorded one.

    Returns:
        The clauses of A's budgets absent from every B budget it pairs with, and the reverse; sorted, empty
        where the budgets agree or none is recorded.

    >>> runs = pd.DataFrame({"dataset": ["d", "d"], "model": ["m", "m"], "training": ["t", "t"],
    ...     "loss": ["mse", "mse"], "matching_score": ["mse", "mse"], "segmentation": ["g", "g"],
    ...     "profile": ["quick", "quick"], "seed": [0, 0], "selection": ["A", "B"],
    ...     "budget": ["24 epochs; at 128 × 72", "24 epochs; at 128 × 72; fits ranked by validation iou"]})
    >>> budget_differences(runs, "selection", "A", "B")
    ([], ['fits ranked by validation iou'])
    """
    if "budget" not in frame:
        return [], []
    pairs = paired_runs(frame, key, a, b, ["budget"])
    clauses = [[set(str(text).split("; ")) if pd.notna(text) else set() for text in pairs[f"budget_{side}"]]
               for side in ("a", "b")]
    only_a = set().union(*(x - y for x, y in zip(*clauses, strict=True)))
    only_b = set().union(*(y - x for x, y in zip(*clauses, strict=True)))
    return sorted(only_a), sorted(only_b)
