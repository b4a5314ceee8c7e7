"""Result tables: aggregation over seeds, bold, the paper's figures, formats, errors."""

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from synthcal.eval.tables import KEYS, aggregate, failed_runs, format_table, paper_results, table_frame

ROOT = Path(__file__).resolve().parents[2]


def runs(rows, complete=None):
    """rows: (dataset, model, training, loss, matching_score, [iou per seed]); complete: row → [per seed]."""
    out = []
    for k, (dataset, model, training, loss, score, values) in enumerate(rows):
        for seed, value in enumerate(values):
            out.append(dict(dataset=dataset, model=model, training=training, loss=loss, matching_score=score,
                            seed=seed, iou=value, completeness=(complete or {}).get(k, [1.0] * len(values))[seed]))
    return pd.DataFrame(out)


MATCHING = runs([
    ("intersection-1", "proposed", "end-to-end", "top-mse", "mse", [0.80, 0.82, 0.84]),  # 82.00 ± 2.00
    ("intersection-1", "proposed", "end-to-end", "top-mse", "top-mse", [0.85, 0.86, 0.90]),  # 87.00 ± 2.65
    ("intersection-1", "proposed", "end-to-end", "mse", "mse", [0.70, 0.71, 0.72]),  # 71.00 ± 1.00
    ("intersection-1", "proposed", "end-to-end", "mse", "top-mse", [0.60, 0.60, 0.60]),  # 60.00 ± 0.00
    ("worldcup2014", "proposed", "end-to-end", "top-mse", "mse", [0.5]),  # one seed, no top-mse run
], complete={3: [1.0, 0.5, 0.9]})  # (mse, top-mse): 80 % of its estimates valid on average


def test_paper_data_is_packaged_and_consistent():
    paper = paper_results()
    shared = pd.read_csv(ROOT / "synthcal" / "data" / "paper_iou.csv")
    pd.testing.assert_frame_equal(paper, shared)
    assert len(paper) == 240 and set(paper["table"]) == {"matching", "models", "mixed"}
    # A configuration printed in two tables carries the same figure in both.
    assert (paper.groupby(list(KEYS))["iou_percent"].nunique() == 1).all()


def test_aggregate_mean_and_sample_std_by_hand():
    cells = aggregate(MATCHING).set_index(["dataset", "loss", "matching_score"])
    row = cells.loc[("intersection-1", "top-mse", "mse")]
    assert row["mean"] == pytest.approx(82.0) and row["std"] == pytest.approx(2.0) and row["n_seeds"] == 3
    row = cells.loc[("intersection-1", "top-mse", "top-mse")]
    assert row["std"] == pytest.approx(np.sqrt(((85 - 87) ** 2 + (86 - 87) ** 2 + (90 - 87) ** 2) / 2))
    assert np.isnan(cells.loc[("worldcup2014", "top-mse", "mse"), "std"])


def test_markdown_matching_table():
    text = format_table(MATCHING, "matching")
    lines = text.splitlines()
    assert lines[0] == "| dataset | loss | mse | mse (complete %) | top-mse | top-mse (complete %) |"
    # Paper order: worldcup2014 first; losses top-mse before mse.
    assert lines[2] == "| worldcup2014 | top-mse | 50.00 | 100.0 | – | – |"  # one seed: mean alone; missing: "–"
    assert lines[3] == "| intersection-1 | top-mse | 82.00 ± 2.00 | 100.0 | **87.00 ± 2.65** | 100.0 |"
    assert lines[4] == "|  | mse | **71.00 ± 1.00** | 100.0 | 60.00 ± 0.00 | 80.0 |"  # completeness beside each mean
    assert "model: proposed; training: end-to-end" in text  # constant keys go to the caption
    assert text.splitlines()[-1].startswith("iou (%) — the paper's IoU read as the mean over classes 1-3")


def test_bold_ties_share_and_single_values_are_not_bold():
    tied = runs([("intersection-2", "proposed", "end-to-end", "dice", s, [0.801, 0.799]) for s in ("mse", "top-mse")])
    line = format_table(tied, "matching").splitlines()[2]
    assert line.count("**80.00 ± 0.14**") == 2
    assert "**" not in format_table(MATCHING, "matching").splitlines()[2]


def test_paper_comparison_joins_the_published_figure():
    text = format_table(MATCHING, "matching", compare_paper=True)
    assert "| intersection-1 | top-mse | 82.00 ± 2.00 | 100.0 | 87.11 | **87.00 ± 2.65** | 100.0 | 87.42 |" in text
    models = runs([
        ("worldcup2014", "sha2020", "step-by-step", "dice", "top-mse", [0.80, 0.81]),
        ("worldcup2014", "proposed", "step-by-step", "dice", "top-mse", [0.82, 0.83]),
    ])
    frame = table_frame(models, "models", compare_paper=True)
    assert frame.loc["worldcup2014", ("sha2020", "paper")] == 80.09
    assert frame.loc["worldcup2014", ("proposed", "paper")] == 82.55
    # Our label for the synthetic pitch can be joined to the paper's.
    soccer = models.assign(dataset="soccer")
    frame = table_frame(soccer, "models", compare_paper=True, aliases={"soccer": "worldcup2014"})
    assert frame.loc["soccer", ("sha2020", "paper")] == 80.09
    mixed = runs([("mixed-5", m, "step-by-step", "top-dice", "top-mse", [0.7, 0.72])
                  for m in ("sha2020", "proposed")])
    frame = table_frame(mixed, "mixed", compare_paper=True)
    assert frame.loc["mixed-5", ("sha2020", "paper")] == 69.41
    assert frame.loc["mixed-5", ("proposed", "paper")] == 73.34


def test_layouts_select_datasets_and_columns():
    both = pd.concat([MATCHING, runs([("mixed-1", "sha2020", "end-to-end", "mse", "top-mse", [0.7, 0.7])])])
    models = table_frame(both, "models")
    assert list(dict.fromkeys(models.columns.get_level_values(0))) == ["proposed"]
    assert "mixed-1" not in models.index.get_level_values("dataset")
    mixed = table_frame(both, "mixed")
    assert list(mixed.index) == ["mixed-1"] and mixed.loc["mixed-1", ("sha2020", "mean")] == pytest.approx(70.0)
    with pytest.raises(ValueError, match="no mixed-dictionary"):
        table_frame(MATCHING, "mixed")


def test_latex_and_csv():
    tex = format_table(MATCHING, "matching", fmt="latex")
    assert r"\begin{tabular}{llrrrr}" in tex
    assert r"intersection-1 & top-mse & 82.00 $\pm$ 2.00 & 100.0 & \textbf{87.00 $\pm$ 2.65} & 100.0 \\" in tex
    assert r"& mse & \textbf{71.00 $\pm$ 1.00} & 100.0 & 60.00 $\pm$ 0.00 & 80.0 \\" in tex
    assert "complete \\%: share of test images with a valid estimate" in tex
    assert "–" not in tex and "±" not in tex  # written "--" and "$\pm$"
    long = pd.read_csv(io.StringIO(format_table(MATCHING, "matching", fmt="csv", compare_paper=True)))
    assert list(long.columns) == ["dataset", "loss", "matching_score", "mean", "std", "n_seeds", "completeness",
                                  "paper"]
    row = long[(long["dataset"] == "intersection-1") & (long["loss"] == "mse") & (long["matching_score"] == "mse")]
    assert row[["mean", "std", "n_seeds", "completeness", "paper"]].iloc[0].tolist() == pytest.approx(
        [71.0, 1.0, 3, 100.0, 84.32])
    row = long[(long["dataset"] == "intersection-1") & (long["loss"] == "mse") & (long["matching_score"] == "top-mse")]
    assert row["completeness"].iloc[0] == pytest.approx(80.0)
    # The missing (worldcup2014, top-mse) cell still carries the paper's figure.
    row = long[(long["dataset"] == "worldcup2014") & (long["matching_score"] == "top-mse")]
    assert np.isnan(row["mean"].iloc[0]) and row["paper"].iloc[0] == 84.21


def test_missing_optional_keys_show_a_dash():
    simple = pd.DataFrame({"dataset": "intersection-3", "model": ["identity", "template"] * 2,
                           "seed": [0, 0, 1, 1], "iou": [0.1, 0.5, 0.2, 0.6]})
    # No completeness column in the results: "–" beside each mean.
    assert "| intersection-3 | 15.00 ± 7.07 | – | **55.00 ± 7.07** | – |" in format_table(simple, "models")


@pytest.mark.parametrize("change, message", [
    (lambda f: f.assign(iou=f["iou"] * 100), "fraction"),
    (lambda f: pd.concat([f, f.iloc[:1]]), "same keys and seed"),
    (lambda f: f.drop(columns="seed"), "lack column"),
])
def test_bad_results_are_refused(change, message):
    with pytest.raises(ValueError, match=message):
        format_table(change(MATCHING), "matching")


def test_bad_requests_are_refused():
    with pytest.raises(ValueError, match="only its IoU"):
        format_table(MATCHING.assign(iou_part=0.5), "matching", value="iou_part", compare_paper=True)
    with pytest.raises(ValueError, match="unknown layout"):
        format_table(MATCHING, "nope")
    with pytest.raises(ValueError, match="unknown format"):
        format_table(MATCHING, "matching", fmt="xlsx")


@pytest.mark.parametrize("reading, words", [("iou_bg", "classes 0-3 (background included)"),
                                            ("iou_weighted", "jaccard_score average='weighted'")])
def test_every_reading_of_the_papers_iou_compares_and_is_named(reading, words):
    frame = MATCHING.assign(**{reading: MATCHING["iou"] / 2})
    text = format_table(frame, "matching", value=reading, compare_paper=True)
    # Our halved means beside the same published figures; the caption names the reading.
    assert "| intersection-1 | top-mse | 41.00 ± 1.00 | 100.0 | 87.11 | **43.50 ± 1.32** | 100.0 | 87.42 |" in text
    assert text.splitlines()[-1].startswith(f"{reading} (%) — ") and words in text.splitlines()[-1]


def test_failed_runs_are_listed_with_their_reason():
    frame = pd.DataFrame({"run_id": ["a", "b", "c"], "status": ["ok", "failed", "failed"],
                          "error": ["", "all 4 estimates invalid: non-finite entries", "fit: timed out after 5 s"]})
    assert failed_runs(frame) == ["failed: b: all 4 estimates invalid: non-finite entries",
                                  "failed: c: fit: timed out after 5 s"]
    assert failed_runs(MATCHING) == []
