"""A results folder's runs as one CSV, the record that outlives the folder.

A results folder holds each run's record, estimates and per-image scores — too much
to keep in git, and gone with the machine that held it. ``synthcal table RESULTS
--layout runs --format csv`` writes its *runs archive*: one row per finished run, with
the run's keys, seed, the summary of every metric, what validation chose and its
seconds (:func:`runs_archive`). ``synthcal table ARCHIVE.csv`` reads it back
(:func:`read_archive`) and prints every table and report the folder printed, and
pairs its runs with another folder's or archive's (``--paired``, ``--against``). What
an archive cannot give is what needs the runs' files: the bootstrap interval over
test images (its columns stay empty), the template diagnostics and the
all-background floor.

Columns: those of :func:`synthcal.eval.harness.collect_results`, then
:data:`CHOICE_COLUMNS` (:func:`synthcal.eval.reproduction.run_choices`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from synthcal.config import FAILURE_SHARES, METRICS
from synthcal.eval.reproduction import CHOICES, frame_choices

__all__ = ["ARCHIVE_SUFFIX", "CHOICE_COLUMNS", "KEY_COLUMNS", "NUMBER_COLUMNS", "ArchiveError", "is_archive",
           "runs_archive", "read_archive"]

ARCHIVE_SUFFIX = ".csv"
CHOICE_COLUMNS = (*CHOICES, "unet_missed", "seconds")
# Present in every archive (a run without a loss leaves its cell empty, but the column is there).
KEY_COLUMNS = ("dataset", "model", "training", "loss", "matching_score", "segmentation", "profile", "seed",
               "estimator", "dictionary", "status", "run_id")
NUMBER_COLUMNS = (*METRICS, *FAILURE_SHARES.values(), "completeness", "n_images", "n_skipped", "learning_rate",
                  "unet_epochs", "stn_epochs", "seconds")


class ArchiveError(ValueError):
    """A runs archive that cannot be read (the message names the file, and the row and column where one is wrong)."""


def is_archive(source: str | Path) -> bool:
    """Whether ``source`` names a runs archive (a ``.csv`` file) rather than a results folder."""
    return Path(source).suffix.lower() == ARCHIVE_SUFFIX and not Path(source).is_dir()


def runs_archive(frame: pd.DataFrame, results: str | Path | None) -> pd.DataFrame:
    """The runs archive of a results folder's runs: ``frame`` with :data:`CHOICE_COLUMNS` from each run's record
    (kept as they are where ``frame`` has them: an archive read back).

    Args:
        frame: the folder's runs (:func:`synthcal.eval.harness.collect_results`).
        results: the folder, whose records give the choices and seconds (None: missing).

    Returns:
        ``frame``'s columns then :data:`CHOICE_COLUMNS`, sorted by run id (one order
        whatever order the runs finished in); :data:`NUMBER_COLUMNS` as floats.
    """
    choices = frame_choices(frame, results)
    archive = pd.concat([frame.drop(columns=[c for c in CHOICE_COLUMNS if c in frame]), choices], axis=1)
    # Numbers as floats, as read_archive reads them, so that an archive written again is the same bytes.
    numbers = [c for c in NUMBER_COLUMNS if c in archive]
    archive[numbers] = archive[numbers].apply(pd.to_numeric, errors="coerce").astype(float)
    return archive.sort_values("run_id", kind="stable").reset_index(drop=True)


def read_archive(path: str | Path) -> pd.DataFrame:
    """The runs of an archive written by ``synthcal table RESULTS --layout runs --format csv``.

    Returns:
        The frame :func:`runs_archive` wrote: ``seed`` as integers, numbers as floats
        (NaN where empty), ``error`` ``""`` for a run that is ok.

    Raises:
        ArchiveError: no such file, not a CSV, a column of :data:`KEY_COLUMNS` or
            :data:`CHOICE_COLUMNS` missing, or a seed or number that is not one
            (naming the file, row and column), or no runs.
    """
    path = Path(path)
    if not path.is_file():
        raise ArchiveError(f"{path}: no such results folder or runs archive")
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""])
    except (OSError, ValueError, UnicodeDecodeError) as error:
        raise ArchiveError(f"{path}: not a readable CSV ({error})") from None
    missing = [c for c in (*KEY_COLUMNS, *CHOICE_COLUMNS) if c not in frame]
    if missing:
        raise ArchiveError(f"{path}: not a runs archive of `synthcal table --layout runs --format csv`: no column "
                           f"{', '.join(repr(c) for c in missing)}")
    if frame.empty:
        raise ArchiveError(f"{path}: no finished runs")
    frame["seed"] = _numbers(frame, "seed", path, integer=True)
    for column in (c for c in NUMBER_COLUMNS if c in frame):
        frame[column] = _numbers(frame, column, path)
    if "error" in frame:
        frame["error"] = frame["error"].fillna("")
    return frame


def _numbers(frame: pd.DataFrame, column: str, path: Path, integer: bool = False) -> pd.Series:
    """``column`` as numbers; the first value that is not one raises, naming file, row (1 = the header) and column."""
    values = pd.to_numeric(frame[column], errors="coerce")
    bad = values.isna() & frame[column].notna()
    if integer:
        bad |= values.isna() | (values != np.round(values))
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        kind = "an integer" if integer else "a number"
        raise ArchiveError(f"{path}, row {row + 2}, column {column!r}: {frame[column].iloc[row]!r} is not {kind}")
    return values.astype(int) if integer else values.astype(float)
