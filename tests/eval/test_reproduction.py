"""``synthcal table --layout report``: the paired CI and the verdict against a computation by hand."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from run_records import write_run as _write_run
from scipy import stats

import synthcal
from synthcal.cli import main
from synthcal.eval.reproduction import verdict

SEEDS = range(5)
# Per loss: sha2020's per-seed IoU and proposed − sha2020 per seed (fractions), chosen so that the three
# verdicts come out (the paper's proposed − sha2020 is positive in each cell).
BASE = np.array([0.60, 0.62, 0.58, 0.61, 0.63])
# The classes the proposed Dice runs' UNets missed, per seed (None: a run that recorded nothing).
MISSED = [[], [3], [], [1, 3], None]
SHIFTS = {"top-mse": np.array([0.030, 0.025, 0.035, 0.020, 0.028]),  # CI well above 0
          "mse": np.array([-0.030, -0.025, -0.035, -0.020, -0.028]),  # CI well below 0
          "dice": np.array([0.004, -0.006, 0.002, -0.003, 0.001])}  # CI around 0, far from the paper's


def _paper(model: str, loss: str) -> float:
    """The published figure, read from the packaged CSV directly."""
    paper = pd.read_csv(Path(__file__).parents[2] / "synthcal" / "data" / "paper_iou.csv")
    hit = paper[(paper["dataset"] == "intersection-1") & (paper["model"] == model) & (paper["loss"] == loss)
                & (paper["training"] == "step-by-step") & (paper["matching_score"] == "top-mse")]
    return float(hit["iou_percent"].iloc[0])


def test_runs_whose_validation_tied_every_rate_are_named_after_the_tables(tmp_path, capsys):
    """A run whose every learning rate scored the same on validation chose by a tie (mixed-5's collapsed STNs)."""
    _write_run(tmp_path, "sha2020", "top-mse", 0, 0.1, 0.0001, 100.0, scores=[1.317, 1.317, 1.317])
    _write_run(tmp_path, "sha2020", "top-mse", 1, 0.1, 0.0003, 100.0, scores=[1.317, 1.316, 1.317])
    _write_run(tmp_path, "proposed", "top-mse", 0, 0.1, 0.0001, 100.0)
    assert main(["table", str(tmp_path)]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if "could not tell" in line]
    assert lines == ["validation could not tell the learning_rate values apart (each scored 1.317): "
                     "intersection-1_sha2020_top-mse_s0 (its chosen learning_rate is a tie; docs/reproduction.md, "
                     "mixed-5)"]


def test_report_csv_interval_and_verdict_match_a_hand_computation(tmp_path, capsys):
    for loss, shift in SHIFTS.items():
        for seed in SEEDS:
            _write_run(tmp_path, "sha2020", loss, seed, BASE[seed], 0.001, 100.0 + seed)
            _write_run(tmp_path, "proposed", loss, seed, BASE[seed] + shift[seed], 0.0003, 200.0 + 10 * seed,
                       unet_epochs=20 + seed if loss == "dice" else None,
                       missed=MISSED[seed] if loss == "dice" else None)
    _write_run(tmp_path, "proposed", "top-mse", 0, 0.7, None, 50.0, dataset="intersection-2")  # no sha2020 pair
    assert main(["table", str(tmp_path), "--layout", "report", "--format", "csv"]) == 0
    out, err = capsys.readouterr()
    report = pd.read_csv(io.StringIO(out), keep_default_na=False, na_values=[""])
    # The runs whose UNet missed a class are named after the table (off stdout for CSV), as failed runs are.
    assert sorted(line.split(" (")[0] for line in err.splitlines() if line.startswith("UNet missed")) == [
        "UNet missed class 1, 3: intersection-1_proposed_dice_s3", "UNet missed class 3: intersection-1_proposed_dice_s1"]
    expected = {"top-mse": "consistent with the paper", "mse": "opposite", "dice": "not reproduced"}
    for loss, shift in SHIFTS.items():
        row = report[(report["dataset"] == "intersection-1") & (report["loss"] == loss)
                     & (report["model"] == "proposed")].iloc[0]
        d = 100.0 * shift
        half = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
        assert row["difference"] == pytest.approx(d.mean())
        assert (row["t_low"], row["t_high"]) == pytest.approx((d.mean() - half, d.mean() + half))
        assert row["p"] == pytest.approx(stats.ttest_rel(BASE + shift, BASE).pvalue)
        assert row["wins"] == int((shift > 0).sum()) and row["n_pairs"] == 5
        paper_difference = _paper("proposed", loss) - _paper("sha2020", loss)
        assert row["paper"] == pytest.approx(_paper("proposed", loss))
        assert row["paper_difference"] == pytest.approx(paper_difference)
        assert row["verdict"] == expected[loss]
        assert row["learning_rates"] == "0.0003, 0.0003, 0.0003, 0.0003, 0.0003"
        assert row["stn_epochs"] == "10, 11, 12, 13, 14" and row["seconds"] == pytest.approx(220.0)
        assert row["unet_epochs"] == ("20, 21, 22, 23, 24" if loss == "dice" else "–")
        assert row["unet_missed"] == ("none, 3, none, 1+3, –" if loss == "dice" else "–")
        assert row["mean"] == pytest.approx(100.0 * np.mean(BASE + shift))
        assert row["std"] == pytest.approx(100.0 * np.std(BASE + shift, ddof=1))
    # The Python API's report is the CSV's numbers.
    api = synthcal.report(tmp_path)
    pd.testing.assert_frame_equal(api[["model", "loss", "difference", "t_low", "t_high", "verdict"]],
                                  report[["model", "loss", "difference", "t_low", "t_high", "verdict"]],
                                  check_dtype=False)
    lone = report[report["dataset"] == "intersection-2"].iloc[0]
    assert lone["verdict"] == "–" and np.isnan(lone["t_low"]) and lone["learning_rates"] == "–"
    assert set(report.loc[report["model"] == "sha2020", "verdict"]) == {"–"}
    # Markdown: the same cells, "–" where there is no pair.
    assert main(["table", str(tmp_path), "--layout", "report"]) == 0
    text = capsys.readouterr().out
    assert "| intersection-2 | top-mse | proposed | 1 | 70.00 | – | – | – | – |" in text
    # The UNet's epochs get a column of their own, before the STN's, once a run kept one.
    # ... and the classes its UNet missed one after, once a run missed one.
    assert "| lr (per seed) | UNet epochs (per seed) | UNet missed (per seed) | STN epochs (per seed) |" in text
    assert "| 20, 21, 22, 23, 24 | none, 3, none, 1+3, – | 10, 11, 12, 13, 14 |" in text
    assert "reproduced |" in text and "| reproduced" not in text


def test_report_shows_no_missed_class_column_where_every_unet_learnt_every_class(tmp_path, capsys):
    for seed in SEEDS[:3]:
        for model, iou in (("sha2020", BASE[seed]), ("proposed", BASE[seed] + 0.01)):
            _write_run(tmp_path, model, "top-mse", seed, iou, 0.001, 100.0, unet_epochs=9, missed=[])
    assert main(["table", str(tmp_path), "--layout", "report", "--format", "csv"]) == 0
    report = pd.read_csv(io.StringIO(capsys.readouterr().out), keep_default_na=False, na_values=[""])
    assert set(report["unet_missed"]) == {"none, none, none"}
    assert main(["table", str(tmp_path), "--layout", "report"]) == 0
    assert "UNet missed" not in capsys.readouterr().out.split("\n\n")[0]  # the table, not its caption


def test_report_without_sha2020_runs_gives_each_cell_without_a_difference(tmp_path, capsys):
    for seed in SEEDS[:2]:
        _write_run(tmp_path, "proposed", "top-mse", seed, BASE[seed], 0.001, 100.0)
    assert main(["table", str(tmp_path), "--layout", "report", "--format", "csv"]) == 0
    row = pd.read_csv(io.StringIO(capsys.readouterr().out)).iloc[0]
    assert row["n_seeds"] == 2 and np.isnan(row["difference"]) and row["verdict"] == "–"
    assert row["mean"] == pytest.approx(100.0 * BASE[:2].mean())


def test_paired_against_another_folder_pairs_the_same_cell_and_seed_across_folders(tmp_path, capsys):
    """Two folders holding the same cells under two settings: A from the first, B from the second."""
    first, second = tmp_path / "weighted", tmp_path / "plain"
    shift = {"sha2020": np.array([0.02, -0.01, 0.03, 0.00, 0.01]), "proposed": np.array([0.05, 0.04, 0.06, 0.03, 0.05])}
    for model, offset in (("sha2020", 0.0), ("proposed", -0.03)):
        for seed in SEEDS:
            b = BASE[seed] + offset
            for folder, iou in ((first, b + shift[model][seed]), (second, b)):
                _write_run(folder, model, "top-mse", seed, iou, 0.001, 100.0)
                # Per image: the run's value on each of 4 images, so that A − B is the same on every image.
                pd.DataFrame({"pool_index": range(4), "iou": iou}).to_csv(
                    folder / "runs" / f"intersection-1_{model}_top-mse_s{seed}" / "metrics.csv", index=False)
    _write_run(second, "sha2020", "top-mse", 7, 0.5, 0.001, 100.0)  # a seed the first folder lacks: no pair
    assert main(["table", str(first), "--against", str(second), "--paired", "loss=top-mse", "loss=top-mse",
                 "--format", "csv"]) == 0
    paired = pd.read_csv(io.StringIO(capsys.readouterr().out)).set_index("model")
    for model, d in shift.items():
        d = 100.0 * d
        row = paired.loc[model]
        assert row["n_pairs"] == 5 and row["a_wins"] == int((d > 0).sum())
        assert row["mean"] == pytest.approx(d.mean())
        half = stats.t.ppf(0.975, 4) * d.std(ddof=1) / np.sqrt(5)
        assert (row["t_low"], row["t_high"]) == pytest.approx((d.mean() - half, d.mean() + half))
        # Each side's per-image values read from its own folder: every resample gives the mean difference.
        assert (row["boot_low"], row["boot_high"]) == pytest.approx((d.mean(), d.mean()))
    api = synthcal.paired_differences(first, "loss=top-mse", "loss=top-mse", against=second).set_index("model")
    pd.testing.assert_frame_equal(api.loc[paired.index, ["mean", "t_low", "t_high", "boot_low", "boot_high"]],
                                  paired[["mean", "t_low", "t_high", "boot_low", "boot_high"]])
    text = main(["table", str(first), "--against", str(second), "--paired", "loss=top-mse", "loss=top-mse"])
    assert text == 0 and "top-mse (weighted) − top-mse (plain)" in capsys.readouterr().out
    # The same setting in two folders is no claim of the paper: no figure, no verdict.
    assert paired["paper"].isna().all() and set(paired["verdict"]) == {"–"}
    # Within one folder the same runs cannot pair with themselves; across, a side absent names its folder.
    assert main(["table", str(first), "--against", str(second), "--paired", "loss=top-mse", "loss=mse"]) == 2
    assert f"B, in {second}: no runs with loss 'mse'" in capsys.readouterr().err
    assert main(["table", str(first), "--against", str(second)]) == 2
    assert "--against needs --paired" in capsys.readouterr().err
    assert main(["table", str(first), "--against", str(first / "."), "--paired", "sha2020", "sha2020"]) == 2
    assert "is the results folder itself" in capsys.readouterr().err



def test_paired_against_another_folder_names_the_budget_clauses_only_one_side_records(tmp_path, capsys):
    """Fits ranked by validation `iou` in one folder, by `L_warp` in the other: no pair key shows the selection
    score, so the runs pair; the caption says what else the pairs differ in, and says nothing where they agree."""
    warp, iou, same = tmp_path / "warp", tmp_path / "iou", tmp_path / "same"
    budget = {"siamese_epochs": 10, "stn_epochs": 24}
    for seed in SEEDS:
        _write_run(warp, "proposed", "top-mse", seed, BASE[seed], 0.001, 100.0, settings=budget)
        _write_run(iou, "proposed", "top-mse", seed, BASE[seed] + 0.01, 0.001, 100.0,
                   settings={**budget, "selection_score": "iou"})
        _write_run(same, "proposed", "top-mse", seed, BASE[seed] + 0.02, 0.001, 100.0, settings=budget)
    assert main(["table", str(iou), "--against", str(warp), "--paired", "loss=top-mse", "loss=top-mse"]) == 0
    caption = " ".join(capsys.readouterr().out.split())
    assert ('training budgets differ: only A\'s record "fits ranked by validation iou"; only B\'s nothing.'
            in caption)
    assert main(["table", str(same), "--against", str(warp), "--paired", "loss=top-mse", "loss=top-mse"]) == 0
    assert "training budgets differ" not in capsys.readouterr().out

@pytest.mark.parametrize("low, high, paper, expected", [
    (1.0, 3.0, 2.0, "consistent with the paper"),  # contains d
    (2.5, 3.0, 2.0, "consistent with the paper"),  # excludes 0 on d's side, not containing d
    (-3.0, -2.5, -2.0, "consistent with the paper"),
    (-1.0, 1.0, 2.0, "not reproduced"),
    (-3.0, -0.1, 2.0, "opposite"),
    (0.1, 3.0, -2.0, "opposite"),
    (-1.0, 3.0, 2.0, "consistent with the paper (and with no difference)"),  # too wide to tell 0 from d
    (0.5, 1.0, 0.0, "not reproduced"),  # no claimed difference, one found
    (np.nan, np.nan, 2.0, "–"),
    (-1.0, 1.0, np.nan, "–"),
])
def test_verdict_rules(low, high, paper, expected):
    assert verdict(low, high, paper) == expected


def test_paired_against_another_folder_compares_two_losses_with_the_papers_figure(tmp_path, capsys):
    """Top-MSE runs kept in one folder, MSE runs in another: the paper's Top-MSE − MSE for the cell and its
    verdict, as within one folder (intersection-1, proposed, step-by-step)."""
    topological, conventional = tmp_path / "topological", tmp_path / "conventional"
    shift = np.array([-0.03, -0.02, -0.04, -0.01, -0.03])  # Top-MSE below MSE on every seed
    for seed in SEEDS:
        _write_run(topological, "proposed", "top-mse", seed, BASE[seed] + shift[seed], 0.001, 100.0)
        _write_run(conventional, "proposed", "mse", seed, BASE[seed], 0.001, 100.0)
    assert main(["table", str(topological), "--against", str(conventional), "--paired", "loss=top-mse",
                 "loss=mse", "--format", "csv"]) == 0
    row = pd.read_csv(io.StringIO(capsys.readouterr().out)).iloc[0]
    assert row["paper"] == pytest.approx(_paper("proposed", "top-mse") - _paper("proposed", "mse"))
    assert row["t_high"] < 0 < row["paper"] and row["verdict"] == "opposite"
