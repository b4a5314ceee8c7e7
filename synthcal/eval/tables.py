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
``chosen``         no      what the run chose on the validation split
                           (:func:`synthcal.eval.runs.chosen_text`; caption, per model)
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
IoU in percent, ``mean ± std`` over seeds with 2 decimals. ``std`` is the sample
standard deviation (``ddof = 1``): the five seeds are five draws of the split,
and the spread of *those draws* is what a reader compares against; a single
seed shows the mean alone. A mean IoU is only comparable with the share of
images it counts as valid: a cell whose completeness (mean over seeds) is under
100 % is marked ``†`` and a footnote gives it. The highest mean of a row (compared
as displayed, so ties share it) is bold — Markdown ``**…**``, LaTeX ``\\textbf{…}`` —
when the row has at least two values and the highest is above 0 (a row of zeros,
every run failed, has no best). ``compare_paper=True`` adds the published figure
beside each column ("paper"), joined on every key (:func:`paper_figure`); the
paper's IoU is undefined beyond its prose, so the comparison is offered for each
of its three readings (``iou``, ``iou_bg``, ``iou_weighted``; SPEC §8).

Below the table
---------------
Wrapped at 100 columns: the all-background floor where the caller gives it
(``floors``: the score of an estimate whose view is all background;
:mod:`synthcal.eval.statistics`), the incomplete cells, the table's *notes* (its
seeds, single-valued keys and the conditions — profile, segmentation with the
models that read it, training budget — from the optional columns) and the
*legend* (the reading named and described, what a cell holds; with
``compare_paper``, that the paper's figures come from a UNet's segmentation and
its own full training). A report of several tables states the legend once
(``with_legend=False``).

Paired differences of two models, with their confidence intervals, are
:mod:`synthcal.eval.statistics`.

Example
-------
>>> import pandas as pd
>>> runs = pd.DataFrame({"dataset": "intersection-1", "model": "proposed", "training": "end-to-end",
...                      "loss": "top-mse", "matching_score": ["mse", "mse", "top-mse", "top-mse"],
...                      "seed": [0, 1, 0, 1], "iou": [0.80, 0.82, 0.84, 0.86]})
>>> text = format_table(runs, "matching")
>>> for line in text.splitlines()[:3]:
...     print(line)
| dataset | mse | top-mse |
|:---|---:|---:|
| intersection-1 | 81.00 ± 1.41 | **85.00 ± 1.41** |
>>> print(text.splitlines()[4])
By matching_score, over 2 seeds. model: proposed; training: end-to-end; loss: top-mse.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

import numpy as np
import pandas as pd

from synthcal.config import DESCRIPTIONS, PIXEL_METRICS, READINGS

__all__ = ["KEYS", "MISSING", "PAIR_KEYS", "FORMATS", "Layout", "LAYOUTS", "paper_results", "paper_figure", "validate_results",
           "aggregate", "order_values", "table_frame", "counted", "wrap_caption", "latex_escape", "text_table", "legend", "notes",
           "floor_line", "format_table", "failed_runs", "SEGMENTATION_WORDS"]

KEYS = ("dataset", "model", "training", "loss", "matching_score")
# Keys that must agree for two runs to be a pair (besides the seed): the table keys and
# what a run was obtained under.
PAIR_KEYS = (*KEYS, "segmentation", "profile")
# The caption's words for a segmentation value.
SEGMENTATION_WORDS = {"unet": "a UNet's segmentation", "ground-truth": "the true semantic maps (ground-truth)"}
# The caption's words for a dictionary value (synthcal.eval.runs: Run.dictionary).
DICTIONARY_WORDS = {"split": "the seed's drawn dictionary", "pool": "the whole pool outside the seed's train, test and "
                    "validation sets (rows NAME (pool))"}
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


@lru_cache(maxsize=1)
def _paper_lookup() -> dict[tuple[str, ...], float]:
    """The paper's figures by their :data:`KEYS` values as text (a configuration in two tables: the first)."""
    paper = paper_results().drop_duplicates(list(KEYS))
    return {tuple(map(str, key)): float(value)
            for key, value in zip(paper[list(KEYS)].itertuples(index=False), paper["iou_percent"], strict=True)}


def paper_figure(cell: Mapping[str, object], aliases: Mapping[str, str] | None = None) -> float:
    """The paper's published IoU for one cell, in percent (``synthcal/data/paper_iou.csv``).

    Args:
        cell: a value for each of :data:`KEYS` (compared as text, "–" for a missing one);
            other entries are ignored.
        aliases: our dataset label → the paper's (e.g. ``{"soccer": "worldcup2014"}``);
            a label without one is the paper's own.

    Returns:
        The figure, NaN where the paper has none for these keys.

    >>> paper_figure({"dataset": "intersection-1", "model": "sha2020", "training": "step-by-step",
    ...               "loss": "top-mse", "matching_score": "top-mse"})
    85.94
    """
    missing = [k for k in KEYS if k not in cell]
    if missing:
        raise ValueError(f"paper_figure: the cell lacks key(s) {missing}; has {sorted(cell)}")
    named = {k: str(cell[k]) for k in KEYS}
    named["dataset"] = (aliases or {}).get(named["dataset"], named["dataset"])
    return _paper_lookup().get(tuple(named[k] for k in KEYS), float("nan"))


def validate_results(results: pd.DataFrame, value: str, keys: tuple[str, ...] = KEYS) -> pd.DataFrame:
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
        raise ValueError(_duplicates_message(frame.loc[duplicated], keys))
    return frame


def _duplicates_message(duplicates: pd.DataFrame, keys: tuple[str, ...], shown: int = 10) -> str:
    """Which runs collide, one per line (run id where known), and the usual cause: runs whose settings differ
    only where the table's keys do not look (a redrawn split, a fixed against a selected learning rate)."""
    lines = [f"  {row.get('run_id', '?')}: " + " / ".join(str(row[k]) for k in (*keys, "seed"))
             for _, row in duplicates.head(shown).iterrows()]
    more = f"\n  … and {len(duplicates) - shown} more" if len(duplicates) > shown else ""
    return (f"several results for the same keys and seed ({' / '.join((*keys, 'seed'))}):\n" + "\n".join(lines)
            + more + "\n  runs that differ only in what the table does not show (a redrawn split, a fixed against a "
            "selected learning rate, another selection score) belong in separate results folders: move the older "
            "runs/<id> folders out")


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
    frame = validate_results(results, value)
    grouped = frame.groupby(list(KEYS), sort=False)
    with np.errstate(invalid="ignore"):  # a pixel error's inf (a failed run median) has no std: NaN, not a warning
        out = grouped[value].agg(mean="mean", std=lambda x: x.std(ddof=1), n_seeds="count")
    out["completeness"] = grouped["completeness"].mean()
    out = out.reset_index()
    out[["mean", "std", "completeness"] if value not in PIXEL_METRICS else ["completeness"]] *= 100.0
    return out


def order_values(values: pd.Series, key: str, layout: str) -> list[str]:
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
    column_values = list(dict.fromkeys(table.columns.get_level_values(0)))
    out = {}
    for value in column_values:
        figures = []
        for row in table.index:
            key = dict(constants, **dict(zip(varying, row if isinstance(row, tuple) else (row,), strict=True)))
            key[column_key] = value
            figures.append(paper_figure(key, aliases))
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
    column_order = order_values(cells[spec.columns], spec.columns, layout)
    table = table.reindex(columns=pd.MultiIndex.from_product([column_order, fields]))
    row_order = [order_values(cells[k], k, layout) for k in varying]
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
    conditions = {"profile": _distinct(results, "profile"), "segmentation": _distinct(results, "segmentation"),
                  "dictionary": _distinct(results, "dictionary"), "budget": _distinct(results, "budget")}
    if "chosen" in results and "model" in results:  # per model: each choice and how many runs made it
        picked = results.dropna(subset=["chosen"]).groupby("model", sort=False)["chosen"]
        conditions["chosen"] = [f"{model} " + ", ".join(f"{text} (×{n})" for text, n in chosen.value_counts(
            sort=False).items()) for model, chosen in picked]
    # Estimators that read no segmentation (plug-ins, references) have none: the caption names those that do.
    if "segmentation" in results and "model" in results and results["segmentation"].isna().any():
        conditions["segmentation_readers"] = _distinct(results[results["segmentation"].notna()], "model")
    return conditions


# --- text ------------------------------------------------------------------------------

# Markdown captions wrap at this width; LaTeX comments too.
CAPTION_WIDTH = 100
# Marks a cell whose runs returned a valid estimate for fewer than all test images.
INCOMPLETE = "†"


def counted(n: int, word: str) -> str:
    """``n`` and the word, plural unless n is 1: ``counted(1, "seed")`` → ``"1 seed"``."""
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def wrap_caption(text: str, fmt: str) -> str:
    """A caption as lines of at most :data:`CAPTION_WIDTH` characters; LaTeX's as comments (escaped)."""
    if fmt == "latex":
        return "\n".join("% " + latex_escape(line) for line in textwrap.wrap(text, CAPTION_WIDTH - 2))
    return textwrap.fill(text, CAPTION_WIDTH)


def _cell(mean: float, std: float, n: float) -> str:
    if pd.isna(mean):
        return MISSING
    return f"{mean:.2f}" if n < 2 or pd.isna(std) else f"{mean:.2f} ± {std:.2f}"


def latex_escape(text: str) -> str:
    """Text for LaTeX: its special characters escaped, the tables' symbols as LaTeX commands."""
    replacements = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                    "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                    "±": r"$\pm$", "–": "--", "—": "---", "−": "$-$", "×": r"$\times$",
                    ">": "$>$", "<": "$<$", INCOMPLETE: r"$^\dagger$"}
    return "".join(replacements.get(ch, ch) for ch in text)



def text_table(header: Sequence[str], body: Sequence[Sequence[str]], aligns: str, caption: str, fmt: str) -> str:
    """A Markdown or LaTeX table of ready-made cells with its caption below.

    Args:
        header: the column titles.
        body: rows of cell texts, one per column.
        aligns: one letter per column, ``l`` (left) or ``r`` (right).
        caption: the text under the table (already wrapped for ``fmt``).
        fmt: ``md`` or ``latex``.
    """
    if fmt == "md":
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join(":---" if a == "l" else "---:" for a in aligns) + "|"]
        lines += ["| " + " | ".join(cells) + " |" for cells in body]
        return "\n".join(lines) + "\n\n" + caption + "\n"
    lines = [rf"\begin{{tabular}}{{{aligns}}}", r"\hline", " & ".join(latex_escape(h) for h in header) + r" \\",
             r"\hline"]
    lines += [" & ".join(latex_escape(c) for c in cells) + r" \\" for cells in body]
    lines += [r"\hline", r"\end{tabular}", caption]
    return "\n".join(lines) + "\n"

def _text_grid(table: pd.DataFrame) -> tuple[list[str], list[list[str]], list[list[bool]], list[str]]:
    """Header, display cells, bold flags (row keys first, repeated keys blanked) and the incomplete cells
    (``"<column> in <row keys>: <complete> %"``, marked :data:`INCOMPLETE` in the grid)."""
    column_values = list(dict.fromkeys(table.columns.get_level_values(0)))
    compare = "paper" in table.columns.get_level_values(1)
    header = list(table.index.names)
    for value in column_values:
        header += [value] + ([f"{value} (paper)"] if compare else [])
    body, bold, incomplete, previous = [], [], [], None
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
            cell = _cell(row[(value, "mean")], row[(value, "std")], row[(value, "n_seeds")])
            complete = row[(value, "completeness")]
            if not pd.isna(complete) and round(complete, 1) < 100.0:  # as displayed: 99.96 is 100.0
                cell += f" {INCOMPLETE}"
                incomplete.append(f"{value} in {' / '.join(key)}: {complete:.1f} %")
            cells.append(cell)
            flags.append(bool(mean == best))
            if compare:
                paper = row[(value, "paper")]
                cells.append(MISSING if pd.isna(paper) else f"{paper:.2f}")
                flags.append(False)
        body.append(cells)
        bold.append(flags)
    return header, body, bold, incomplete


def legend(value: str, compare_paper: bool = False) -> str:
    """What every table of a reading says alike: the reading, the cells, bold, the paper's figures."""
    reading = f" — {DESCRIPTIONS[value]}" if value in DESCRIPTIONS else ""
    unit = "px" if value in PIXEL_METRICS else "%"
    text = (f"{value} ({unit}){reading}. Cells: mean ± std over seeds (std with ddof = 1; the mean alone for one seed); "
            f"best per row in bold; {INCOMPLETE}: fewer than all test images got a valid estimate (failures count "
            f"as 0).")
    if compare_paper:
        text += (" Paper: the published figure, from a UNet's segmentation and the paper's own full training"
                 " (SPEC §7).")
    return text


def notes(table: pd.DataFrame) -> str:
    """What one table's runs share: the seeds, its single-valued keys and the conditions they were obtained under."""
    seeds = table.attrs.get("n_seeds", [])
    n = counted(seeds[0], "seed") if len(seeds) == 1 else f"{min(seeds)}–{max(seeds)} seeds" if seeds else "? seeds"
    # A key missing in every run (estimators that do not train have no loss) says nothing: left out.
    constants = {k: v for k, v in table.attrs.get("constants", {}).items() if v != MISSING}
    text = f"By {table.columns.names[0]}, over {n}."
    if constants:
        text += " " + "; ".join(f"{k}: {v}" for k, v in constants.items()) + "."
    return text + _conditions_text(table.attrs.get("conditions", {}))


def _conditions_text(conditions: Mapping[str, list[str]]) -> str:
    """`` Ours: profile …; segmentation …; training ….`` from what the results record ("" if nothing)."""
    parts = []
    if conditions.get("profile"):
        parts.append("profile " + ", ".join(conditions["profile"]))
    if conditions.get("segmentation"):
        readers = conditions.get("segmentation_readers")
        parts.append("segmentation: " + ", ".join(SEGMENTATION_WORDS.get(v, v) for v in conditions["segmentation"])
                     + (f" (read by {', '.join(readers)} only)" if readers else ""))
    if set(conditions.get("dictionary", ())) - {"split"}:  # said once some run searched the pool
        parts.append("dictionary: " + " | ".join(DICTIONARY_WORDS.get(v, v) for v in conditions["dictionary"]))
    if conditions.get("budget"):
        parts.append("training: " + " | ".join(conditions["budget"]))
    if conditions.get("chosen"):
        parts.append("chosen on validation: " + " | ".join(conditions["chosen"]))
    return f" Ours: {'; '.join(parts)}." if parts else ""


def floor_line(table: pd.DataFrame, floors: Mapping[str, float]) -> str:
    """``all-background floor: 52.87`` (one dataset) or ``…: intersection-1 52.87, soccer 61.02``; the
    score of an estimate whose view is all background, for the table's datasets that have one ("" if none)."""
    datasets = list(dict.fromkeys(table.index.get_level_values("dataset")))
    known = [(d, floors[d]) for d in datasets if d in floors]
    if not known:
        return ""
    if len(datasets) == 1:
        return f"all-background floor: {known[0][1]:.2f}"
    return "all-background floor: " + ", ".join(f"{d} {f:.2f}" for d, f in known)


def format_table(
    results: pd.DataFrame,
    layout: str,
    fmt: str = "md",
    value: str = "iou",
    compare_paper: bool = False,
    aliases: Mapping[str, str] | None = None,
    floors: Mapping[str, float] | None = None,
    with_legend: bool = True,
) -> str:
    """One of the paper's tables as Markdown, LaTeX or CSV text.

    Below the table, each on lines of its own wrapped at :data:`CAPTION_WIDTH`:
    the all-background floor (:func:`floor_line`, where ``floors`` has the
    table's datasets), the cells under 100 % complete, the table's :func:`notes`
    and the :func:`legend`.

    Args:
        results: per-run results (module docstring).
        layout: ``matching``, ``models`` or ``mixed``.
        fmt: ``md``, ``latex`` or ``csv`` (long form: the row keys, the column key,
            ``mean``, ``std``, ``n_seeds``, ``completeness`` and ``paper``, plain
            numbers in percent).
        value: the metric column.
        compare_paper: add the published figures.
        aliases: our dataset label → the paper's, for the join.
        floors: dataset label → the all-background floor in percent
            (:func:`synthcal.eval.statistics.background_floor`); none: no floor line.
        with_legend: False leaves the legend out (a report of several tables states it once).

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
    header, body, bold, incomplete = _text_grid(table)
    below = [floor_line(table, floors or {}),
             (f"{INCOMPLETE} complete (share of test images with a valid estimate, mean over seeds): "
              + "; ".join(incomplete) + ".") if incomplete else "",
             notes(table), legend(value, compare_paper) if with_legend else ""]
    caption = "\n".join(wrap_caption(text, fmt) for text in below if text)
    n_keys = table.index.nlevels
    if fmt == "md":
        def md(cell: str, strong: bool) -> str:
            return f"**{cell}**" if strong else cell
        lines = ["| " + " | ".join(header) + " |",
                 "|" + "|".join([":---"] * n_keys + ["---:"] * (len(header) - n_keys)) + "|"]
        lines += ["| " + " | ".join(md(c, b) for c, b in zip(cells, flags, strict=True)) + " |"
                  for cells, flags in zip(body, bold, strict=True)]
        return "\n".join(lines) + "\n\n" + caption + "\n"

    def tex(cell: str, strong: bool) -> str:
        return rf"\textbf{{{latex_escape(cell)}}}" if strong else latex_escape(cell)
    lines = [rf"\begin{{tabular}}{{{'l' * n_keys}{'r' * (len(header) - n_keys)}}}", r"\hline",
             " & ".join(latex_escape(h) for h in header) + r" \\", r"\hline"]
    lines += [" & ".join(tex(c, b) for c, b in zip(cells, flags, strict=True)) + r" \\"
              for cells, flags in zip(body, bold, strict=True)]
    lines += [r"\hline", r"\end{tabular}", caption]
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
