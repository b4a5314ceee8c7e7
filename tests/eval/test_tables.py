"""Result tables: aggregation over seeds, bold, the paper's figures, formats, errors."""

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from synthcal.eval.tables import (
    CAPTION_WIDTH,
    KEYS,
    aggregate,
    failed_runs,
    format_table,
    paper_figure,
    paper_results,
    table_frame,
)

ROOT = Path(__file__).resolve().parents[2]


def flat(text):
    """The text with its line breaks as spaces (captions are wrapped)."""
    return " ".join(text.split())


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
    assert lines[0] == "| dataset | loss | mse | top-mse |"  # no completeness columns
    # Paper order: worldcup2014 first; losses top-mse before mse.
    assert lines[2] == "| worldcup2014 | top-mse | 50.00 | – |"  # one seed: mean alone; missing: "–"
    assert lines[3] == "| intersection-1 | top-mse | 82.00 ± 2.00 | **87.00 ± 2.65** |"
    assert lines[4] == "|  | mse | **71.00 ± 1.00** | 60.00 ± 0.00 † |"  # the one cell under 100 % is marked
    caption = flat(text[text.index("\n\n"):])
    assert "†: fewer than all test images got a valid estimate" in caption
    assert "valid estimate, mean over seeds): top-mse in intersection-1 / mse: 80.0 %." in caption
    assert "model: proposed; training: end-to-end" in caption  # constant keys go to the caption
    assert caption.startswith("† complete") and "iou (%) — the paper's IoU read as the mean over classes 1-3" in caption


def test_bold_ties_share_and_single_values_are_not_bold():
    tied = runs([("intersection-2", "proposed", "end-to-end", "dice", s, [0.801, 0.799]) for s in ("mse", "top-mse")])
    line = format_table(tied, "matching").splitlines()[2]
    assert line.count("**80.00 ± 0.14**") == 2
    assert "**" not in format_table(MATCHING, "matching").splitlines()[2]


def test_paper_comparison_joins_the_published_figure():
    text = format_table(MATCHING, "matching", compare_paper=True)
    assert "| intersection-1 | top-mse | 82.00 ± 2.00 | 87.11 | **87.00 ± 2.65** | 87.42 |" in text
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
    assert r"\begin{tabular}{llrr}" in tex
    assert r"intersection-1 & top-mse & 82.00 $\pm$ 2.00 & \textbf{87.00 $\pm$ 2.65} \\" in tex
    assert r"& mse & \textbf{71.00 $\pm$ 1.00} & 60.00 $\pm$ 0.00 $^\dagger$ \\" in tex
    caption = [line for line in tex.splitlines() if line.startswith("%")]
    assert caption and all(len(line) <= CAPTION_WIDTH + 20 for line in caption)  # wrapped before escaping
    assert "share of test images with a valid estimate" in flat(" ".join(line[2:] for line in caption))
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
    # No completeness column in the results: no mark, no footnote.
    text = format_table(simple, "models")
    assert "| intersection-3 | 15.00 ± 7.07 | **55.00 ± 7.07** |" in text and "† complete" not in text


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
    assert "| intersection-1 | top-mse | 41.00 ± 1.00 | 87.11 | **43.50 ± 1.32** | 87.42 |" in text
    assert f"\n{reading} (%) — " in text and words in flat(text)


def test_failed_runs_are_listed_with_their_reason():
    frame = pd.DataFrame({"run_id": ["a", "b", "c"], "status": ["ok", "failed", "failed"],
                          "error": ["", "all 4 estimates invalid: non-finite entries", "fit: timed out after 5 s"]})
    assert failed_runs(frame) == ["failed: b: all 4 estimates invalid: non-finite entries",
                                  "failed: c: fit: timed out after 5 s"]
    assert failed_runs(MATCHING) == []


# --- issue 14 item 8: tables that explain themselves --------------------------------------


def test_compare_paper_caption_says_profile_segmentation_and_budget():
    budget = "step-by-step Siamese 10, STN 24 epochs; 1500 train images; at 128 × 72; stn template retrieved"
    models = runs([("intersection-1", m, "step-by-step", "top-mse", "top-mse", [0.6, 0.62]) for m in
                   ("sha2020", "proposed")]).assign(profile="quick", segmentation="ground-truth", budget=budget)
    caption = flat(format_table(models, "models", compare_paper=True))
    assert (f"Ours: profile quick; segmentation: the true semantic maps (ground-truth); training: {budget}."
            in caption)
    assert "Paper: the published figure, from a UNet's segmentation and the paper's own full training" in caption
    # Without the paper's figures, the conditions still show; the paper's do not.
    assert "Paper:" not in format_table(models, "models")
    unet = flat(format_table(models.assign(segmentation="unet"), "models", fmt="latex").replace("\n% ", " "))
    assert r"segmentation: a UNet's segmentation" in unet and r"128 $\times$ 72" in unet


def test_training_budget_reads_the_runs_settings():
    from synthcal.eval.harness import training_budget

    settings = {"unet_epochs": 10, "siamese_epochs": 8, "stn_epochs": 16, "end_to_end_epochs": 12,
                "max_train": 100, "work_size": [128, 72], "stn_template": "retrieved", "class_reduction": "sum"}
    record = {"run": {"training": "step-by-step", "segmentation": "unet", "settings": settings},
              "sizes": {"train": 128}}
    assert training_budget(record) == ("step-by-step UNet 10, Siamese 8, STN 16 epochs; 100 train images; "
                                       "at 128 × 72; stn template retrieved; class reduction sum")
    record["run"].update(training="end-to-end", segmentation="ground-truth")
    record["run"]["settings"] = dict(settings, max_train=None, stn_template=None, class_reduction=None)
    assert training_budget(record) == "end-to-end 12 epochs; 128 train images; at 128 × 72"
    record["run"]["settings"].update(select={"learning_rate": [1e-4, 1e-3]}, selection_score="iou")
    assert training_budget(record).endswith("learning rate chosen on validation from 0.0001, 0.001; fits ranked by "
                                            "validation iou")
    record["run"]["settings"]["selection_score"] = "warp-loss"  # the default, said by no caption
    assert training_budget(record).endswith("from 0.0001, 0.001")
    assert training_budget({"run": {"training": None, "settings": None}}) is None  # identity, template, ecc


def test_estimators_that_do_not_train_show_no_training_keys():
    untrained = pd.DataFrame({"dataset": "intersection-1", "model": ["identity", "template"] * 2,
                              "training": None, "loss": None, "matching_score": None, "seed": [0, 0, 1, 1],
                              "iou": [0.1, 0.5, 0.2, 0.6], "budget": None})
    text = format_table(untrained, "models", compare_paper=True)
    caption = flat(text[text.index("\n\n"):])
    for key in ("training", "loss", "matching_score"):
        assert key not in text.splitlines()[0] and f"{key}: " not in caption
    assert "Ours:" not in caption  # no profile, segmentation or budget recorded


def test_a_row_of_zeros_has_no_bold():
    failed = runs([("intersection-1", m, "step-by-step", "top-mse", "top-mse", [0.0, 0.0]) for m in
                   ("sha2020", "proposed")])
    assert "**" not in format_table(failed, "models") and r"\textbf" not in format_table(failed, "models", "latex")
    one = pd.concat([failed, runs([("intersection-1", "identity", "step-by-step", "top-mse", "top-mse",
                                    [0.01, 0.0])])])
    assert "**0.50 ± 0.71**" in format_table(one, "models")  # any value above 0 is a best


# --- issue 9 item 5: paired differences ---------------------------------------------------

PROPOSED = [0.70, 0.72, 0.69, 0.75, 0.71]
BASELINE = [0.68, 0.70, 0.70, 0.71, 0.69]  # differences 2, 2, -1, 4, 2 points: mean 1.8, std sqrt(12.8 / 4)


def paired_runs():
    rows = [("intersection-1", "proposed", "step-by-step", "top-mse", "top-mse", PROPOSED),
            ("intersection-1", "sha2020", "step-by-step", "top-mse", "top-mse", BASELINE),
            ("intersection-1", "proposed", "step-by-step", "mse", "top-mse", [0.60, 0.61, 0.62, 0.63, 0.64]),
            ("intersection-1", "sha2020", "step-by-step", "mse", "top-mse", [0.61, 0.62, 0.63, 0.64, 0.65]),
            ("intersection-1", "identity", None, None, None, [0.1] * 5)]
    return runs(rows).assign(segmentation="ground-truth", profile="quick")


def test_paired_differences_by_hand():
    from synthcal.eval.statistics import paired_frame

    cells = paired_frame(paired_runs(), "proposed", "sha2020").set_index("loss")
    top = cells.loc["top-mse"]
    assert top["mean"] == pytest.approx(1.8) and top["std"] == pytest.approx(np.sqrt(12.8 / 4))
    assert (top["n_pairs"], top["a_wins"]) == (5, 4)
    assert top["paper"] == pytest.approx(87.91 - 85.94)  # the paper's proposed − sha2020, same cell
    mse = cells.loc["mse"]
    assert mse["mean"] == pytest.approx(-1.0) and mse["std"] == pytest.approx(0.0, abs=1e-9) and mse["a_wins"] == 0
    assert mse["paper"] == pytest.approx(85.65 - 84.41)
    # A seed without its partner is not a pair.
    partial = paired_runs()
    partial = partial[~((partial["model"] == "sha2020") & (partial["seed"] == 4))]
    assert paired_frame(partial, "proposed", "sha2020").set_index("loss").loc["top-mse", "n_pairs"] == 4


def test_paired_t_interval_and_p_agree_with_scipys_paired_t_test():
    from scipy import stats

    from synthcal.eval.statistics import paired_frame

    top = paired_frame(paired_runs(), "proposed", "sha2020").set_index("loss").loc["top-mse"]
    test = stats.ttest_rel(np.multiply(PROPOSED, 100), np.multiply(BASELINE, 100))
    interval = test.confidence_interval(0.95)
    assert (top["t_low"], top["t_high"], top["p"]) == pytest.approx((interval.low, interval.high, test.pvalue))
    # Closed form too: mean ± t_{0.975, 4} · sd / √5.
    half = stats.t.ppf(0.975, 4) * np.sqrt(12.8 / 4) / np.sqrt(5)
    assert top["t_high"] - top["mean"] == pytest.approx(half)
    assert np.isnan(top["boot_low"])  # no per-image scores given: no bootstrap


def per_image_scores(n_images, seeds=5, shift=0.02, rng_seed=1):
    """Per-image scores of two runs per seed (B's = A's − shift + noise) and a reader over them."""
    rng = np.random.default_rng(rng_seed)
    scores = {}
    for seed in range(seeds):
        a = rng.uniform(0.5, 0.9, n_images)
        scores[f"a{seed}"] = pd.Series(a, index=np.arange(n_images) * 3)
        scores[f"b{seed}"] = pd.Series(np.clip(a - shift + rng.normal(0, 0.1, n_images), 0, 1),
                                       index=np.arange(n_images) * 3)
    frame = pd.DataFrame([dict(dataset="intersection-1", model=m, seed=s, iou=scores[f"{m[0]}{s}"].mean(),
                               run_id=f"{m[0]}{s}") for s in range(seeds) for m in ("aa", "bb")])
    return frame, scores.get


def test_bootstrap_interval_contains_the_mean_shrinks_with_images_and_is_reproducible():
    from synthcal.eval.statistics import BOOTSTRAP_RESAMPLES, format_paired, paired_frame

    widths = []
    for n_images in (20, 500):
        frame, reader = per_image_scores(n_images)
        cell = paired_frame(frame, "aa", "bb", per_image=reader).iloc[0]
        assert cell["boot_low"] < cell["mean"] < cell["boot_high"]
        widths.append(cell["boot_high"] - cell["boot_low"])
        again = paired_frame(frame, "aa", "bb", per_image=reader).iloc[0]
        assert (again["boot_low"], again["boot_high"]) == (cell["boot_low"], cell["boot_high"])
    assert widths[1] < widths[0] / 3  # ~√25 = 5 times narrower with 25 times the images
    text = format_paired(frame, "aa", "bb", per_image=reader)
    assert f"{BOOTSTRAP_RESAMPLES} resamples" in flat(text) and "95 % CI (bootstrap)" in text.splitlines()[0]


def test_one_seed_has_an_undefined_t_interval_but_a_bootstrap():
    from synthcal.eval.statistics import format_paired, paired_frame

    frame, reader = per_image_scores(50, seeds=1)
    cell = paired_frame(frame, "aa", "bb", per_image=reader).iloc[0]
    assert np.isnan(cell["t_low"]) and np.isnan(cell["p"]) and cell["boot_low"] < cell["mean"] < cell["boot_high"]
    row = format_paired(frame, "aa", "bb", per_image=reader).splitlines()[2].split(" | ")
    assert row[2] == "undefined (1 seed)" and row[3].startswith("[") and row[4] == "–" and "nan" not in row
    assert row[5] == f"{int(cell['a_wins'])} of 1"


def test_paired_over_another_key_and_other_metrics():
    from synthcal.eval.statistics import format_paired, paired_frame

    cells = paired_frame(paired_runs(), "top-mse", "mse", key="loss").set_index("model")
    assert cells.loc["proposed", "mean"] == pytest.approx(np.mean(np.subtract(PROPOSED, [.60, .61, .62, .63, .64]))
                                                          * 100)
    assert cells.loc["proposed", "paper"] == pytest.approx(87.91 - 85.65)
    frame = paired_runs().assign(iou_part=lambda f: f["iou"] / 2)
    text = format_paired(frame, "proposed", "sha2020", value="iou_part")
    assert "| intersection-1 | top-mse | +0.90 ± 0.89 | [-0.21, +2.01] | – | 0.088 | 4 of 5 | – |" in text
    with pytest.raises(ValueError, match="no paired runs"):
        paired_frame(paired_runs(), "proposed", "nobody")


def test_each_paired_cell_has_a_verdict_on_the_papers_difference():
    from synthcal.eval.statistics import UNDECIDED, format_paired, paired_frame

    by_model = paired_frame(paired_runs(), "proposed", "sha2020").set_index("loss")
    # Top-MSE: [-0.42, +4.02] holds both 0 and the paper's +1.97; MSE: -1 point on every seed, the paper +1.24.
    assert by_model.loc["top-mse", "verdict"] == UNDECIDED
    assert by_model.loc["mse", "verdict"] == "opposite"
    # Over the loss: +9.4 points, the interval clear of 0 on the side of the paper's +2.26.
    by_loss = paired_frame(paired_runs(), "top-mse", "mse", key="loss").set_index("model")
    assert by_loss.loc["proposed", "verdict"] == "consistent with the paper"
    text = format_paired(paired_runs(), "proposed", "sha2020")
    assert text.splitlines()[0].endswith("| verdict |") and "| -1.00 ± 0.00 |" in text and text.count("| opposite |") == 1


def test_table_paired_command_on_hand_made_run_records(tmp_path, capsys):
    from synthcal.cli import main

    for row in paired_runs().to_dict("records"):
        estimator = {"sha2020": "baseline"}.get(row["model"], row["model"])
        run_id = f"{row['model']}_{row['loss']}_s{row['seed']}"
        folder = tmp_path / "runs" / run_id
        folder.mkdir(parents=True)
        run = {"dataset": row["dataset"], "model": row["model"], "estimator": estimator, "seed": row["seed"],
               "training": row["training"], "loss": row["loss"], "matching": row["matching_score"],
               "segmentation": None if pd.isna(row["training"]) else row["segmentation"], "profile": "quick"}
        summary = {"iou": row["iou"], "iou_weighted": row["iou"], "completeness": 1.0, "n_images": 8,
                   "iou_part": row["iou"] / 2}
        (folder / "run.json").write_text(json.dumps({"run": run, "id": run_id, "status": "ok", "summary": summary}))
        # Per image: the run's mean on 7 of 8 images, the 8th skipped (NaN), as metrics.csv stores them.
        pd.DataFrame({"pool_index": np.arange(8) + 10, "iou": [row["iou"]] * 7 + [np.nan]}).to_csv(
            folder / "metrics.csv", index=False)
    assert main(["table", str(tmp_path), "--paired", "proposed", "baseline"]) == 0  # baseline: sha2020's estimator
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ("| dataset | loss | proposed − sha2020 | 95 % CI (t) | 95 % CI (bootstrap) | p | "
                        "proposed > sha2020 | paper proposed − sha2020 | verdict |")
    # Every image of a run scores its mean: the bootstrap has no spread to find.
    assert lines[2] == ("| intersection-1 | top-mse | +1.80 ± 1.79 | [-0.42, +4.02] | [+1.80, +1.80] | 0.088 | 4 of 5 | "
                        "+1.97 | consistent with the paper (and with no difference) |")
    assert lines[3].startswith("| intersection-1 | mse | -1.00 ± 0.00 | [-1.00, -1.00] | [-1.00, -1.00] | < 0.001 |")
    assert main(["table", str(tmp_path), "--paired", "proposed", "identity", "--metric", "iou_part",
                 "--format", "csv"]) == 0
    csv = pd.read_csv(io.StringIO(capsys.readouterr().out)).set_index("loss")
    assert csv.loc["top-mse", "mean"] == pytest.approx((np.mean(PROPOSED) - 0.1) * 50)
    assert csv["paper"].isna().all() and csv["boot_low"].isna().all()  # metrics.csv has no iou_part
    assert main(["table", str(tmp_path), "--paired", "loss=top-mse", "loss=mse"]) == 0
    out = capsys.readouterr().out
    assert "| top-mse − mse |" in out and "identity" not in out  # a reference has no loss to pair over
    # Pairs in another segmentation or profile are other cells, each in its own row.
    unet = tmp_path / "runs" / "proposed_top-mse_s0" / "run.json"
    record = json.loads(unet.read_text())
    record["run"]["segmentation"] = "unet"
    unet.write_text(json.dumps(record))
    assert main(["table", str(tmp_path), "--paired", "proposed", "identity"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| dataset | loss | segmentation | proposed − identity |")
    assert "| intersection-1 | top-mse | unet | +60.00 | undefined (1 seed) | [+60.00, +60.00] | – | 1 of 1 | – | – |" in lines
    assert main(["table", str(tmp_path), "--paired", "proposed", "nobody"]) == 2
    assert main(["table", str(tmp_path), "--paired", "proposed", "loss=mse"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("synthcal: error: --paired: no runs with model 'nobody'; present: ")
    assert err[1] == "synthcal: error: --paired: both sides must vary the same key (value 'proposed loss=mse')"


# --- issue 25 item 6: the all-background floor ---------------------------------------------


def test_background_floor_is_sklearns_weighted_jaccard_of_an_all_background_estimate():
    from sklearn.metrics import jaccard_score

    from synthcal.eval.statistics import background_floor

    rng = np.random.default_rng(3)
    truths = rng.choice(4, size=(4, 6, 9), p=[0.6, 0.2, 0.15, 0.05]).astype(np.uint8)
    truths[1] = 0  # a view of background only: the estimate is right
    truths[2, :, :4] = 2  # and one with a lot of class 2
    zeros = np.zeros(truths.shape[1:], np.uint8)
    expected = np.mean([jaccard_score(t.ravel(), zeros.ravel(), average="weighted") for t in truths])
    assert background_floor(truths, "iou_weighted") == pytest.approx(expected)
    assert background_floor(truths, "iou_weighted") == pytest.approx(np.mean([np.mean(t == 0) ** 2 for t in truths]))
    assert background_floor(truths[[0, 2, 3]], "iou") == 0.0  # no foreground predicted
    with pytest.raises(ValueError, match="iou_part"):
        background_floor(truths, "iou_part")


def test_iou_weighted_tables_print_the_floor_on_a_line_of_its_own():
    frame = MATCHING.assign(iou_weighted=MATCHING["iou"])
    lines = format_table(frame, "matching", value="iou_weighted", floors={"intersection-1": 52.871}).splitlines()
    assert "all-background floor: intersection-1 52.87" in lines  # two datasets: named
    one = frame[frame["dataset"] == "intersection-1"]
    assert "all-background floor: 52.87" in format_table(one, "matching", floors={"intersection-1": 52.871})
    assert "floor" not in format_table(one, "matching")


# --- issue 24 item 5: tables a person can read -------------------------------------------


def test_plurals_and_one_seed():
    from synthcal.eval.tables import counted

    assert (counted(1, "seed"), counted(2, "run"), counted(0, "run")) == ("1 seed", "2 runs", "0 runs")
    one = MATCHING[MATCHING["dataset"] == "worldcup2014"]
    text = flat(format_table(one, "matching"))
    assert "over 1 seed." in text and "1 seeds" not in text


def test_segmentation_is_said_of_the_models_that_read_it():
    models = runs([("intersection-1", m, "step-by-step", "top-mse", "top-mse", [0.6, 0.62]) for m in
                   ("sha2020", "proposed", "sift")]).assign(segmentation="ground-truth")
    models.loc[models["model"] == "sift", ["segmentation", "training", "loss", "matching_score"]] = None
    text = flat(format_table(models, "models"))
    assert "segmentation: the true semantic maps (ground-truth) (read by sha2020, proposed only)" in text
    assert "read by" not in flat(format_table(models[models["model"] != "sift"], "models"))


def test_a_report_states_the_legend_once_wrapped(tmp_path):
    from synthcal.eval.report import results_tables

    frame = pd.concat([paired_runs(), paired_runs().assign(profile="smoke")], ignore_index=True)
    blocks = list(results_tables(frame, None, "md", False, "iou"))
    text = "".join(blocks)
    assert text.count("### ") == 2 and flat(text).count("Cells: mean ± std over seeds") == 1
    assert max(len(line) for line in text.splitlines() if not line.startswith("|")) <= CAPTION_WIDTH


def test_an_entry_points_name_wins_over_a_dotted_path_to_the_same_class(monkeypatch):
    from importlib.metadata import EntryPoint

    from synthcal.estimators import registry
    from synthcal.eval.report import one_label, results_tables

    real = registry.estimator_entry_points()
    fake = EntryPoint(name="ordered", value="collections:OrderedDict", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "estimator_entry_points", lambda: [*real, fake])
    rows = pd.DataFrame({"dataset": "intersection-1", "seed": [0, 1, 0, 1, 0, 1],
                         "model": ["ordered", "ordered", "OrderedDict", "OrderedDict", "identity", "identity"],
                         "estimator": ["ordered"] * 2 + ["collections:OrderedDict"] * 2 + ["identity"] * 2,
                         "iou": [0.5, 0.6, 0.5, 0.6, 0.1, 0.1], "run_id": list("abcdef"), "training": None,
                         "loss": None, "matching_score": None, "segmentation": None, "profile": None})
    labelled = one_label(rows)
    assert sorted(labelled["model"]) == ["identity", "identity", "ordered", "ordered"]
    assert list(labelled["run_id"]) == list("abef")  # the entry point's runs kept
    # A path run alone (no run under the entry point) is relabelled, not dropped.
    alone = one_label(rows[rows["estimator"] != "ordered"])
    assert list(alone["model"]) == ["ordered", "ordered", "identity", "identity"]
    table = "".join(results_tables(rows, "models", "md", False, "iou"))
    assert table.splitlines()[0] == "| dataset | identity | ordered |"  # one column each


def test_paper_figure_is_the_csv_row_for_its_keys():
    shared = pd.read_csv(ROOT / "synthcal" / "data" / "paper_iou.csv")
    for row in shared.sample(5, random_state=0).to_dict("records"):
        assert paper_figure(row) == pytest.approx(row["iou_percent"])
    row = shared.iloc[0].to_dict()
    # our label for the paper's dataset, through the aliases; a label it lacks has no figure
    assert paper_figure(dict(row, dataset="ours"), {"ours": row["dataset"]}) == pytest.approx(row["iou_percent"])
    assert np.isnan(paper_figure(dict(row, dataset="ours")))
    assert np.isnan(paper_figure(dict(row, loss="no-such-loss")))
    with pytest.raises(ValueError, match="lacks key"):
        paper_figure({k: row[k] for k in KEYS if k != "loss"})


def test_colliding_runs_are_named_by_run_id_with_the_way_out():
    twice = pd.concat([MATCHING.iloc[:1], MATCHING.iloc[:1]]).assign(run_id=["old-run", "new-run"])
    with pytest.raises(ValueError) as raised:
        format_table(pd.concat([MATCHING.iloc[1:], twice]), "matching")
    text = str(raised.value)
    assert "old-run: intersection-1 / proposed" in text and "new-run: intersection-1" in text
    assert "separate results folders" in text


def test_a_layout_leaves_out_the_parts_it_has_no_rows_for():
    from synthcal.eval.report import ReportError, results_tables

    def rows(dataset, segmentation, values):
        return pd.DataFrame({"dataset": dataset, "seed": range(len(values)), "model": "template",
                             "estimator": "template", "iou": values, "run_id": [f"{dataset}-{segmentation}-{s}"
                                                                               for s in range(len(values))],
                             "training": None, "loss": None, "matching_score": None,
                             "segmentation": segmentation, "profile": None})

    # mixed runs only on true maps, own-dictionary runs on both: the UNet part has nothing for `mixed`
    frame = pd.concat([rows("mixed-1", "ground-truth", [0.2, 0.3]), rows("intersection-1", "ground-truth", [0.5, 0.6]),
                       rows("intersection-1", "unet", [0.4, 0.5])], ignore_index=True)
    mixed = "".join(results_tables(frame, "mixed", "md", False, "iou"))
    assert "| mixed-1 | 25.00 ± 7.07 |" in mixed and "intersection-1" not in mixed
    models = "".join(results_tables(frame, "models", "md", False, "iou"))
    assert "### segmentation: unet" in models and "45.00 ± 7.07" in models and "mixed-1" not in models
    with pytest.raises(ReportError, match="no mixed-dictionary"):
        list(results_tables(frame[~frame["dataset"].str.startswith("mixed-")], "mixed", "md", False, "iou"))
