"""Paired differences of two models with their uncertainty, and the all-background floor.

Paired differences
------------------
Two runs that agree on every key of :data:`synthcal.eval.tables.PAIR_KEYS` but one
(``model``, or another such as ``loss``) and on the split seed are a *pair*: the
same train, test and dictionary sets, the same settings. Per cell (dataset and
settings) :func:`paired_frame` gives the mean of the per-seed differences A − B
in points, their standard deviation (ddof = 1), the seeds where A > B, the
paper's A − B for the same cell with a verdict on it (:func:`verdict`: the rules
of the reproduction report, :mod:`synthcal.eval.reproduction`), and two 95 %
confidence intervals of the mean difference:

* **paired t over seeds** (:func:`t_interval`): the seeds are independent draws
  of the split, so ``mean ± t_{0.975, n−1} · sd / √n``, and the two-sided p-value
  of the paired t test of "no difference". Undefined for one seed.
* **bootstrap over test images within seeds** (:func:`bootstrap_interval`): each
  seed's test images are resampled with replacement (both runs of a pair scored
  the same images, so the per-image differences are resampled), the seed means
  recomputed and averaged; the 2.5 and 97.5 percentiles of
  :data:`BOOTSTRAP_RESAMPLES` such means, from a generator seeded with
  :data:`BOOTSTRAP_SEED` so that the report is reproducible. It measures how much
  the result depends on *which* test images were drawn, not on which split: with
  one seed it is the only interval there is, and it is narrower than the t
  interval whenever the seeds disagree more than their images do.

The all-background floor
------------------------
What an estimate scores whose view is all background (class 0): the
``identity`` estimator (the train set's medoid camera) often looks at nothing
but background and scores it. :func:`background_floor` computes it from the
test set's true class maps with the metric's own code
(:func:`synthcal.eval.metrics.semantic_readings` of an all-zero prediction):
``iou`` 0 (no class 1–3 predicted; 1 for a view without any, which both agree
on), ``iou_bg`` ``s₀ / k`` (``s₀`` the background's share of the true view, ``k``
the classes present in it) and ``iou_weighted`` ``s₀²`` — the background's
Jaccard ``s₀`` (the prediction covers the whole view) weighted by its share
``s₀``, the other classes' Jaccard 0. At ``s₀ ≈ 0.73`` that is ~53: half of
``iou_weighted``'s scale is reached by predicting nothing.

Contrasts of paired differences
-------------------------------
Whether a paired difference A − B is larger under one value C of a second key than
under another, D — what a UNet's maps cost the proposed model against what they
cost ``sha2020`` (``key`` segmentation, ``between`` model). Per seed the four runs
(A and B under C, A and B under D) give one contrast ``(A − B)_C − (A − B)_D``;
:func:`contrast_frame` summarises them per cell with the paired t interval over
seeds (:func:`t_interval`), the interval of scipy's ``ttest_rel`` of the per-seed
``(A − B)_C`` against ``(A − B)_D``. No bootstrap: the four runs' per-image scores
are two pairs' differences on the same images, which their mean over seeds already
sums up; no paper figure: the paper publishes no such contrast.

Example
-------
>>> low, high, p = t_interval([2.0, 2.0, -1.0, 4.0, 2.0])
>>> round(low, 2), round(high, 2), round(p, 3)
(-0.42, 4.02, 0.088)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

from synthcal.config import DESCRIPTIONS, PIXEL_METRICS, READINGS
from synthcal.eval.metrics import semantic_readings
from synthcal.eval.tables import (
    FORMATS,
    KEYS,
    MISSING,
    PAIR_KEYS,
    SEGMENTATION_WORDS,
    counted,
    order_values,
    paper_figure,
    text_table,
    validate_results,
    wrap_caption,
)

__all__ = ["CONFIDENCE", "BOOTSTRAP_RESAMPLES", "BOOTSTRAP_SEED", "t_interval", "bootstrap_interval",
           "background_floor", "VERDICTS", "UNDECIDED", "verdict", "paired_runs", "paired_frame", "format_paired",
           "contrast_frame", "format_contrast"]

CONFIDENCE = 0.95
BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0
VERDICTS = ("consistent with the paper", "not reproduced", "opposite")
#: Rule 2 met by an interval that also holds 0: consistent with the claim and with no effect alike.
UNDECIDED = f"{VERDICTS[0]} (and with no difference)"

# A run id → its per-image values of the compared metric (fractions, indexed by pool index;
# NaN for images not scored), or None where the run has none recorded.
PerImage = Callable[[str], "pd.Series | None"]


def t_interval(differences: Sequence[float] | np.ndarray,
               confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Paired t interval of the mean difference and the p-value of "no difference".

    Args:
        differences: (n,) per-seed differences A − B.
        confidence: the interval's coverage.

    Returns:
        ``(low, high, p)``: the two-sided interval and p-value; all NaN for fewer
        than two differences (undefined); for differences without spread the
        interval is the mean and p is 0 (NaN when they are all 0).
    """
    d = np.asarray(differences, np.float64)
    n = len(d)
    if n < 2:
        return np.nan, np.nan, np.nan
    mean, error = float(d.mean()), float(d.std(ddof=1)) / np.sqrt(n)
    if error == 0:
        return mean, mean, (0.0 if mean != 0 else np.nan)
    half = float(stats.t.ppf(0.5 + confidence / 2, n - 1)) * error
    p = 2.0 * float(stats.t.sf(abs(mean) / error, n - 1))
    return float(mean - half), float(mean + half), p


def bootstrap_interval(per_seed: Sequence[np.ndarray], resamples: int = BOOTSTRAP_RESAMPLES,
                       confidence: float = CONFIDENCE, seed: int = BOOTSTRAP_SEED) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean over seeds of per-seed means, resampling within seeds.

    Args:
        per_seed: one (n_s,) array per seed of per-image values (here differences A − B).
        resamples: bootstrap resamples.
        confidence: the interval's coverage.
        seed: the generator's seed (the same inputs give the same interval).

    Returns:
        ``(low, high)``.

    Raises:
        ValueError: no seed, or a seed without images.
    """
    if not per_seed or any(len(values) == 0 for values in per_seed):
        raise ValueError("bootstrap: every seed needs at least one image")
    rng = np.random.default_rng(seed)
    total = np.zeros(resamples)
    for values in per_seed:
        values = np.asarray(values, np.float64)
        total += values[rng.integers(0, len(values), size=(resamples, len(values)))].mean(axis=1)
    low, high = np.quantile(total / len(per_seed), [0.5 - confidence / 2, 0.5 + confidence / 2])
    return float(low), float(high)


def background_floor(truths: np.ndarray, value: str) -> float:
    """Mean score over images of an estimate whose view is all background (module docstring).

    Args:
        truths: (K, H, W) true class maps of the scored test images, classes 0–3.
        value: a reading of the paper's IoU (``iou``, ``iou_bg``, ``iou_weighted``).

    Returns:
        The mean over the K images, a fraction.
    """
    if value not in READINGS:
        raise ValueError(f"the all-background floor is defined for {', '.join(READINGS)}, not {value!r}")
    truths = np.asarray(truths)
    background = np.zeros(truths.shape[1:], np.uint8)
    return float(np.mean([semantic_readings(background, truth)[value] for truth in truths]))


# --- paired differences ----------------------------------------------------------------


def _paper_difference(row: Mapping[str, str], key: str, a: str, b: str, aliases: Mapping[str, str]) -> float:
    """The paper's A − B for a cell (NaN where it lacks either figure, or does not vary ``key``).

    >>> import math
    >>> row = {"dataset": "intersection-1", "model": "proposed", "training": "step-by-step", "loss": "top-mse",
    ...        "matching_score": "top-mse"}
    >>> round(_paper_difference(row, "model", "proposed", "sha2020", {}), 2)
    1.97
    >>> math.isnan(_paper_difference(row, "segmentation", "unet", "ground-truth", {}))
    True
    """
    if key not in KEYS:  # the paper's tables do not vary it (e.g. segmentation): it claims no difference
        return float("nan")
    return paper_figure(dict(row, **{key: a}), aliases) - paper_figure(dict(row, **{key: b}), aliases)


def _points(value: str) -> float:
    """What one unit of ``value`` is in the tables: percent points for fractions, pixels as they are."""
    return 1.0 if value in PIXEL_METRICS else 100.0


def _image_differences(pairs: pd.DataFrame, per_image: PerImage | None) -> list[np.ndarray] | None:
    """Each pair's per-image differences A − B in points, on the images both runs scored (None: a run lacks them)."""
    if per_image is None or "run_id_a" not in pairs:
        return None
    out = []
    for run_a, run_b in zip(pairs["run_id_a"], pairs["run_id_b"], strict=True):
        a, b = per_image(str(run_a)), per_image(str(run_b))
        if a is None or b is None:
            return None
        differences = (a - b).dropna().to_numpy() * 100.0  # aligned on the pool index
        if len(differences) == 0:
            return None
        out.append(differences)
    return out


def verdict(low: float, high: float, paper_difference: float) -> str:
    """The verdict on the paper's difference A − B from our 95 % interval of A − B
    (:mod:`synthcal.eval.reproduction`, *Verdict rules*; ``--paired`` prints it too).

    Args:
        low, high: the paired t interval of our A − B (in the report, a model − sha2020), points
            (NaN: undefined).
        paper_difference: the paper's A − B for the same cell, points (NaN: no claim).

    Returns:
        One of :data:`VERDICTS`, :data:`UNDECIDED`, or "–" where there is no verdict.

    >>> verdict(0.5, 3.0, 2.1), verdict(-1.0, 0.8, 2.1), verdict(-4.0, -0.2, 2.1), verdict(-1.0, 5.0, 2.1)
    ('consistent with the paper', 'not reproduced', 'opposite', 'consistent with the paper (and with no difference)')
    """
    if any(pd.isna(v) for v in (low, high, paper_difference)):
        return MISSING
    d = paper_difference
    if low <= d <= high or (d > 0 and low > 0) or (d < 0 and high < 0):
        return UNDECIDED if low <= 0 <= high else VERDICTS[0]
    if (d > 0 and high < 0) or (d < 0 and low > 0):
        return VERDICTS[2]
    return VERDICTS[1]


def paired_runs(frame: pd.DataFrame, key: str, a: str, b: str, columns: Sequence[str]) -> pd.DataFrame:
    """The runs of ``key`` = ``a`` beside those of ``key`` = ``b`` on the same seed and every other pair key
    (:data:`PAIR_KEYS`): one row per pair, ``columns`` suffixed ``_a`` / ``_b``."""
    others = [k for k in PAIR_KEYS if k != key]
    sides = [frame.loc[frame[key] == side, [*others, "seed", *columns]] for side in (a, b)]
    return sides[0].merge(sides[1], on=[*others, "seed"], suffixes=("_a", "_b"))


def paired_frame(
    results: pd.DataFrame,
    a: str,
    b: str,
    key: str = "model",
    value: str = "iou",
    aliases: Mapping[str, str] | None = None,
    per_image: PerImage | None = None,
    resamples: int = BOOTSTRAP_RESAMPLES,
    claim: tuple[str, str] | None = None,
) -> pd.DataFrame:
    """Per-seed paired differences A − B, summarised per cell with their confidence intervals.

    Args:
        results: per-run results (:mod:`synthcal.eval.tables`), with ``segmentation``,
            ``profile`` and ``run_id`` where the runs have them.
        a, b: the two values of ``key`` compared.
        key: ``model`` (default) or another key of :data:`PAIR_KEYS`.
        value: the metric column.
        aliases: our dataset label → the paper's, for the paper's figures.
        per_image: a run id → its per-image values of ``value``
            (:data:`PerImage`); None: no bootstrap interval.
        resamples: bootstrap resamples.
        claim: the two values of ``key`` whose paper figures give ``paper``; None: ``(a, b)``.
            Across two results folders ``a`` and ``b`` are labels that name their folder
            (``top-mse (runs_x.csv)``) and the claim is the sides' own values (``top-mse``,
            ``mse``); where those are equal there is no claim (the paper compares no two folders).

    Returns:
        One row per cell: the other pair keys, ``mean`` and ``std`` (ddof = 1; NaN
        for one pair) of the differences in points, ``n_pairs``, ``a_wins`` (pairs
        where A's value is higher), ``t_low``, ``t_high``, ``p`` (:func:`t_interval`;
        NaN for one pair), ``boot_low``, ``boot_high`` (:func:`bootstrap_interval`;
        NaN without per-image values), ``paper`` (the paper's A − B for the
        cell; NaN where it has no figure, or for a metric that is not a reading of
        its IoU) and ``verdict`` (:func:`verdict` of the t interval on ``paper``). ``attrs``: ``a``, ``b``, ``key``, ``value``, ``resamples``.

    Raises:
        ValueError: bad results (as :func:`synthcal.eval.tables.aggregate`), an
            unknown key, or no pair.
    """
    _check_pairable(key)
    frame = validate_results(results, value, PAIR_KEYS)
    others = [k for k in PAIR_KEYS if k != key]
    pairs = paired_runs(frame, key, a, b, [value] + (["run_id"] if "run_id" in frame else []))
    if pairs.empty:
        raise ValueError(f"no paired runs: no dataset, seed and settings with both {key} {a!r} and {key} {b!r}")
    pairs["difference"] = (pairs[f"{value}_a"] - pairs[f"{value}_b"]) * _points(value)
    pairs["a_wins"] = pairs[f"{value}_a"] > pairs[f"{value}_b"]  # as displayed: A > B (for pixels, A worse)
    rows = []
    for cell, group in pairs.groupby(others, sort=False):
        # Pixel metrics are summarised by per-run medians (an image may score inf): no bootstrap of means.
        images = None if value in PIXEL_METRICS else _image_differences(group, per_image)
        boot = bootstrap_interval(images, resamples) if images else (np.nan, np.nan)
        rows.append({**dict(zip(others, cell, strict=True)),
                     **_seed_summary(group["difference"], "a_wins", int(group["a_wins"].sum())),
                     "boot_low": boot[0], "boot_high": boot[1]})
    out = pd.DataFrame(rows)
    paper_a, paper_b = claim or (a, b)
    compare = value in READINGS and paper_a != paper_b
    out["paper"] = [_paper_difference(row, key, paper_a, paper_b, aliases or {}) if compare else np.nan
                    for row in out[others].to_dict("records")]
    out["verdict"] = [verdict(lo, hi, d) for lo, hi, d in zip(out["t_low"], out["t_high"], out["paper"], strict=True)]
    out.attrs.update(a=a, b=b, key=key, value=value, resamples=resamples)
    return out


def _check_pairable(key: str) -> None:
    """Raise ValueError unless runs can be paired over ``key`` (a key of :data:`PAIR_KEYS` but ``dataset``)."""
    if key not in PAIR_KEYS or key == "dataset":
        raise ValueError(f"cannot pair over {key!r}; one of {', '.join(k for k in PAIR_KEYS if k != 'dataset')}")


def _seed_summary(differences: pd.Series, wins_column: str, wins: int) -> dict[str, float]:
    """One cell's per-seed differences summarised: ``mean``, ``std`` (ddof = 1), ``n_pairs``, the seeds
    counted in ``wins_column``, and the t interval with its p (:func:`t_interval`)."""
    t_low, t_high, p = t_interval(differences)
    return {"mean": differences.mean(), "std": differences.std(ddof=1), "n_pairs": len(differences),
            wins_column: wins, "t_low": t_low, "t_high": t_high, "p": p}


def _varying_and_constant(cells: pd.DataFrame, keys: Sequence[str]) -> tuple[list[str], dict[str, str]]:
    """Of ``keys``, those whose values differ across ``cells`` (dataset always), and the others' one value
    (left out where it is missing): a table's row keys and its caption's constants."""
    varying = [k for k in keys if k == "dataset" or cells[k].nunique() > 1]
    constants = {k: cells[k].iloc[0] for k in keys if k not in varying and cells[k].iloc[0] != MISSING}
    return varying, constants


def _signed(mean: float, std: float, n: int) -> str:
    if pd.isna(mean):
        return MISSING
    return f"{mean:+.2f}" if n < 2 or pd.isna(std) else f"{mean:+.2f} ± {std:.2f}"


def _interval(low: float, high: float, undefined: str = MISSING) -> str:
    return undefined if pd.isna(low) else f"[{low:+.2f}, {high:+.2f}]"


def _p_value(p: float) -> str:
    return MISSING if pd.isna(p) else "< 0.001" if p < 0.001 else f"{p:.3f}"


def format_paired(
    results: pd.DataFrame,
    a: str,
    b: str,
    key: str = "model",
    fmt: str = "md",
    value: str = "iou",
    aliases: Mapping[str, str] | None = None,
    per_image: PerImage | None = None,
    resamples: int = BOOTSTRAP_RESAMPLES,
    claim: tuple[str, str] | None = None,
) -> str:
    """:func:`paired_frame` as Markdown, LaTeX or CSV text.

    Rows are the pair keys that take more than one value (dataset always), in
    the paper's order; the others are stated in the caption. Columns: ``A − B``
    (mean ± std of the per-seed differences, points), the t and bootstrap 95 %
    intervals, the t test's p, ``A > B`` (seeds), ``paper A − B`` and the verdict.
    CSV has the numbers of :func:`paired_frame`.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; one of {FORMATS}")
    cells = paired_frame(results, a, b, key, value, aliases, per_image, resamples, claim)
    varying, constants = _varying_and_constant(cells, [k for k in PAIR_KEYS if k != key])
    cells = _in_paper_order(cells, varying)
    if fmt == "csv":
        return cells[[*varying, "mean", "std", "n_pairs", "a_wins", "t_low", "t_high", "p", "boot_low", "boot_high",
                      "paper", "verdict"]].to_csv(index=False)
    header = [*varying, f"{a} − {b}", "95 % CI (t)", "95 % CI (bootstrap)", "p", f"{a} > {b}", f"paper {a} − {b}",
              "verdict"]
    body = []
    for _, row in cells.iterrows():
        paper = MISSING if pd.isna(row["paper"]) else f"{row['paper']:+.2f}"
        body.append([str(row[k]) for k in varying] + [
            _signed(row["mean"], row["std"], row["n_pairs"]),
            _interval(row["t_low"], row["t_high"], "undefined (1 seed)" if row["n_pairs"] < 2 else MISSING),
            _interval(row["boot_low"], row["boot_high"]), _p_value(row["p"]),
            f"{row['a_wins']} of {row['n_pairs']}", paper, row["verdict"]])
    caption = wrap_caption(_paired_caption(a, b, key, value, constants, resamples), fmt)
    return text_table(header, body, "l" * len(varying) + "r" * (len(header) - len(varying) - 1) + "l", caption, fmt)


def _in_paper_order(cells: pd.DataFrame, keys: Sequence[str]) -> pd.DataFrame:
    """The rows of ``cells`` sorted on ``keys`` in the paper's order of their values (:func:`order_values`)."""
    order = [{v: i for i, v in enumerate(order_values(cells[k], k, "models"))} for k in keys]
    return cells.iloc[sorted(range(len(cells)),
                             key=lambda i: [o[cells[k].iloc[i]] for o, k in zip(order, keys, strict=True)])]


def _paired_caption(a: str, b: str, key: str, value: str, constants: Mapping[str, str], resamples: int) -> str:
    reading = f" — {DESCRIPTIONS[value]}" if value in DESCRIPTIONS else ""
    unit = "px" if value in PIXEL_METRICS else "%"
    text = (f"{a} − {b} in points of {value} ({unit}){reading}: per split seed, the difference between two runs that "
            f"differ only in {key} (same dataset, seed and settings); mean ± std over the seeds (std with ddof = 1). "
            f"95 % CI (t): paired t interval over the seeds, p: its two-sided test of no difference (both undefined "
            f"for one seed). 95 % CI (bootstrap): test images resampled with replacement within each seed, "
            f"{counted(resamples, 'resample')}, generator seed {BOOTSTRAP_SEED}; the spread due to the test images "
            f"drawn, not to the split (– where the runs' per-image scores are missing). {a} > {b}: seeds where {a} "
            f"scores higher. Paper: the published {a} − {b} for the same cell (a UNet's segmentation, the paper's "
            f"own training; SPEC §7)"
            + ("" if value in READINGS else f"; none for {value}, which is not a reading of the paper's IoU") + ". "
            f"Verdict on the paper's {a} − {b} from the t interval alone (docs/reproduction.md, \"Verdicts\").")
    if constants:
        text += " " + "; ".join(f"{k}: {SEGMENTATION_WORDS.get(v, v) if k == 'segmentation' else v}"
                                for k, v in constants.items()) + "."
    return text


# --- contrasts of paired differences -----------------------------------------------------


def contrast_frame(results: pd.DataFrame, a: str, b: str, key: str, c: str, d: str, between: str = "model",
                   value: str = "iou") -> pd.DataFrame:
    """Per seed, the paired difference A − B under ``between`` = C minus the same under D, summarised per cell.

    Args:
        results: per-run results, as for :func:`paired_frame`.
        a, b: the two values of ``key`` whose paired difference is contrasted
            (``ground-truth``, ``unet``: what the UNet's maps cost).
        key: the key A and B vary, one of :data:`PAIR_KEYS` but ``dataset``.
        c, d: the two values of ``between`` the difference is compared across (``proposed``, ``sha2020``).
        between: another such key.
        value: the metric column.

    Returns:
        One row per cell (the pair keys other than ``key`` and ``between``): ``mean`` and ``std`` (ddof = 1)
        of the per-seed contrasts in points, ``n_pairs`` (seeds with all four runs), ``c_wins`` (seeds where
        C's A − B is the larger), ``t_low``, ``t_high``, ``p`` (:func:`t_interval`). ``attrs``: ``a``,
        ``b``, ``key``, ``c``, ``d``, ``between``, ``value``.

    Raises:
        ValueError: bad results (as :func:`paired_frame`), a key that cannot be paired over, ``between``
            equal to ``key``, or no seed with all four runs.

    >>> runs = pd.DataFrame({"dataset": "d", "model": ["p", "p", "s", "s"] * 2, "seed": [0] * 4 + [1] * 4,
    ...                      "segmentation": ["true", "unet"] * 4, "iou": [.6, .5, .6, .58, .7, .62, .7, .69]})
    >>> cell = contrast_frame(runs, "true", "unet", "segmentation", "p", "s").iloc[0]
    >>> round(float(cell["mean"]), 2), int(cell["c_wins"]), int(cell["n_pairs"])
    (7.5, 2, 2)
    """
    for k in (key, between):
        _check_pairable(k)
    if key == between:
        raise ValueError(f"the contrast must be taken over another key than the paired one ({key!r})")
    pairs = paired_runs(validate_results(results, value, PAIR_KEYS), key, a, b, [value])
    pairs["difference"] = (pairs[f"{value}_a"] - pairs[f"{value}_b"]) * _points(value)
    cells = [k for k in PAIR_KEYS if k not in (key, between)]
    sides = [pairs.loc[pairs[between] == side, [*cells, "seed", "difference"]] for side in (c, d)]
    both = sides[0].merge(sides[1], on=[*cells, "seed"], suffixes=("_c", "_d"))
    if both.empty:
        raise ValueError(f"no seed with all four runs: {key} {a!r} and {b!r}, each under {between} {c!r} and {d!r}, "
                         f"on the same dataset, seed and settings")
    both["contrast"] = both["difference_c"] - both["difference_d"]
    rows = [{**dict(zip(cells, cell, strict=True)),
             **_seed_summary(group["contrast"], "c_wins", int((group["contrast"] > 0).sum()))}
            for cell, group in both.groupby(cells, sort=False)]
    out = pd.DataFrame(rows)
    out.attrs.update(a=a, b=b, key=key, c=c, d=d, between=between, value=value)
    return out


def format_contrast(results: pd.DataFrame, a: str, b: str, key: str, c: str, d: str, between: str = "model",
                    fmt: str = "md", value: str = "iou") -> str:
    """:func:`contrast_frame` as Markdown, LaTeX or CSV text: rows the cell keys that vary (dataset always),
    columns the contrast's mean ± std, its t interval, p and the seeds where C's A − B is the larger."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; one of {FORMATS}")
    cells = contrast_frame(results, a, b, key, c, d, between, value)
    varying, constants = _varying_and_constant(cells, [k for k in PAIR_KEYS if k not in (key, between)])
    cells = _in_paper_order(cells, varying)
    if fmt == "csv":
        return cells[[*varying, "mean", "std", "n_pairs", "c_wins", "t_low", "t_high", "p"]].to_csv(index=False)
    header = [*varying, f"({a} − {b}) {c} − {d}", "95 % CI (t)", "p", f"{c} > {d}"]
    body = [[str(row[k]) for k in varying]
            + [_signed(row["mean"], row["std"], row["n_pairs"]),
               _interval(row["t_low"], row["t_high"], "undefined (1 seed)" if row["n_pairs"] < 2 else MISSING),
               _p_value(row["p"]), f"{row['c_wins']} of {row['n_pairs']}"]
            for _, row in cells.iterrows()]
    unit = "px" if value in PIXEL_METRICS else "%"
    caption = (f"({a} − {b}) {c} − {d} in points of {value} ({unit}): per split seed, the paired difference "
               f"{a} − {b} (two runs that differ only in {key}) under {between} {c}, minus the same under {d}; "
               f"mean ± std over the seeds (ddof = 1). 95 % CI (t): paired t interval over the seeds, p: its "
               f"two-sided test of no difference. {c} > {d}: seeds where {c}'s {a} − {b} is the larger. The paper "
               f"publishes no such contrast.")
    if constants:
        caption += " " + "; ".join(f"{k}: {v}" for k, v in constants.items()) + "."
    return text_table(header, body, "l" * len(varying) + "r" * (len(header) - len(varying)), caption=wrap_caption(
        caption, fmt), fmt=fmt)
