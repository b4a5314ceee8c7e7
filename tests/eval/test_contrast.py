"""Contrasts of paired differences: (A − B) under C minus (A − B) under D, per seed, with its t interval."""

import io

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from synthcal.eval.statistics import contrast_frame, format_contrast

SEEDS = 5


def unet_runs(rng_seed: int = 4) -> tuple[pd.DataFrame, dict[tuple[str, str], np.ndarray]]:
    """Two models on true and UNet maps, two datasets, five seeds: the runs, and each (dataset, model)'s per-seed
    iou on true maps minus on UNet maps in points, computed here apart from the code under test."""
    rng = np.random.default_rng(rng_seed)
    rows, costs = [], {}
    for dataset in ("intersection-2", "intersection-3"):
        for model in ("proposed", "sha2020"):
            true = rng.uniform(0.5, 0.7, SEEDS)
            unet = true - rng.normal(0.02 if model == "proposed" else 0.0, 0.01, SEEDS)
            costs[(dataset, model)] = (true - unet) * 100
            for segmentation, values in (("ground-truth", true), ("unet", unet)):
                rows += [dict(dataset=dataset, model=model, training="step-by-step", loss="top-mse",
                              matching_score="top-mse", segmentation=segmentation, profile="quick", seed=seed,
                              iou=value) for seed, value in enumerate(values)]
    return pd.DataFrame(rows), costs


def test_contrast_is_scipys_paired_t_test_of_one_models_cost_against_the_others():
    runs, costs = unet_runs()
    cells = contrast_frame(runs, "ground-truth", "unet", "segmentation", "proposed", "sha2020").set_index("dataset")
    for dataset in ("intersection-2", "intersection-3"):
        proposed, sha2020 = costs[(dataset, "proposed")], costs[(dataset, "sha2020")]
        test = stats.ttest_rel(proposed, sha2020)
        interval = test.confidence_interval(0.95)
        cell = cells.loc[dataset]
        assert (cell["t_low"], cell["t_high"], cell["p"]) == pytest.approx((interval.low, interval.high, test.pvalue))
        assert cell["mean"] == pytest.approx(np.mean(proposed - sha2020))
        assert cell["std"] == pytest.approx(np.std(proposed - sha2020, ddof=1))
        assert (cell["n_pairs"], cell["c_wins"]) == (SEEDS, int(np.sum(proposed > sha2020)))
    # C and D swapped: the contrast changes sign, its interval mirrors.
    swapped = contrast_frame(runs, "ground-truth", "unet", "segmentation", "sha2020", "proposed").set_index("dataset")
    assert swapped["mean"].to_numpy() == pytest.approx(-cells["mean"].to_numpy())
    assert swapped["t_low"].to_numpy() == pytest.approx(-cells["t_high"].to_numpy())


def test_a_seed_lacking_one_of_its_four_runs_is_left_out():
    runs, costs = unet_runs()
    dropped = runs[~((runs["dataset"] == "intersection-2") & (runs["model"] == "sha2020")
                     & (runs["segmentation"] == "unet") & (runs["seed"] == 3))]
    cell = contrast_frame(dropped, "ground-truth", "unet", "segmentation", "proposed", "sha2020").set_index(
        "dataset").loc["intersection-2"]
    keep = np.arange(SEEDS) != 3
    expected = costs[("intersection-2", "proposed")][keep] - costs[("intersection-2", "sha2020")][keep]
    assert cell["n_pairs"] == 4 and cell["mean"] == pytest.approx(expected.mean())


def test_contrast_refuses_what_it_cannot_compute():
    runs, _ = unet_runs()
    with pytest.raises(ValueError, match="another key than the paired one"):
        contrast_frame(runs, "ground-truth", "unet", "segmentation", "ground-truth", "unet", "segmentation")
    with pytest.raises(ValueError, match="cannot pair over 'dataset'"):
        contrast_frame(runs, "ground-truth", "unet", "segmentation", "intersection-2", "intersection-3", "dataset")
    with pytest.raises(ValueError, match="no seed with all four runs"):
        contrast_frame(runs, "ground-truth", "unet", "segmentation", "proposed", "nobody")


def test_format_contrast_rows_columns_and_csv():
    runs, costs = unet_runs()
    text = format_contrast(runs, "ground-truth", "unet", "segmentation", "proposed", "sha2020")
    lines = text.splitlines()
    assert lines[0] == "| dataset | (ground-truth − unet) proposed − sha2020 | 95 % CI (t) | p | proposed > sha2020 |"
    contrast = costs[("intersection-2", "proposed")] - costs[("intersection-2", "sha2020")]
    assert lines[2].startswith(f"| intersection-2 | {contrast.mean():+.2f} ± {contrast.std(ddof=1):.2f} | [")
    assert lines[3].startswith("| intersection-3 |") and "The paper publishes no such contrast" in " ".join(lines)
    csv = pd.read_csv(io.StringIO(format_contrast(runs, "ground-truth", "unet", "segmentation", "proposed",
                                                  "sha2020", fmt="csv")))
    assert list(csv.columns) == ["dataset", "mean", "std", "n_pairs", "c_wins", "t_low", "t_high", "p"]


def _archive(runs: pd.DataFrame, path) -> None:
    """``runs`` as a runs archive of `synthcal table --layout runs --format csv` (what the CLI reads)."""
    runs = runs.assign(estimator=runs["model"].replace({"sha2020": "baseline"}), dictionary="split", status="ok",
                       run_id=[f"r{i}" for i in range(len(runs))])
    choices = ["learning_rate", "unet_epochs", "stn_epochs", "unet_missed", "seconds"]
    runs.reindex(columns=[*runs, *choices]).to_csv(path, index=False)


def test_table_between_command_across_two_archives(tmp_path, capsys):
    from synthcal.cli import main

    runs, costs = unet_runs()
    _archive(runs[runs["segmentation"] == "ground-truth"], tmp_path / "true.csv")
    _archive(runs[runs["segmentation"] == "unet"], tmp_path / "unet.csv")
    paired = ["--paired", "segmentation=ground-truth", "segmentation=unet"]
    assert main(["table", str(tmp_path / "true.csv"), "--against", str(tmp_path / "unet.csv"), *paired,
                 "--between", "proposed", "baseline", "--format", "csv"]) == 0  # baseline: sha2020's estimator name
    csv = pd.read_csv(io.StringIO(capsys.readouterr().out)).set_index("dataset")
    contrast = costs[("intersection-3", "proposed")] - costs[("intersection-3", "sha2020")]
    assert csv.loc["intersection-3", "mean"] == pytest.approx(contrast.mean())
    assert main(["table", str(tmp_path / "true.csv"), "--against", str(tmp_path / "unet.csv"), *paired,
                 "--between", "proposed", "sha2020"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "Across two results folders" in out and "(ground-truth (true.csv) − unet (unet.csv)) proposed − sha2020" in out
    # Bad requests: named, exit 2, nothing printed on stdout.
    for args, message in (
        (["--between", "proposed", "sha2020"], "--between needs --paired A B"),
        ([*paired, "--between", "proposed", "nobody"], "--between: no runs with model 'nobody'"),
        ([*paired, "--between", "segmentation=unet", "segmentation=ground-truth"],
         "--between must vary another key than --paired's 'segmentation'"),
        ([*paired, "--between", "proposed", "loss=top-mse"], "--between: both sides must vary the same key"),
    ):
        assert main(["table", str(tmp_path / "true.csv"), "--against", str(tmp_path / "unet.csv"), *args]) == 2
        captured = capsys.readouterr()
        assert captured.out == "" and message in captured.err, (args, captured.err)
