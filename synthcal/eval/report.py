"""The text of ``synthcal table``: the results tables, or the paired differences of two sides.

:func:`results_tables` splits a results frame by segmentation and profile and
formats one table per part and layout (:func:`synthcal.eval.tables.format_table`);
:func:`paired_report` reads the two sides of ``--paired A B`` (:func:`paired_sides`)
and formats their per-seed differences (:func:`synthcal.eval.tables.format_paired`).
A request the results cannot answer raises :class:`ReportError`, one line for the user.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import pandas as pd

from synthcal.eval.harness import table_runs
from synthcal.eval.tables import PAIR_KEYS, format_paired, format_table

__all__ = ["ReportError", "results_tables", "split_by", "paired_sides", "paired_report"]

# Tables name the soccer dataset as the paper does.
_ALIASES = {"soccer": "worldcup2014"}


class ReportError(ValueError):
    """The results cannot answer the request (no runs, a side absent, a layout without rows)."""


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
                   metric: str) -> Iterator[str]:
    """The tables of a results frame, one per segmentation / profile in it, each after its title (one block each).

    A generator: the blocks before a failing layout come out before the error.

    Args:
        frame: the results (:func:`synthcal.eval.harness.collect_results`).
        layout: a layout of :func:`format_table`; None picks ``models`` for own-dictionary
            datasets and ``mixed`` for mixed ones, each where there are results.
        fmt: ``md``, ``latex`` or ``csv`` (no titles in CSV).
        compare_paper: add the published figures.
        metric: the column shown.

    Raises:
        ReportError: no finished runs, or a layout the results cannot fill.
    """
    if frame.empty:
        raise ReportError("no finished runs in the results folder")
    frame = table_runs(frame)
    for title, part in split_by(frame, ("segmentation", "profile")):
        mixed = part["dataset"].str.startswith("mixed-")
        layouts = [layout] if layout else [name for name, rows in (("models", ~mixed), ("mixed", mixed)) if rows.any()]
        for name in layouts:
            if title and fmt != "csv":
                yield f"{'%' if fmt == 'latex' else '###'} {title}\n"
            try:
                table = format_table(part, name, fmt, value=metric, compare_paper=compare_paper, aliases=_ALIASES)
            except ValueError as error:
                raise ReportError(f"table {name!r}: {error}") from None
            yield table


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


def paired_report(frame: pd.DataFrame, sides: Sequence[str], fmt: str, metric: str) -> str:
    """``table --paired A B``: per-seed differences A − B per cell, beside the paper's difference.

    Raises:
        ReportError: as :func:`paired_sides`, or no pairs to compare.
    """
    key, a, b = paired_sides(frame, sides)
    try:
        # A reference estimator (no loss, no segmentation) pairs with each trained configuration;
        # not over the key compared (its one value would be paired with itself).
        frame = table_runs(frame, tuple(k for k in ("training", "loss", "matching_score", "segmentation") if k != key))
        return format_paired(frame, a, b, key, fmt, metric, aliases=_ALIASES)
    except ValueError as error:
        raise ReportError(str(error)) from None
