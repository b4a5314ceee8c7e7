"""The paper's three result tables, built from per-run results (SPEC §8).

Input schema (one row per run, "tidy")
--------------------------------------
A run is one estimator configuration evaluated on one dataset with one split seed.

=================  ======  ==========================================================
column             needed  meaning
=================  ======  ==========================================================
``dataset``        yes     the paper's label: ``worldcup2014``, ``intersection-1`` …
                           for a target's own dictionary, ``mixed-<k>`` for target
                           ``intersection-<k>`` with a mixed dictionary (SPEC §6)
``model``          yes     ``proposed``, ``sha2020`` (the baseline), ``template``,
                           ``identity``, ``ecc`` or a plug-in's name
``training``       no      ``end-to-end`` or ``step-by-step``
``loss``           no      ``mse``, ``dice``, ``top-mse``, ``top-dice``
``matching_score`` no      ``mse`` or ``top-mse``
``seed``           yes     the split seed (the five cycles: 0–4)
``iou`` …          yes     the mean over the run's test images of a metric of
                           :func:`synthcal.eval.scoring.evaluate`, a fraction in
                           [0, 1] (failures counted as 0); pick it with ``value``;
                           a pixel error (``reproj_px``, ``corner_error``: the run's
                           median in pixels) is shown as it is, the lowest mean bold
``completeness``   no      share of the run's test images with a valid estimate
                           (a fraction; shown "–" where missing)
``profile``        no      the profile the run was trained under (caption)
``segmentation``   no      ``unet`` or ``ground-truth`` (caption)
``dictionary``     no      ``split`` or ``pool``: what the run searched (caption)
``budget``         no      the run's training budget in words
                           (:func:`synthcal.eval.runs.training_budget`; caption)
=================  ======  ==========================================================

A missing optional column, or a missing value (estimators without training or
loss), is shown as "–"; a key that is missing in every run of a table (a table of
estimators that do not train has no training, loss or matching score) is left out
of it, caption included. Two rows with the same keys and seed are an error.

Layouts (the paper's ``table`` values in ``paper_iou.csv``)
-----------------------------------------------------------
``matching``  own-dictionary datasets; one column per matching score.
``models``    own-dictionary datasets; one column per model.
``mixed``     mixed-dictionary datasets (``mixed-*``); one column per model.

The rows are ``dataset`` followed by every other key that takes more than one
value among the selected runs (so the paper's data gives rows dataset × training
× loss in all three); keys with a single value are stated in the caption. Values
appear in the paper's order (first appearance in ``paper_iou.csv``, the
layout's own table first, so the baseline ``sha2020`` precedes ``proposed`` as in
the paper's model tables), then unknown values alphabetically, "–" last.

Cells
-----
Beside every column, its completeness in percent (mean over seeds, 1 decimal):
a mean IoU is only comparable with the share of images it counts as valid.
IoU in percent, ``mean ± std`` over seeds with 2 decimals. ``std`` is the sample
standard deviation (``ddof = 1``): the five seeds are five draws of the split,
and the spread of *those draws* is what a reader compares against; a single
seed shows the mean alone. The highest mean of a row (compared as displayed,
so ties share it) is bold — Markdown ``**…**``, LaTeX ``\\textbf{…}`` — when the
row has at least two values and the highest is above 0 (a row of zeros, every run
failed, has no best). ``compare_paper=True`` adds the published figure
beside each column ("paper"), joined on every key; the paper's IoU is undefined
beyond its prose, so the comparison is offered for each of its three readings
(``iou``, ``iou_bg``, ``iou_weighted``; SPEC §8), and the caption names the
reading shown. The caption also says under what our figures were obtained —
profile, segmentation (a UNet's or the true maps) and training budget, from the
optional columns — and, with ``compare_paper``, that the paper's come from a UNet's
segmentation and its own full training.

Paired differences
------------------
:func:`paired_frame` / :func:`format_paired`: two models (or two values of another
key) trained on the same split of the same seed with the same settings are a
pair; per cell, the mean of the per-seed differences A − B in points, its
standard deviation (ddof = 1), the seeds where A > B, and the paper's A − B for
the same cell.

Example
-------
>>> import pandas as pd
>>> runs = pd.DataFrame({"dataset": "intersection-1", "model": "proposed", "training": "end-to-end",
...                      "loss": "top-mse", "matching_score": ["mse", "mse", "top-mse", "top-mse"],
...                      "seed": [0, 1, 0, 1], "iou": [0.80, 0.82, 0.84, 0.86]})
>>> text = format_table(runs, "matching")
>>> for line in text.splitlines()[:3]:
...     print(line)
| dataset | mse | mse (complete %) | top-mse | top-mse (complete %) |
|:---|---:|---:|---:|---:|
| intersection-1 | 81.00 ± 1.41 | – | **85.00 ± 1.41** | – |
>>> text.splitlines()[-1].split(". ")[-1]
'model: proposed; training: end-to-end; loss: top-mse.'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

import numpy as np
import pandas as pd

from synthcal.config import DESCRIPTIONS, PIXEL_METRICS, READINGS

__all__ = ["KEYS", "MISSING", "Layout", "LAYOUTS", "paper_results", "aggregate", "table_frame", "format_table",
           "failed_runs", "PAIR_KEYS", "paired_frame", "format_paired"]

KEYS = ("dataset", "model", "training", "loss", "matching_score")
# Keys that must agree for two runs to be a pair (besides the seed): the table keys and
# what a run was obtained under.
PAIR_KEYS = (*KEYS, "segmentation", "profile")
# The caption's words for a segmentation value.
SEGMENTATION_WORDS = {"unet": "a UNet's segmentation", "ground-truth": "the true semantic maps (ground-truth)"}
# The caption's words for a dictionary value (synthcal.eval.runs: Run.dictionary).
DICTIONARY_WORDS = {"split": "the seed's drawn dictionary", "pool": "the whole pool outside the seed's train and test "
                    "sets (rows NAME (pool))"}
REQUIRED = ("dataset", "model", "seed")
MISSING = "–"
FORMATS = ("md", "latex", "csv")


@dataclass(frozen=True)
class Layout:
    """One of the paper's tables.

    Attributes:
        columns: the key spread over the columns.
        mixed: True for mixed-dictionary datasets (``mixed-*``), False for the others.
        title: what the table compares.
    """

    columns: str
    mixed: bool
    title: str


LAYOUTS: dict[str, Layout] = {
    "matching": Layout("matching_score", False, "matching scores"),
    "models": Layout("model", False, "Sha et al.'s baseline and the proposed model"),
    "mixed": Layout("model", True, "models with mixed dictionaries"),
}


@lru_cache(maxsize=1)
def paper_results() -> pd.DataFrame:
    """The paper's published IoU figures (``synthcal/data/paper_iou.csv``).

    Returns:
        DataFrame with columns ``table``, the five keys and ``iou_percent``.
    """
    with resources.files("synthcal").joinpath("data/paper_iou.csv").open("r", encoding="utf-8") as f:
        return pd.read_csv(f)


def _validate(results: pd.DataFrame, value: str, keys: tuple[str, ...] = KEYS) -> pd.DataFrame:
    """The results with every key present (missing values as "–", as text), the value and completeness
    as numbers; one run per keys and seed."""
    missing = [c for c in (*REQUIRED, value) if c not in results.columns]
    if missing:
        raise ValueError(f"results lack column(s) {missing}; have {list(results.columns)}")
    frame = results.copy()
    for key in keys:
        frame[key] = frame[key].astype(object).where(frame[key].notna(), MISSING) if key in frame else MISSING
        frame[key] = frame[key].astype(str)
    values = pd.to_numeric(frame[value], errors="raise")
    if value in PIXEL_METRICS:  # pixels, shown as they are; inf where most of a run's images failed
        if (values < 0).any():
            raise ValueError(f"column {value!r} is a distance in pixels, never negative")
    elif ((values < 0) | (values > 1)).any():
        raise ValueError(f"column {value!r} must be a fraction in [0, 1] (tables convert to percent)")
    frame[value] = values
    frame["completeness"] = (pd.to_numeric(frame["completeness"], errors="raise") if "completeness" in frame
                             else np.nan)
    duplicated = frame.duplicated([*keys, "seed"], keep=False)
    if duplicated.any():
        raise ValueError(f"several results for the same keys and seed:\n{frame.loc[duplicated, [*keys, 'seed']]}")
    return frame


def aggregate(results: pd.DataFrame, value: str = "iou") -> pd.DataFrame:
    """Mean, standard deviation (ddof = 1) and count over seeds, in percent.

    Args:
        results: per-run results (module docstring).
        value: the metric column.

    Returns:
        DataFrame with the five keys and ``mean``, ``std`` (NaN for one seed),
        ``n_seeds``, ``completeness`` (mean over seeds; NaN where the results have
        none).
    """
    frame = _validate(results, value)
    grouped = frame.groupby(list(KEYS), sort=False)
    with np.errstate(invalid="ignore"):  # a pixel error's inf (a failed run median) has no std: NaN, not a warning
        out = grouped[value].agg(mean="mean", std=lambda x: x.std(ddof=1), n_seeds="count")
    out["completeness"] = grouped["completeness"].mean()
    out = out.reset_index()
    out[["mean", "std", "completeness"] if value not in PIXEL_METRICS else ["completeness"]] *= 100.0
    return out


def _order(values: pd.Series, key: str, layout: str) -> list[str]:
    """Distinct values in the paper's order (this layout's table first), then the others sorted, "–" last."""
    paper = paper_results()
    paper = pd.concat([paper[paper["table"] == layout], paper[paper["table"] != layout]])
    paper = list(dict.fromkeys(paper[key].astype(str))) if key in paper else []  # segmentation, profile: none
    present = set(values)
    known = [v for v in paper if v in present]
    rest = sorted(present - set(known) - {MISSING})
    return known + rest + ([MISSING] if MISSING in present else [])


def _with_paper(
    table: pd.DataFrame, varying: list[str], column_key: str, constants: dict, aliases: Mapping[str, str]
) -> pd.DataFrame:
    """Add a ``paper`` field to every cell of the grid, ours present or not."""
    paper = paper_results().drop_duplicates(list(KEYS))
    lookup = {tuple(map(str, key)): value
              for key, value in zip(paper[list(KEYS)].itertuples(index=False), paper["iou_percent"], strict=True)}
    column_values = list(dict.fromkeys(table.columns.get_level_values(0)))
    out = {}
    for value in column_values:
        figures = []
        for row in table.index:
            key = dict(constants, **dict(zip(varying, row if isinstance(row, tuple) else (row,), strict=True)))
            key[column_key] = value
            key["dataset"] = aliases.get(key["dataset"], key["dataset"])
            figures.append(lookup.get(tuple(key[k] for k in KEYS), np.nan))
        out[value] = pd.concat([table[value], pd.Series(figures, index=table.index, name="paper")], axis=1)
    return pd.concat(out, axis=1)


def table_frame(
    results: pd.DataFrame,
    layout: str,
    value: str = "iou",
    compare_paper: bool = False,
    aliases: Mapping[str, str] | None = None,
) -> pd.DataFrame:
    """One of the paper's tables as numbers.

    Args:
        results: per-run results (module docstring).
        layout: ``matching``, ``models`` or ``mixed``.
        value: the metric column (the paper's IoU is one of :data:`READINGS`).
        compare_paper: add the published figure (column ``paper``).
        aliases: our dataset label → the paper's, for the join only (e.g.
            ``{"soccer": "worldcup2014"}``).

    Returns:
        DataFrame indexed by the row keys, with column MultiIndex
        ``(column value, field)``, fields ``mean``, ``std``, ``n_seeds``,
        ``completeness`` and optionally ``paper``; ``attrs["constants"]`` holds the
        single-valued keys, ``attrs["layout"]`` the layout name, ``attrs["value"]``
        the metric.
    """
    if layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; one of {sorted(LAYOUTS)}")
    if compare_paper and value not in READINGS:
        raise ValueError(f"the paper reports only its IoU (the readings {', '.join(READINGS)}), not {value!r}")
    spec = LAYOUTS[layout]
    cells = aggregate(results, value)
    cells = cells[cells["dataset"].str.startswith("mixed-") == spec.mixed]
    if cells.empty:
        kind = "mixed-dictionary (mixed-*)" if spec.mixed else "own-dictionary"
        raise ValueError(f"no {kind} results for layout {layout!r}")
    fields = ["mean", "std", "n_seeds", "completeness"]
    varying = [k for k in KEYS if k != spec.columns and (k == "dataset" or cells[k].nunique() > 1)]
    constants = {k: cells[k].iloc[0] for k in KEYS if k != spec.columns and k not in varying}
    # Keys are unique per cell after aggregation, so unstacking loses nothing.
    table = cells.set_index([*varying, spec.columns])[fields].unstack(spec.columns).swaplevel(0, 1, axis=1)
    column_order = _order(cells[spec.columns], spec.columns, layout)
    table = table.reindex(columns=pd.MultiIndex.from_product([column_order, fields]))
    row_order = [_order(cells[k], k, layout) for k in varying]
    present = set(map(tuple, cells[varying].to_numpy()))
    rows = [r for r in pd.MultiIndex.from_product(row_order) if tuple(r) in present]
    index = (pd.MultiIndex.from_tuples(rows, names=varying) if len(varying) > 1
             else pd.Index([r[0] for r in rows], name=varying[0]))
    table = table.reindex(index)
    if compare_paper:
        table = _with_paper(table, varying, spec.columns, constants, aliases or {})
    table.columns.names = [spec.columns, "field"]
    table.attrs.update(constants=constants, layout=layout, n_seeds=sorted(cells["n_seeds"].unique().tolist()),
                       value=value, conditions=_conditions(results, spec.mixed))
    return table


def _distinct(results: pd.DataFrame, column: str) -> list[str]:
    """The column's distinct present values in order of appearance (none if there is no such column)."""
    if column not in results:
        return []
    return [str(v) for v in dict.fromkeys(results[column].dropna())]


def _conditions(results: pd.DataFrame, mixed: bool) -> dict[str, list[str]]:
    """Profile, segmentation and training budget of the runs a layout shows (caption)."""
    if "dataset" in results:
        results = results[results["dataset"].astype(str).str.startswith("mixed-") == mixed]
    return {"profile": _distinct(results, "profile"), "segmentation": _distinct(results, "segmentation"),
            "dictionary": _distinct(results, "dictionary"), "budget": _distinct(results, "budget")}


# --- text ------------------------------------------------------------------------------


def _cell(mean: float, std: float, n: float) -> str:
    if pd.isna(mean):
        return MISSING
    return f"{mean:.2f}" if n < 2 or pd.isna(std) else f"{mean:.2f} ± {std:.2f}"


def _latex_escape(text: str) -> str:
    replacements = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                    "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                    "±": r"$\pm$", "–": "--", "—": "---", "−": "$-$", "×": r"$\times$",
                    ">": "$>$", "<": "$<$"}
    return "".join(replacements.get(ch, ch) for ch in text)


def _text_grid(table: pd.DataFrame) -> tuple[list[str], list[list[str]], list[list[bool]]]:
    """Header, display cells and bold flags (row keys first, repeated keys blanked)."""
    column_values = list(dict.fromkeys(table.columns.get_level_values(0)))
    compare = "paper" in table.columns.get_level_values(1)
    header = list(table.index.names)
    for value in column_values:
        header += [value, f"{value} (complete %)"] + ([f"{value} (paper)"] if compare else [])
    body, bold, previous = [], [], None
    for key, row in table.iterrows():
        key = key if isinstance(key, tuple) else (key,)
        shown = [k if previous is None or key[: i + 1] != previous[: i + 1] else "" for i, k in enumerate(key)]
        previous = key
        means = np.array([round(row[(v, "mean")], 2) for v in column_values], dtype=float)
        # Nothing to single out in a row of one value, or of zeros (every run failed); pixel errors: lowest.
        if table.attrs.get("value") in PIXEL_METRICS:
            best = np.nanmin(means) if (~np.isnan(means)).sum() >= 2 and np.isfinite(np.nanmin(means)) else np.nan
        else:
            best = np.nanmax(means) if np.isfinite(means).sum() >= 2 and np.nanmax(means) > 0 else np.nan
        cells, flags = list(shown), [False] * len(shown)
        for value, mean in zip(column_values, means, strict=True):
            cells.append(_cell(row[(value, "mean")], row[(value, "std")], row[(value, "n_seeds")]))
            flags.append(bool(mean == best))
            complete = row[(value, "completeness")]
            cells.append(MISSING if pd.isna(complete) else f"{complete:.1f}")
            flags.append(False)
            if compare:
                paper = row[(value, "paper")]
                cells.append(MISSING if pd.isna(paper) else f"{paper:.2f}")
                flags.append(False)
        body.append(cells)
        bold.append(flags)
    return header, body, bold


def _caption(table: pd.DataFrame) -> str:
    seeds = table.attrs.get("n_seeds", [])
    n = str(seeds[0]) if len(seeds) == 1 else f"{min(seeds)}–{max(seeds)}" if seeds else "?"
    columns = table.columns.names[0]
    value = table.attrs.get("value", "iou")
    reading = f" — {DESCRIPTIONS[value]}" if value in DESCRIPTIONS else ""
    unit = "px" if value in PIXEL_METRICS else "%"
    text = (f"{value} ({unit}){reading}; by {columns}, mean ± std over {n} seeds (std with ddof = 1); best per row in "
            f"bold; complete %: share of test images with a valid estimate, mean over seeds.")
    # A key missing in every run (estimators that do not train have no loss) says nothing: left out.
    constants = {k: v for k, v in table.attrs.get("constants", {}).items() if v != MISSING}
    if constants:
        text += " " + "; ".join(f"{k}: {v}" for k, v in constants.items()) + "."
    text += _conditions_text(table.attrs.get("conditions", {}))
    if "paper" in table.columns.get_level_values(-1):
        text += (" Paper: the published figure, from a UNet's segmentation and the paper's own full training"
                 " (SPEC §7).")
    return text


def _conditions_text(conditions: Mapping[str, list[str]]) -> str:
    """`` Ours: profile …; segmentation …; training ….`` from what the results record ("" if nothing)."""
    parts = []
    if conditions.get("profile"):
        parts.append("profile " + ", ".join(conditions["profile"]))
    if conditions.get("segmentation"):
        parts.append("segmentation: " + ", ".join(SEGMENTATION_WORDS.get(v, v) for v in conditions["segmentation"]))
    if set(conditions.get("dictionary", ())) - {"split"}:  # said once some run searched the pool
        parts.append("dictionary: " + " | ".join(DICTIONARY_WORDS.get(v, v) for v in conditions["dictionary"]))
    if conditions.get("budget"):
        parts.append("training: " + " | ".join(conditions["budget"]))
    return f" Ours: {'; '.join(parts)}." if parts else ""


def format_table(
    results: pd.DataFrame,
    layout: str,
    fmt: str = "md",
    value: str = "iou",
    compare_paper: bool = False,
    aliases: Mapping[str, str] | None = None,
) -> str:
    """One of the paper's tables as Markdown, LaTeX or CSV text.

    Args:
        results: per-run results (module docstring).
        layout: ``matching``, ``models`` or ``mixed``.
        fmt: ``md``, ``latex`` or ``csv`` (long form: the row keys, the column key,
            ``mean``, ``std``, ``n_seeds``, ``completeness`` and ``paper``, plain
            numbers in percent).
        value: the metric column.
        compare_paper: add the published figures.
        aliases: our dataset label → the paper's, for the join.

    Returns:
        The table as text.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; one of {FORMATS}")
    table = table_frame(results, layout, value, compare_paper, aliases)
    if fmt == "csv":
        long = table.stack(level=0, future_stack=True).reset_index()
        long["n_seeds"] = long["n_seeds"].astype("Int64")
        return long.dropna(subset=[c for c in ("mean", "paper") if c in long], how="all").to_csv(index=False)
    header, body, bold = _text_grid(table)
    n_keys = table.index.nlevels
    if fmt == "md":
        def md(cell: str, strong: bool) -> str:
            return f"**{cell}**" if strong else cell
        lines = ["| " + " | ".join(header) + " |",
                 "|" + "|".join([":---"] * n_keys + ["---:"] * (len(header) - n_keys)) + "|"]
        lines += ["| " + " | ".join(md(c, b) for c, b in zip(cells, flags, strict=True)) + " |"
                  for cells, flags in zip(body, bold, strict=True)]
        return "\n".join(lines) + "\n\n" + _caption(table) + "\n"

    def tex(cell: str, strong: bool) -> str:
        return rf"\textbf{{{_latex_escape(cell)}}}" if strong else _latex_escape(cell)
    lines = [rf"\begin{{tabular}}{{{'l' * n_keys}{'r' * (len(header) - n_keys)}}}", r"\hline",
             " & ".join(_latex_escape(h) for h in header) + r" \\", r"\hline"]
    lines += [" & ".join(tex(c, b) for c, b in zip(cells, flags, strict=True)) + r" \\"
              for cells, flags in zip(body, bold, strict=True)]
    lines += [r"\hline", r"\end{tabular}", "% " + _latex_escape(_caption(table))]
    return "\n".join(lines) + "\n"


def failed_runs(results: pd.DataFrame) -> list[str]:
    """One line per failed run (status not ``ok``): its id and its reason.

    Args:
        results: :func:`synthcal.eval.harness.collect_results`'s frame (``status``,
            ``run_id`` and ``error`` columns; none of them: no line).

    Returns:
        ``"failed: <run id>: <reason>"`` lines, in the frame's order.
    """
    if "status" not in results:
        return []
    failed = results[results["status"].astype(str) != "ok"]
    ids = failed["run_id"] if "run_id" in failed else failed.index.astype(str)
    errors = failed["error"] if "error" in failed else pd.Series("", index=failed.index)
    return [f"failed: {run_id}: {error or 'no reason recorded'}" for run_id, error in zip(ids, errors, strict=True)]


# --- paired differences ----------------------------------------------------------------


def _paper_difference(row: Mapping[str, str], key: str, a: str, b: str, aliases: Mapping[str, str]) -> float:
    """The paper's A − B for a cell (NaN where it lacks either figure)."""
    paper = paper_results().drop_duplicates(list(KEYS))
    lookup = {tuple(map(str, k)): v
              for k, v in zip(paper[list(KEYS)].itertuples(index=False), paper["iou_percent"], strict=True)}
    cell = {k: row[k] for k in KEYS if k != key}
    cell["dataset"] = aliases.get(cell.get("dataset", ""), cell.get("dataset", ""))
    figures = [lookup.get(tuple(dict(cell, **{key: side})[k] for k in KEYS), np.nan) for side in (a, b)]
    return float(figures[0] - figures[1])


def paired_frame(
    results: pd.DataFrame,
    a: str,
    b: str,
    key: str = "model",
    value: str = "iou",
    aliases: Mapping[str, str] | None = None,
) -> pd.DataFrame:
    """Per-seed paired differences A − B, summarised per cell.

    Two runs pair when they agree on every key of :data:`PAIR_KEYS` but ``key``
    and on the seed, ``key`` being ``a`` in one and ``b`` in the other (e.g. the
    proposed model and the baseline trained on the same split with the same loss).

    Args:
        results: per-run results (module docstring), with ``segmentation`` and
            ``profile`` where the runs have them.
        a, b: the two values of ``key`` compared.
        key: ``model`` (default) or another key of :data:`PAIR_KEYS`.
        value: the metric column.
        aliases: our dataset label → the paper's, for the paper's figures.

    Returns:
        One row per cell: the other pair keys, ``mean`` and ``std`` (ddof = 1;
        NaN for one pair) of the differences in points, ``n_pairs``, ``a_wins``
        (pairs where A's value is higher), ``paper`` (the paper's A − B for the
        cell; NaN where it has no figure, or for a metric that is not a reading
        of its IoU). ``attrs``: ``a``, ``b``, ``key``, ``value``.

    Raises:
        ValueError: bad results (as :func:`aggregate`), an unknown key, or no pair.
    """
    if key not in PAIR_KEYS or key == "dataset":
        raise ValueError(f"cannot pair over {key!r}; one of {', '.join(k for k in PAIR_KEYS if k != 'dataset')}")
    frame = _validate(results, value, PAIR_KEYS)
    others = [k for k in PAIR_KEYS if k != key]
    sides = [frame.loc[frame[key] == side, [*others, "seed", value]] for side in (a, b)]
    pairs = sides[0].merge(sides[1], on=[*others, "seed"], suffixes=("_a", "_b"))
    if pairs.empty:
        raise ValueError(f"no paired runs: no dataset, seed and settings with both {key} {a!r} and {key} {b!r}")
    pairs["difference"] = (pairs[f"{value}_a"] - pairs[f"{value}_b"]) * (1.0 if value in PIXEL_METRICS else 100.0)
    pairs["a_wins"] = pairs[f"{value}_a"] > pairs[f"{value}_b"]  # as displayed: A > B (for pixels, A worse)
    grouped = pairs.groupby(others, sort=False)
    out = grouped["difference"].agg(mean="mean", std=lambda x: x.std(ddof=1), n_pairs="count")
    out["a_wins"] = grouped["a_wins"].sum().astype(int)
    out = out.reset_index()
    compare = value in READINGS
    out["paper"] = [_paper_difference(row, key, a, b, aliases or {}) if compare else np.nan
                    for row in out[others].to_dict("records")]
    out.attrs.update(a=a, b=b, key=key, value=value)
    return out


def _signed(mean: float, std: float, n: int) -> str:
    if pd.isna(mean):
        return MISSING
    return f"{mean:+.2f}" if n < 2 or pd.isna(std) else f"{mean:+.2f} ± {std:.2f}"


def format_paired(
    results: pd.DataFrame,
    a: str,
    b: str,
    key: str = "model",
    fmt: str = "md",
    value: str = "iou",
    aliases: Mapping[str, str] | None = None,
) -> str:
    """:func:`paired_frame` as Markdown, LaTeX or CSV text.

    Rows are the pair keys that take more than one value (dataset always), in
    the paper's order; the others are stated in the caption. Columns: ``A − B``
    (mean ± std of the per-seed differences, points), ``A > B`` (seeds), and
    ``paper A − B``.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; one of {FORMATS}")
    cells = paired_frame(results, a, b, key, value, aliases)
    others = [k for k in PAIR_KEYS if k != key]
    varying = [k for k in others if k == "dataset" or cells[k].nunique() > 1]
    constants = {k: cells[k].iloc[0] for k in others if k not in varying and cells[k].iloc[0] != MISSING}
    order = [{v: i for i, v in enumerate(_order(cells[k], k, "models"))} for k in varying]
    cells = cells.iloc[sorted(range(len(cells)),
                              key=lambda i: [o[cells[k].iloc[i]] for o, k in zip(order, varying, strict=True)])]
    if fmt == "csv":
        return cells[[*varying, "mean", "std", "n_pairs", "a_wins", "paper"]].to_csv(index=False)
    header = [*varying, f"{a} − {b}", f"{a} > {b}", f"paper {a} − {b}"]
    body = []
    for _, row in cells.iterrows():
        paper = MISSING if pd.isna(row["paper"]) else f"{row['paper']:+.2f}"
        body.append([str(row[k]) for k in varying] + [_signed(row["mean"], row["std"], row["n_pairs"]),
                                                      f"{row['a_wins']} of {row['n_pairs']}", paper])
    caption = _paired_caption(a, b, key, value, constants)
    if fmt == "md":
        lines = ["| " + " | ".join(header) + " |",
                 "|" + "|".join([":---"] * len(varying) + ["---:"] * 3) + "|"]
        lines += ["| " + " | ".join(cells_) + " |" for cells_ in body]
        return "\n".join(lines) + "\n\n" + caption + "\n"
    lines = [rf"\begin{{tabular}}{{{'l' * len(varying)}rrr}}", r"\hline",
             " & ".join(_latex_escape(h) for h in header) + r" \\", r"\hline"]
    lines += [" & ".join(_latex_escape(c) for c in cells_) + r" \\" for cells_ in body]
    lines += [r"\hline", r"\end{tabular}", "% " + _latex_escape(caption)]
    return "\n".join(lines) + "\n"


def _paired_caption(a: str, b: str, key: str, value: str, constants: Mapping[str, str]) -> str:
    reading = f" — {DESCRIPTIONS[value]}" if value in DESCRIPTIONS else ""
    text = (f"{a} − {b} in points of {value} ({'px' if value in PIXEL_METRICS else '%'}){reading}: per split seed, the difference between two runs that "
            f"differ only in {key} (same dataset, seed and settings); mean ± std over the seeds (std with ddof = 1); "
            f"{a} > {b}: seeds where {a} scores higher. Paper: the published {a} − {b} for the same cell "
            f"(a UNet's segmentation, the paper's own training; SPEC §7)"
            + ("" if value in READINGS else f"; none for {value}, which is not a reading of the paper's IoU") + ".")
    if constants:
        text += " " + "; ".join(f"{k}: {SEGMENTATION_WORDS.get(v, v) if k == 'segmentation' else v}"
                                for k, v in constants.items()) + "."
    return text
