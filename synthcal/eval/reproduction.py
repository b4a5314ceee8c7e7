"""The reproduction report: one row per cell, its paired difference against ``sha2020``, and a verdict.

A *cell* is one value of each of :data:`CELL_KEYS` — dataset (the table label:
``mixed-<k>`` for a mixed dictionary, ``NAME (pool)`` for a pool dictionary),
training, loss, matching score, segmentation, dictionary, profile and the
estimator's table label (``model``). Per cell :func:`report_frame` gives:

* ``n_seeds``, ``mean`` and ``std`` (ddof = 1) of the reading over the seeds, in
  points (percent for fractions, pixels as they are);
* the paired difference ``model − sha2020`` (:func:`synthcal.eval.statistics.paired_frame`:
  runs of both models on the same split seed, dataset and settings): its mean,
  the 95 % paired t interval ``[t_low, t_high]`` over the seeds, the two-sided p
  of "no difference", the pairs and the seeds where the model scores higher;
* ``paper``: the paper's figure for the cell, and ``paper_difference``, its
  figure minus its Sha et al. figure for the same cell (``synthcal/data/paper_iou.csv``;
  only for readings of the paper's IoU);
* what validation chose per seed (``learning_rates``, ``unet_epochs`` — "–" but with
  the UNet in the loop under ``patience`` —, ``stn_epochs``: the runs'
  ``selection.chosen``, in seed order) and the median seconds per run;
* ``unet_missed``, per seed, the classes the run's kept UNet all but missed on the
  validation split (its record's ``history["unet-missed-classes"]``,
  :class:`synthcal.estimators.paper.MissedClassWarning`): ``3`` or ``1+3``, ``none``,
  or "–" where the run recorded nothing (true maps, no validation split, older code).
  A cell whose UNet lost a class measures a different pipeline from one whose UNet
  did not; the Markdown shows the column wherever a run missed one;
* ``verdict`` (:func:`synthcal.eval.statistics.verdict`, re-exported here).

Verdict rules
-------------
A verdict judges the paper's *claim* for a cell, its difference
``d = paper − paper's sha2020``, with nothing but the 95 % paired t interval
``[lo, hi]`` of our per-seed differences. Taken in this order:

1. no verdict ("–"): the cell is ``sha2020`` itself, the paper has no figure for
   it or for its ``sha2020`` (no claim), or the interval is undefined (fewer than
   two paired seeds);
2. **consistent with the paper**: ``lo ≤ d ≤ hi`` (the interval contains the
   paper's difference), or the interval excludes 0 on the paper's side
   (``d > 0`` and ``lo > 0``, or ``d < 0`` and ``hi < 0``);
3. **opposite**: the interval excludes 0 on the other side (``d > 0`` and
   ``hi < 0``, or ``d < 0`` and ``lo > 0``);
4. **not reproduced**: what is left — the interval contains 0 but not ``d``
   (the paper claims a difference our seeds show no sign of), or ``d = 0`` and the
   interval excludes 0.

Rule 2 comes first, so an interval wide enough to hold both 0 and ``d`` counts
as consistent, but it says so: "consistent with the paper (and with no
difference)" (:data:`UNDECIDED`), because such an interval cannot tell the
paper's claim from no effect; its width and p are printed beside it. The verdict never reads "reproduced": a mean that lands near
the paper's figure proves nothing the interval does not.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from synthcal.config import PIXEL_METRICS, READINGS
from synthcal.eval.statistics import UNDECIDED, VERDICTS, paired_frame, verdict
from synthcal.eval.tables import (
    FORMATS,
    KEYS,
    MISSING,
    PAIR_KEYS,
    order_values,
    paper_figure,
    text_table,
    validate_results,
    wrap_caption,
)

__all__ = ["BASELINE", "CELL_KEYS", "VERDICTS", "UNDECIDED", "verdict", "run_choices", "frame_choices",
           "missed_class_runs", "tied_selection_runs", "report_frame", "format_report"]

BASELINE = "sha2020"
CELL_KEYS = ("dataset", "training", "loss", "matching_score", "segmentation", "dictionary", "profile", "model")
# The CSV's columns after the keys (the Markdown shows them in words).
NUMBERS = ("n_seeds", "mean", "std", "difference", "t_low", "t_high", "p", "n_pairs", "wins", "paper",
           "paper_difference", "learning_rates", "unet_epochs", "unet_missed", "stn_epochs", "seconds", "verdict")
CHOICES = ("learning_rate", "unet_epochs", "stn_epochs")


def _record(results: Path, run_id: str) -> dict[str, Any]:
    try:
        record = json.loads((results / "runs" / run_id / "run.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return record if isinstance(record, dict) else {}


def _missed_classes(record: Mapping[str, Any]) -> str | float:
    """The classes the run's kept UNet all but missed: ``"3"``, ``"1+3"``, ``"none"`` (NaN: not recorded)."""
    classes = (record.get("history") or {}).get("unet-missed-classes")
    if not isinstance(classes, list):
        return np.nan
    return "+".join(str(k) for k in classes) or "none"


def run_choices(results: str | Path | None, run_ids: pd.Series) -> pd.DataFrame:
    """Per run: what validation chose, the classes its UNet missed and its seconds, from its record.

    Args:
        results: the results folder (None: every value missing).
        run_ids: run ids (``RESULTS/runs/<id>/run.json``).

    Returns:
        DataFrame indexed like ``run_ids`` with :data:`CHOICES`, ``unet_missed``
        (:func:`report_frame`) and ``seconds`` (NaN where the record lacks them or
        cannot be read).
    """
    rows = []
    for run_id in run_ids:
        record = {} if results is None or pd.isna(run_id) else _record(Path(results), str(run_id))
        chosen = (record.get("selection") or {}).get("chosen") or {}
        seconds = record.get("seconds")
        rows.append({**{key: chosen.get(key, np.nan) for key in CHOICES}, "unet_missed": _missed_classes(record),
                     "seconds": float(seconds) if isinstance(seconds, (int, float)) else np.nan})
    return pd.DataFrame(rows, index=run_ids.index, columns=[*CHOICES, "unet_missed", "seconds"])


def frame_choices(frame: pd.DataFrame, results: str | Path | None) -> pd.DataFrame:
    """:func:`run_choices` of the frame's runs, or the frame's own columns where it has them (a runs archive),
    indexed like ``frame``."""
    columns = [*CHOICES, "unet_missed", "seconds"]
    if set(columns) <= set(frame.columns):
        return frame[columns]
    return run_choices(results, frame.get("run_id", pd.Series(np.nan, frame.index)))


def missed_class_runs(results: str | Path, frame: pd.DataFrame) -> list[str]:
    """One line per run whose kept UNet all but missed a class (its record's ``history["unet-missed-classes"]``).

    ``bench`` and ``table`` print them after the tables, as they print failed runs: the
    warning the run's process gave scrolls by among the progress bars of a sweep.

    Args:
        results: the results folder (unread where the frame holds ``unet_missed``: a runs archive).
        frame: its runs (:func:`synthcal.eval.harness.collect_results`; no ``run_id``: no line).

    Returns:
        ``"UNet missed class 3: <run id> (…)"`` lines, in the frame's order.
    """
    lines: list[str] = []
    if "run_id" not in frame:
        return lines
    missed_per_run = frame_choices(frame, results)["unet_missed"]
    for run_id, missed in zip(frame["run_id"].astype(str), missed_per_run, strict=True):
        if isinstance(missed, str) and missed != "none":
            lines.append(f"UNet missed class {missed.replace('+', ', ')}: {run_id} (docs/decisions.md, "
                         f"\"The UNet's loss\")")
    return lines


def tied_selection_runs(results: str | Path, frame: pd.DataFrame) -> list[str]:
    """One line per run whose validation scored every candidate of a grid alike: its choice is a tie, not a
    preference (its record's ``selection["scores"]``, compared exactly).

    A model whose validation loss no longer depends on the setting (mixed-5's collapsed STNs: every learning
    rate ends on the same loss to the last digit, docs/reproduction.md) still reports a "chosen" rate and
    epoch; ``bench`` and ``table`` say so after the tables, as for failed runs.

    Args:
        results: the results folder (a runs archive keeps no scores: no line).
        frame: its runs (:func:`synthcal.eval.harness.collect_results`; no ``run_id``: no line).

    Returns:
        ``"validation could not tell the learning_rate values apart (…): <run id> (…)"`` lines, in the frame's order.
    """
    lines: list[str] = []
    if "run_id" not in frame or not Path(results).is_dir():
        return lines
    for run_id in frame["run_id"].astype(str):
        scores = ((_record(Path(results), run_id).get("selection") or {}).get("scores") or {})
        for key, values in scores.items() if isinstance(scores, dict) else ():
            if isinstance(values, list) and len(values) > 1 and len(set(map(repr, values))) == 1:
                lines.append(f"validation could not tell the {key} values apart (each scored {values[0]!r}): "
                             f"{run_id} (its chosen {key} is a tie; docs/reproduction.md, mixed-5)")
    return lines


def _per_seed(values: pd.Series) -> str:
    """Values in seed order as ``a, b, …`` ("–" for none recorded)."""
    if values.isna().all():
        return MISSING
    return ", ".join(MISSING if pd.isna(v) else v if isinstance(v, str) else f"{v:g}" for v in values)


def _misses_a_class(per_seed: str) -> bool:
    """Whether a cell's ``unet_missed`` names a class on some seed."""
    return any(value not in (MISSING, "none") for value in per_seed.split(", "))


def _paper_figures(cells: pd.DataFrame, aliases: Mapping[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's paper figure and the paper's figure minus its sha2020 figure for the same keys (NaN: none)."""
    records = cells[list(KEYS)].to_dict("records")
    figures = np.array([paper_figure(c, aliases) for c in records], dtype=float)
    baseline = np.array([paper_figure(dict(c, model=BASELINE), aliases) for c in records], dtype=float)
    differences = np.where([c["model"] == BASELINE for c in records], np.nan, figures - baseline)
    return figures, differences


def _differences(frame: pd.DataFrame, value: str, aliases: Mapping[str, str]) -> pd.DataFrame:
    """Paired ``model − sha2020`` per cell for every model with pairs (none: an empty frame)."""
    others = [k for k in PAIR_KEYS if k != "model"]
    pieces = []
    if BASELINE in set(frame["model"]):
        for model in [m for m in dict.fromkeys(frame["model"]) if m != BASELINE]:
            try:
                cells = paired_frame(frame, model, BASELINE, "model", value, aliases)
            except ValueError:  # no seed and settings with both: "–" in its rows
                continue
            pieces.append(cells.assign(model=model))
    columns = [*others, "model", "mean", "t_low", "t_high", "p", "n_pairs", "a_wins"]
    frame = pd.DataFrame(columns=columns) if not pieces else pd.concat(pieces, ignore_index=True)[columns]
    return frame.rename(columns={"mean": "difference", "a_wins": "wins"})


def report_frame(frame: pd.DataFrame, value: str = "iou", results: str | Path | None = None,
                 aliases: Mapping[str, str] | None = None) -> pd.DataFrame:
    """The reproduction report as numbers, one row per cell (module docstring).

    Args:
        frame: per-run results (:func:`synthcal.eval.harness.collect_results`, references
            already spread over the training keys: :func:`synthcal.eval.harness.table_runs`).
        value: the reading.
        results: the results folder, whose records give the choices and times (None: "–"), unless the
            frame holds them (a runs archive, :mod:`synthcal.eval.archive`).
        aliases: our dataset label → the paper's.

    Returns:
        DataFrame with :data:`CELL_KEYS` then :data:`NUMBERS`, in the paper's order;
        ``attrs["value"]`` the reading.
    """
    aliases = aliases or {}
    checked = validate_results(frame, value, PAIR_KEYS)
    checked["dictionary"] = (frame["dictionary"].fillna("split").astype(str) if "dictionary" in frame else "split")
    choices = frame_choices(frame, results).set_axis(checked.index)
    checked = pd.concat([checked.drop(columns=list(choices.columns), errors="ignore"), choices],
                        axis=1).sort_values("seed", kind="stable")
    scale = 1.0 if value in PIXEL_METRICS else 100.0
    grouped = checked.groupby(list(CELL_KEYS), sort=False)
    with np.errstate(invalid="ignore"):
        cells = grouped[value].agg(n_seeds="count", mean="mean", std=lambda x: x.std(ddof=1)).reset_index()
    cells[["mean", "std"]] *= scale
    chosen = grouped.agg(learning_rates=("learning_rate", _per_seed), unet_epochs=("unet_epochs", _per_seed),
                         unet_missed=("unet_missed", _per_seed), stn_epochs=("stn_epochs", _per_seed),
                         seconds=("seconds", "median")).reset_index()
    cells = cells.merge(chosen, on=list(CELL_KEYS), how="left")
    cells = cells.merge(_differences(checked, value, aliases), on=list(PAIR_KEYS), how="left")
    if value in READINGS:
        cells["paper"], cells["paper_difference"] = _paper_figures(cells, aliases)
    else:
        cells["paper"] = cells["paper_difference"] = np.nan
    cells["verdict"] = [verdict(lo, hi, d) for lo, hi, d in
                        zip(cells["t_low"], cells["t_high"], cells["paper_difference"], strict=True)]
    orders = [{v: i for i, v in enumerate(order_values(cells[k].astype(str), k, "models"))} for k in CELL_KEYS]
    position = [tuple(o[str(v)] for o, v in zip(orders, row, strict=True))
                for row in cells[list(CELL_KEYS)].itertuples(index=False)]
    cells = cells.iloc[sorted(range(len(cells)), key=position.__getitem__)].reset_index(drop=True)
    cells[["n_pairs", "wins"]] = cells[["n_pairs", "wins"]].astype("Int64")
    out = cells[[*CELL_KEYS, *NUMBERS]]
    out.attrs["value"] = value
    return out


# --- text ------------------------------------------------------------------------------


def _number(value: float, signed: bool = False) -> str:
    return MISSING if pd.isna(value) else f"{value:+.2f}" if signed else f"{value:.2f}"


def _row_text(row: Mapping[str, Any], unet: bool, missed: bool) -> list[str]:
    """The display cells after the keys (``unet``: with the UNet's epochs; ``missed``: its missed classes)."""
    spread = "" if row["n_seeds"] < 2 or pd.isna(row["std"]) else f" ± {row['std']:.2f}"
    interval = MISSING if pd.isna(row["t_low"]) else f"[{row['t_low']:+.2f}, {row['t_high']:+.2f}]"
    p = MISSING if pd.isna(row["p"]) else "< 0.001" if row["p"] < 0.001 else f"{row['p']:.3f}"
    wins = MISSING if pd.isna(row["n_pairs"]) else f"{row['wins']} of {row['n_pairs']}"
    seconds = MISSING if pd.isna(row["seconds"]) else f"{row['seconds']:.0f}"
    return [str(row["n_seeds"]), _number(row["mean"]) + ("" if pd.isna(row["mean"]) else spread),
            _number(row["difference"], True), interval, p, wins, _number(row["paper"]),
            _number(row["paper_difference"], True), row["learning_rates"], *([row["unet_epochs"]] if unet else []),
            *([row["unet_missed"]] if missed else []), row["stn_epochs"], seconds, row["verdict"]]


# "> sha2020", not "wins": for a pixel reading a higher value is a worse one
HEADER = ("n", "mean ± std", f"− {BASELINE}", "95 % CI (t)", "p", f"> {BASELINE}", "paper", f"paper − {BASELINE}",
          "lr (per seed)", "STN epochs (per seed)", "s/run", "verdict")
UNET_HEADER = "UNet epochs (per seed)"  # before the STN's, shown where a row's runs kept a UNet epoch
MISSED_HEADER = "UNet missed (per seed)"  # after it, shown where a row's UNet all but missed a class


def report_caption(value: str, constants: Mapping[str, str]) -> str:
    """What the report's columns hold and how a verdict is reached."""
    unit = "px" if value in PIXEL_METRICS else "%"
    text = (f"{value} ({unit}): mean ± std over seeds (ddof = 1). − {BASELINE}: mean over seeds of the per-seed "
            f"difference against {BASELINE} run on the same split seed and settings; 95 % CI (t): paired t interval; "
            f"p: its two-sided test of no difference; > {BASELINE}: seeds where the row's value is higher (for a "
            f"pixel reading: worse). paper: the published "
            f"figure (a UNet's segmentation, the paper's own training; SPEC §7), paper − {BASELINE}: its difference "
            f"for the same cell. lr, UNet / STN epochs: what validation chose, per seed in seed order; s/run: median "
            f"seconds of a run. UNet missed: the classes a run's UNet all but missed on the validation split, as it "
            f"warned (none; – not recorded), shown where a run missed one. "
            f"Verdict, from the 95 % CI [lo, hi] and the paper's difference d only: consistent "
            f"with the paper if lo ≤ d ≤ hi or the CI excludes 0 on d's side ('and with no difference' when it also "
            f"holds 0); opposite if it excludes 0 on the "
            f"other side; not reproduced otherwise (the CI holds 0 but not d); – without a claim or a CI.")
    if constants:
        text += " " + "; ".join(f"{k}: {v}" for k, v in constants.items()) + "."
    return text


def format_report(report: pd.DataFrame, fmt: str = "md") -> str:
    """:func:`report_frame` as Markdown, LaTeX or CSV (the numbers, re-readable with pandas).

    Markdown and LaTeX show the keys that vary among the rows (dataset and model
    always), the others in the caption.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; one of {FORMATS}")
    if fmt == "csv":
        return report.to_csv(index=False)
    shown = [k for k in CELL_KEYS if k in ("dataset", "model") or report[k].nunique() > 1]
    constants = {k: str(report[k].iloc[0]) for k in CELL_KEYS if k not in shown and report[k].iloc[0] != MISSING}
    unet = bool((report["unet_epochs"] != MISSING).any())
    missed = bool(report["unet_missed"].map(_misses_a_class).any())
    header = [*shown, *HEADER]
    at = header.index("STN epochs (per seed)")
    header[at:at] = [*([UNET_HEADER] if unet else []), *([MISSED_HEADER] if missed else [])]
    body = [[str(row[k]) for k in shown] + _row_text(row, unet, missed) for row in report.to_dict("records")]
    caption = wrap_caption(report_caption(str(report.attrs.get("value", "iou")), constants), fmt)
    return text_table(header, body, "l" * len(shown) + "r" * (len(header) - len(shown) - 1) + "l", caption, fmt)
