"""The bench harness end to end on smoke stores: oracle, failures, resume, Dask, CLI."""

import json
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
import yaml
from run_records import write_run

from synthcal.cli import main
from synthcal.eval.harness import (
    DamagedRecordWarning,
    collect_results,
    estimate_seconds,
    execute_run,
    expand_runs,
    expected_seconds,
    recorded_seconds,
    run_sweep,
    run_threads,
    table_runs,
    trained_images,
)
from synthcal.eval.runs import Run
from synthcal.eval.tables import format_table
from synthcal.generate.splits import draw_splits
from synthcal.store.splits import SplitError, read_split_indices
from synthcal.utils.machine import cpu_model

ROOT = Path(__file__).resolve().parents[2]
ORACLE = "synthcal_oracle_plugin:OracleEstimator"
FAULTY = "synthcal_faulty_plugins"
RETRY = "synthcal_retry_plugins"  # tests/eval/synthcal_retry_plugins.py


@pytest.fixture(scope="module")
def data(smoke_stores, tmp_path_factory) -> Path:
    """The five intersections at smoke size; intersection-1 with seeds 0, 1 and its mixed dictionary."""
    out = tmp_path_factory.mktemp("bench-data")
    smoke_stores.copy([f"intersection-{k}" for k in range(1, 6)], out)
    draw_splits(out / "intersection-1.zarr", seeds=[0, 1])
    return out


@pytest.fixture(autouse=True)
def plugins(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "tests"))
    monkeypatch.syspath_prepend(str(ROOT / "tests" / "eval"))


def bench(data: Path, results: Path, *estimators: str, seeds: str = "0-1", extra: tuple = ()) -> int:
    return main(["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", *estimators,
                 "--seeds", seeds, "--results", str(results), "--profile", "smoke", "--device", "cpu", "--quiet",
                 *extra])


def test_oracle_scores_one_through_bench(data, tmp_path, capsys):
    assert bench(data, tmp_path, ORACLE, "identity") == 0
    frame = collect_results(tmp_path)
    oracle = frame[frame["model"] == "OracleEstimator"]
    assert len(oracle) == 2 and (oracle["status"] == "ok").all()
    assert (oracle["iou"] == 1.0).all() and (oracle["completeness"] == 1.0).all()
    for run_id in oracle["run_id"]:
        per_image = pd.read_csv(tmp_path / "runs" / run_id / "metrics.csv")
        assert len(per_image) == 8 and (per_image["iou"] == 1.0).all() and not per_image["failed"].any()
        # Every metric of SPEC §8 is stored per image, the three readings of the paper's IoU included.
        assert (per_image[["iou_bg", "iou_weighted", "iou_part", "iou_whole"]] == 1.0).all().all()
    assert "| intersection-1 | 100.00 ± 0.00 |" in capsys.readouterr().out.replace("**", "")
    # The runs archive of real records prints the same tables as the folder, and writes itself again unchanged.
    archive = tmp_path / "runs.csv"
    assert main(["table", str(tmp_path), "--layout", "runs", "--format", "csv"]) == 0
    archive.write_text(capsys.readouterr().out)
    for layout in ("runs", "models", "report"):
        assert main(["table", str(tmp_path), "--layout", layout, "--format", "csv"]) == 0
        from_folder = capsys.readouterr().out
        assert main(["table", str(archive), "--layout", layout, "--format", "csv"]) == 0
        assert capsys.readouterr().out == from_folder


def test_failing_estimators_score_zero_and_the_sweep_goes_on(data, tmp_path, capsys):
    estimators = (f"{FAULTY}:RaisingEstimator", f"{FAULTY}:NaNEstimator", "identity")
    assert bench(data, tmp_path, *estimators, seeds="0") == 1  # a failed run: exit status 1
    summary = capsys.readouterr().out
    frame = collect_results(tmp_path).set_index("model")
    for model, reason in (("RaisingEstimator", "predict: ValueError: this estimator always fails"),
                          ("NaNEstimator", "non-finite entries")):
        rows = frame.loc[[model]]
        assert (rows["iou"] == 0).all() and (rows["completeness"] == 0).all() and len(rows) == 1
        per_image = pd.read_csv(tmp_path / "runs" / rows["run_id"].iloc[0] / "metrics.csv")
        assert per_image["failed"].all() and (per_image["failure"] == reason).all()
    assert (frame.loc[["RaisingEstimator", "NaNEstimator"], "status"] == "failed").all()
    # Every estimate invalid: a failed run with its reason, in bench's summary and in `table`.
    nan_run = frame.loc["NaNEstimator", "run_id"]
    assert frame.loc["NaNEstimator", "error"] == "all 8 estimates invalid: non-finite entries"
    assert f"failed: {nan_run}: all 8 estimates invalid: non-finite entries" in summary
    assert main(["table", str(tmp_path), "--metric", "iou_weighted"]) == 0
    out = capsys.readouterr().out
    assert f"failed: {nan_run}: all 8 estimates invalid" in out and "iou_weighted (%)" in out
    assert main(["table", str(tmp_path), "--metric", "reproj_px"]) == 0
    out = capsys.readouterr().out
    assert "reproj_px (px)" in out and "| inf |" in out  # the NaN estimator's median image failed
    with pytest.raises(SystemExit) as refused:
        main(["table", str(tmp_path), "--metric", "nope"])
    assert refused.value.code == 2
    identity = frame.loc[["identity"]]
    assert (identity["completeness"] == 1).all() and (identity["iou"] > 0).all()


def test_killed_sweep_resumes_to_the_same_table(data, tmp_path, monkeypatch):
    estimators = ["identity", f"{FAULTY}:InterruptingEstimator", "template"]
    runs = expand_runs(data, ["intersection-1"], estimators, [0])
    assert [r.model for r in runs] == ["identity", "InterruptingEstimator", "template"]
    reference = run_sweep(runs, tmp_path / "uninterrupted", device="cpu", progress=False)

    marker = tmp_path / "interrupt-now"
    marker.touch()
    monkeypatch.setenv("SYNTHCAL_TEST_INTERRUPT", str(marker))
    results = tmp_path / "interrupted"
    with pytest.raises(KeyboardInterrupt):  # the plug-in sends SIGINT to the sweep, as Ctrl-C would
        run_sweep(runs, results, device="cpu", progress=False)
    finished = {p.parent.name: p.stat().st_mtime_ns for p in (results / "runs").glob("*/run.json")}
    assert list(finished) == [runs[0].id]  # the identity run, before the interruption
    assert not (results / "runs" / runs[1].id).exists()
    with pytest.raises(ProcessLookupError):  # the interrupted run's process was killed with the sweep
        os.kill(int(marker.with_suffix(".pid").read_text()), 0)

    resumed = run_sweep(runs, results, device="cpu", progress=False)
    assert {name: (results / "runs" / name / "run.json").stat().st_mtime_ns for name in finished} == finished
    assert len(resumed) == len(runs)
    assert format_table(table_runs(resumed), "models") == format_table(table_runs(reference), "models")


def test_axes_collapse_and_ids_are_stable(data):
    runs = expand_runs(data, ["intersection-1"], ["identity", "proposed"], [0, 1],
                       losses=("top-mse", "mse"), segmentations=("ground-truth",))
    identity = [r for r in runs if r.model == "identity"]
    proposed = [r for r in runs if r.model == "proposed"]
    assert len(identity) == 2 and all(r.loss is None and r.segmentation is None for r in identity)
    assert len(proposed) == 4 and {r.loss for r in proposed} == {"top-mse", "mse"}
    assert all(r.training == "step-by-step" and r.segmentation == "ground-truth" for r in proposed)
    again = expand_runs(data, ["intersection-1"], ["identity", "proposed"], [0, 1],
                        losses=("top-mse", "mse"), segmentations=("ground-truth",))
    assert [r.id for r in again] == [r.id for r in runs] and len({r.id for r in runs}) == 6


def test_missing_seed_or_store_stops_before_running(data, tmp_path, capsys):
    with pytest.raises(SplitError, match="seed"):
        expand_runs(data, ["intersection-1"], ["identity"], [7])
    assert bench(data, tmp_path, "identity", seeds="7") == 2
    assert main(["bench", "--data", str(data), "--datasets", "nowhere", "--estimator", "identity",
                 "--results", str(tmp_path), "--seeds", "0"]) == 2
    assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "no-such",
                 "--results", str(tmp_path), "--seeds", "0"]) == 2
    err = capsys.readouterr().err
    assert "no such store" in err and "unknown estimator 'no-such'" in err
    assert not (tmp_path / "runs").exists()


def test_mixed_dictionary_runs_under_its_paper_label(data, tmp_path):
    runs = expand_runs(data, ["mixed-1"], ["template"], [0])
    assert runs[0].mixed is True and runs[0].store.endswith("intersection-1.zarr")
    folder = execute_run(runs[0], tmp_path, device="cpu")
    record = json.loads((folder / "run.json").read_text())
    assert record["status"] == "ok" and record["run"]["dataset"] == "mixed-1"
    frame = collect_results(tmp_path)
    assert "| mixed-1 |" in format_table(frame, "mixed")


def test_dask_scheduler_gives_the_same_results(data, tmp_path):
    from dask.distributed import LocalCluster

    runs = expand_runs(data, ["intersection-1"], ["identity", ORACLE], [0])
    local = run_sweep(runs, tmp_path / "local", device="cpu", progress=False)
    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        remote = run_sweep(runs, tmp_path / "dask", device="cpu", scheduler=cluster.scheduler_address, progress=False)
    columns = ["run_id", "iou", "iou_part", "iou_whole", "completeness"]
    pd.testing.assert_frame_equal(local[columns], remote[columns])


def test_table_and_plot_commands(data, tmp_path, capsys):
    results = tmp_path / "results"
    assert bench(data, results, "identity", "template") == 0
    capsys.readouterr()
    assert main(["table", str(results), "--format", "latex"]) == 0
    assert r"\begin{tabular}" in capsys.readouterr().out
    assert main(["table", str(results), "--format", "csv", "--compare-paper"]) == 0
    assert "paper" in capsys.readouterr().out.splitlines()[0]
    assert main(["plot", str(results), "-o", str(tmp_path / "plots"), "--count", "2"]) == 0
    for name in ("iou.png", "overlays-intersection-1.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 1000
    assert main(["table", str(tmp_path / "empty")]) == 2


def test_plot_draws_the_metric_it_is_given(data, tmp_path, monkeypatch, capsys):
    """``plot --metric``: the bars are the chosen column's mean, the label and the overlay titles name it."""
    from matplotlib.figure import Figure

    results = tmp_path / "results"
    assert bench(data, results, "identity", seeds="0") == 0
    frame = collect_results(results)
    per_image = pd.read_csv(results / "runs" / frame["run_id"].iloc[0] / "metrics.csv")
    saved: dict[str, Figure] = {}
    savefig = Figure.savefig

    def keep(fig, path, *args, **kwargs):
        saved[Path(path).name] = fig
        return savefig(fig, path, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    heights = {}
    for metric in ("iou", "iou_bg"):
        assert main(["plot", str(results), "-o", str(tmp_path / metric), "--count", "1", "--metric", metric]) == 0
        bars = saved["iou.png"].axes[0]
        assert bars.get_ylabel() == f"{metric} (%)"
        heights[metric] = [patch.get_height() for patch in bars.patches]
        assert heights[metric] == pytest.approx([100 * frame[metric].iloc[0]])
        titles = [ax.get_title() for ax in saved["overlays-intersection-1.png"].axes]
        assert titles[1] == f"identity\n{metric} {100 * per_image[metric].iloc[0]:.1f} %"
    assert heights["iou"] != pytest.approx(heights["iou_bg"])  # the two readings differ here: the bars show which
    capsys.readouterr()
    with pytest.raises(SystemExit) as refused:
        main(["plot", str(results), "-o", str(tmp_path / "x"), "--metric", "miou"])
    assert refused.value.code == 2 and "--metric: invalid choice: 'miou'" in capsys.readouterr().err


def test_reference_estimators_sit_in_every_row():
    frame = pd.DataFrame({
        "dataset": "d", "model": ["identity", "proposed", "proposed"], "training": [None, "e2e", "e2e"],
        "loss": [None, "mse", "top-mse"], "matching_score": [None, "mse", "mse"], "seed": 0,
        "iou": [0.1, 0.5, 0.6]})
    out = table_runs(frame)
    identity = out[out["model"] == "identity"]
    assert sorted(identity["loss"]) == ["mse", "top-mse"] and (identity["training"] == "e2e").all()
    assert np.allclose(identity["iou"], 0.1) and len(out) == 4


def test_reference_estimators_join_only_configurations_that_ran():
    """Keys spread together: step-by-step × top-mse and end-to-end × mse ran, so the reference runs sit in
    those two rows and not in end-to-end × top-mse or step-by-step × mse (rows with references alone); a
    reference that has a key (``oracle`` matched with ``dice``) joins only the configurations that agree,
    and one that none agrees with is kept once."""
    frame = pd.DataFrame({
        "dataset": "d", "model": ["identity", "oracle", "oracle", "proposed", "proposed"],
        "training": [None, None, None, "step-by-step", "end-to-end"], "loss": [None, None, None, "top-mse", "mse"],
        "matching_score": [None, "top-mse", "dice", "top-mse", "top-mse"], "seed": 0, "iou": [0.1, 0.2, 0.3, 0.5, 0.6]})
    out = table_runs(frame)
    rows = {(r.model, r.training, r.loss, r.matching_score) for r in out.itertuples()}
    configurations = {("step-by-step", "top-mse", "top-mse"), ("end-to-end", "mse", "top-mse")}
    assert {(t, lo, m) for name, t, lo, m in rows if name == "identity"} == configurations
    assert {(t, lo, m) for name, t, lo, m in rows if name == "oracle" and m == "top-mse"} == configurations
    dice = out[(out["model"] == "oracle") & (out["matching_score"] == "dice")]
    assert len(dice) == 1 and dice["training"].isna().all() and np.isclose(dice["iou"].iloc[0], 0.3)
    assert len(out) == 7


def test_runs_are_isolated_and_their_failures_recorded(data, tmp_path, capsys):
    """Each misbehaving plug-in is one failed run with its reason; the mutating one scores as the
    identity it is; the identity after them all completes; ``table`` lists the failures."""
    faulty = ("SleepingEstimator", "ExitingEstimator", "SegfaultingEstimator", "UnreadableEstimator",
              "MutatingEstimator")
    assert bench(data, tmp_path, *(f"{FAULTY}:{name}" for name in faulty), "identity", seeds="0",
                 extra=("--timeout", "2")) == 1
    frame = collect_results(tmp_path).set_index("model")
    assert sorted(frame.index) == sorted([*faulty, "identity"])
    reasons = {"SleepingEstimator": "predict: timed out after 2 s",
               "ExitingEstimator": "fit: exited with status 1",
               "SegfaultingEstimator": "predict: killed by signal 11 (SIGSEGV)",
               "UnreadableEstimator": "predict: result not readable: RuntimeError: no numbers here"}
    for model, reason in reasons.items():
        row = frame.loc[model]
        assert (row["status"], row["error"], row["iou"], row["completeness"]) == ("failed", reason, 0, 0), model
        per_image = pd.read_csv(tmp_path / "runs" / row["run_id"] / "metrics.csv")
        assert per_image["failed"].all() and (per_image["failure"] == reason).all()
    identity, mutating = frame.loc["identity"], frame.loc["MutatingEstimator"]
    assert identity["status"] == "ok" and identity["completeness"] == 1 and 0 < identity["iou"] < 1
    # Zeroing the scene's classes where scoring could see them would have made every view score 1.
    assert mutating["status"] == "ok", mutating["error"]
    columns = ["iou", "iou_part", "iou_whole"]
    mutated = pd.read_csv(tmp_path / "runs" / mutating["run_id"] / "metrics.csv")[columns]
    reference = pd.read_csv(tmp_path / "runs" / identity["run_id"] / "metrics.csv")[columns]
    pd.testing.assert_frame_equal(mutated, reference)

    capsys.readouterr()
    assert main(["table", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for model, reason in reasons.items():
        assert f"{frame.loc[model, 'run_id']}: {reason}" in out


def test_damaged_run_record_is_skipped_with_a_warning_and_run_again(data, tmp_path, capsys):
    assert bench(data, tmp_path, "identity", ORACLE, seeds="0") == 0
    damaged = next((tmp_path / "runs").glob("*OracleEstimator*/run.json"))
    damaged.write_text("")
    capsys.readouterr()
    with pytest.warns(DamagedRecordWarning, match=f"{damaged}: damaged run record skipped"):
        assert main(["table", str(tmp_path)]) == 0
    assert "OracleEstimator" not in capsys.readouterr().out
    with pytest.warns(DamagedRecordWarning, match=f"{damaged}: damaged run record ignored; the run is done again"):
        assert bench(data, tmp_path, "identity", ORACLE, seeds="0") == 0
    assert json.loads(damaged.read_text())["status"] == "ok"
    assert "| intersection-1 | 100.00 |" in capsys.readouterr().out.replace("**", "")


def test_bench_and_table_errors_name_the_path(data, tmp_path, capsys):
    results = tmp_path / "a-file"
    results.write_text("not a folder")
    assert bench(data, results, "identity", seeds="0") == 2
    assert main(["table", str(tmp_path / "nowhere")]) == 2
    assert main(["table", str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"synthcal: error: --results {results}: a file of that name exists; --results names a folder"
    assert err[1:] == [f"synthcal: error: {tmp_path / 'nowhere'}: no such results folder",
                       f"synthcal: error: {tmp_path}: no finished runs"]
    with pytest.raises(SystemExit) as exit_status:
        bench(data, tmp_path, "identity", extra=("--timeout", "-1"))
    assert exit_status.value.code == 2 and "'-1' is not a number of seconds >= 0" in capsys.readouterr().err


# --- issue 14: retries, the run's identity, the profile's sizes, Ctrl-C ---------------------


def record_of(results: Path, run_id: str) -> dict:
    return json.loads((results / "runs" / run_id / "run.json").read_text())


def test_a_failed_run_is_retried_once_fixed_and_finished_runs_are_kept(data, tmp_path, monkeypatch, capsys):
    broken = tmp_path / "bug-present"
    broken.touch()
    monkeypatch.setenv("SYNTHCAL_TEST_BROKEN", str(broken))
    results = tmp_path / "results"
    assert bench(data, results, "identity", f"{RETRY}:FlakyEstimator", seeds="0") == 1
    out = capsys.readouterr().out
    first = collect_results(results).set_index("model")
    flaky_id, identity_id = first.loc["FlakyEstimator", "run_id"], first.loc["identity", "run_id"]
    assert first.loc["FlakyEstimator", "status"] == "failed"
    assert f"failed: {flaky_id}: fit: RuntimeError: not fixed yet" in out  # the reason, on the console
    kept = (results / "runs" / identity_id / "run.json").stat().st_mtime_ns

    broken.unlink()  # the plug-in's bug is fixed; the same command again
    assert bench(data, results, "identity", f"{RETRY}:FlakyEstimator", seeds="0") == 0
    out = capsys.readouterr().out
    second = collect_results(results).set_index("model")
    assert second.loc["FlakyEstimator", "run_id"] == flaky_id and second.loc["FlakyEstimator", "status"] == "ok"
    assert second.loc["FlakyEstimator", "iou"] == second.loc["identity", "iou"] > 0
    assert "2 runs (0 failed)" in out and "failed:" not in out
    assert (results / "runs" / identity_id / "run.json").stat().st_mtime_ns == kept  # not run again


def test_the_device_is_part_of_the_identity_of_runs_that_take_one(data, tmp_path):
    recording = f"{RETRY}:SizeRecordingEstimator"
    on = {device: {r.model: r for r in expand_runs(data, ["intersection-1"], [recording, "identity"], [0],
                                                   device=device)}
          for device in ("cpu", "cuda")}
    assert on["cpu"]["SizeRecordingEstimator"].device == "cpu"
    assert on["cpu"]["SizeRecordingEstimator"].id != on["cuda"]["SizeRecordingEstimator"].id
    # An estimator that takes no device runs the same wherever: one run.
    assert on["cpu"]["identity"].device is None and on["cpu"]["identity"].id == on["cuda"]["identity"].id
    auto = expand_runs(data, ["intersection-1"], [recording], [0])[0]  # auto: resolved here
    assert auto.device == ("cuda" if torch.cuda.is_available() else "cpu")
    folder = execute_run(on["cpu"]["SizeRecordingEstimator"], tmp_path)
    record = json.loads((folder / "run.json").read_text())
    assert record["device"] == record["run"]["device"] == record["history"]["device"] == "cpu"
    # The machine, read in the run's own process; a NumPy estimator's process has no torch to describe.
    assert record["machine"] == {"cpu": cpu_model(), "python": platform.python_version(), "numpy": np.__version__}


def test_bench_refuses_a_device_this_machine_lacks(data, tmp_path, capsys):
    if torch.cuda.is_available():
        pytest.skip("this machine has CUDA")
    assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "identity",
                 "--seeds", "0", "--results", str(tmp_path), "--device", "cuda"]) == 2
    assert "synthcal: error: --device: CUDA is not available on this machine (value 'cuda')" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


@pytest.fixture
def tiny_config(tmp_path) -> Path:
    """The bundled configuration with a profile ``tiny`` whose splits are smaller than the smoke stores'."""
    config = yaml.safe_load((ROOT / "synthcal" / "datasets.yaml").read_text())
    config["profiles"]["tiny"] = {"splits": {"train": 5, "test": 3, "dictionary": 4},
                                  "training": config["profiles"]["smoke"]["training"]}
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_a_profile_sizes_the_splits_bench_uses(data, tmp_path, tiny_config, capsys):
    results = tmp_path / "results"
    assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "mixed-1", "--estimator",
                 f"{RETRY}:SizeRecordingEstimator", "--seeds", "0", "--results", str(results), "--profile", "tiny",
                 "--config", str(tiny_config), "--device", "cpu", "--quiet"]) == 0
    out = capsys.readouterr().out
    # Said up front, before the sweep: what each dataset's runs use of the stored splits (24/8/12).
    plan = out.index("intersection-1 (seeds 0): train 5 of 24, test 3 of 8, dictionary 4 of 12")
    assert plan < out.index("mixed-1 (seeds 0): train 5 of 24, test 3 of 8, dictionary 4 of 12") < out.index("runs (")
    frame = collect_results(results).set_index("dataset")
    for dataset in ("intersection-1", "mixed-1"):
        record = record_of(results, frame.loc[dataset, "run_id"])
        assert record["run"]["limits"] == {"dictionary": 4, "test": 3, "train": 5}
        assert record["sizes"] == {"train": 5, "test": 3, "dictionary": 4}
        seen = record["history"]
        assert (seen["train"], seen["dictionary"], seen["test"]) == (5, 4, 3)  # what the estimator was handed
        per_image = pd.read_csv(results / "runs" / record["id"] / "metrics.csv")
        assert len(per_image) == 3  # scored on the same capped test split
        # The first ones of the stored split (its indices ascend), the same for scoring and estimator.
        stored = read_split_indices(data / "intersection-1.zarr", "test", 0)
        assert per_image["pool_index"].tolist() == stored[:3].tolist()
    # The mixed dictionary keeps an equal share of each of its four sources.
    assert record_of(results, frame.loc["mixed-1", "run_id"])["history"]["dictionary_sources"] == [1, 1, 1, 1]
    # The same runs without the profile's caps are other runs.
    smoke = expand_runs(data, ["intersection-1"], [f"{RETRY}:SizeRecordingEstimator"], [0], "tiny", device="cpu")
    assert smoke[0].id != frame.loc["intersection-1", "run_id"]


def test_prefix_positions_keep_a_prefix_or_an_equal_share_per_source():
    from synthcal.eval.harness import prefix_positions

    assert prefix_positions(10, 4).tolist() == [0, 1, 2, 3]
    assert prefix_positions(3, 10).tolist() == [0, 1, 2] and prefix_positions(3, None).tolist() == [0, 1, 2]
    source = np.array([0, 0, 0, 1, 1, 1, 2, 2, 2])
    assert prefix_positions(9, 5, source).tolist() == [0, 1, 3, 4, 6]  # 2, 2, 1
    uneven = np.array([0, 1, 1, 1, 1])
    assert prefix_positions(5, 3, uneven).tolist() == [0, 1, 2]  # source 0 has one: source 1 gives two


def test_ctrl_c_stops_bench_with_130_and_a_rerun_resumes(data, tmp_path, monkeypatch):
    slow = tmp_path / "slow"
    slow.touch()
    results = tmp_path / "results"
    env = dict(os.environ, SYNTHCAL_TEST_SLOW=str(slow),
               PYTHONPATH=os.pathsep.join([str(ROOT / "tests" / "eval"), os.environ.get("PYTHONPATH", "")]))
    command = ["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "identity",
               f"{RETRY}:SlowEstimator", "--seeds", "0", "--results", str(results), "--profile", "smoke",
               "--device", "cpu", "--quiet"]
    process = subprocess.Popen([sys.executable, "-m", "synthcal.cli", *command], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    started = slow.with_suffix(".started")
    deadline = time.monotonic() + 120
    while not started.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert started.exists(), process.communicate()
    process.send_signal(signal.SIGINT)  # Ctrl-C, as the terminal sends it to the sweep
    try:
        out, err = process.communicate(timeout=5)
    except subprocess.TimeoutExpired:
        process.kill()
        raise AssertionError("bench did not stop within 5 s of SIGINT") from None
    assert process.returncode == 130, err
    assert "run the same command again to resume" in err and "Traceback" not in err
    with pytest.raises(ProcessLookupError):  # the interrupted run's process went with it
        os.kill(int(started.read_text()), 0)
    finished = {p.parent.name: p.stat().st_mtime_ns for p in (results / "runs").glob("*/run.json")}
    assert len(finished) == 1 and next(iter(finished)).startswith("intersection-1_identity_")

    slow.unlink()  # the same command again resumes: the identity run is kept, the other one runs
    monkeypatch.setenv("SYNTHCAL_TEST_SLOW", str(slow))
    assert main(command) == 0
    frame = collect_results(results)
    assert len(frame) == 2 and (frame["status"] == "ok").all()
    assert {name: (results / "runs" / name / "run.json").stat().st_mtime_ns for name in finished} == finished


def test_bench_searches_the_whole_pool_with_dictionary_pool(data, tmp_path, capsys):
    results = tmp_path / "results"
    assert bench(data, results, "template", f"{RETRY}:SizeRecordingEstimator", seeds="0",
                 extra=("--dictionary", "pool")) == 0
    out = capsys.readouterr().out
    # 48 samples, 24 train, 8 test, 4 validation: the other 12 are the templates, never capped by the profile.
    assert "intersection-1 (pool) (seeds 0): train 24 of 24, test 8 of 8, dictionary 12 of 12" in out
    assert "whole pool outside the seed's train, test and" in out  # the table's caption says so
    frame = collect_results(results)
    assert (frame["status"] == "ok").all() and set(frame["dataset"]) == {"intersection-1 (pool)"}
    assert (frame["dictionary"] == "pool").all() and (frame["iou"] > 0).all()
    pool = set(range(48)) - set(read_split_indices(data / "intersection-1.zarr", "train", 0)) \
        - set(read_split_indices(data / "intersection-1.zarr", "test", 0)) \
        - set(read_split_indices(data / "intersection-1.zarr", "validation", 0))
    for run_id in frame["run_id"]:
        record = record_of(results, run_id)
        assert "_pool_" in run_id and record["run"]["dictionary"] == "pool"
        assert record["sizes"]["dictionary"] == len(pool) == 12
    recorder = frame[frame["model"] == "SizeRecordingEstimator"]["run_id"].iloc[0]
    assert record_of(results, recorder)["history"]["dictionary"] == 12  # what the plug-in was handed
    # The dictionary is part of a run's identity; split runs keep the ids they had before it existed.
    split = expand_runs(data, ["intersection-1"], ["template"], [0], "smoke", device="cpu")[0]
    whole = expand_runs(data, ["intersection-1"], ["template"], [0], "smoke", device="cpu", dictionary="pool")[0]
    assert split.dictionary == "split" and "pool" not in split.id and split.id != whole.id
    assert split.id.rsplit("_", 1)[1] == dataclasses_replace_hash(split)


def dataclasses_replace_hash(run) -> str:
    """The id hash of a run as computed before the dictionary and options fields existed (no such keys)."""
    import dataclasses
    import hashlib

    record = {k: v for k, v in dataclasses.asdict(run).items()
              if k not in ("store", "dictionary") and not (k in ("device", "limits", "options") and v is None)}
    return hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:10]


def test_the_pool_dictionary_is_refused_for_mixed_dictionaries(data, tmp_path, capsys):
    code = main(["bench", "--data", str(data), "--datasets", "mixed-1", "--estimator", "template", "--seeds", "0",
                 "--results", str(tmp_path), "--profile", "smoke", "--dictionary", "pool", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("synthcal: error: ") and len(err.strip().splitlines()) == 1
    assert "intersection-1.zarr: dictionary pool: dataset 'mixed-1' uses a mixed dictionary" in err
    assert "--dictionary split" in err and not (tmp_path / "runs").exists()


def test_a_profile_or_dataset_may_ask_for_the_pool_dictionary(data, tmp_path, capsys):
    config = yaml.safe_load((ROOT / "synthcal" / "datasets.yaml").read_text())
    config["profiles"]["smoke"]["dictionary"] = "pool"
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    results = tmp_path / "results"
    assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "mixed-1", "--estimator", "identity",
                 "--seeds", "0", "--results", str(results), "--profile", "smoke", "--config", str(path),
                 "--quiet"]) == 0
    # The profile's pool applies to datasets with an own pool; a mixed label keeps its mixed dictionary.
    assert set(collect_results(results)["dataset"]) == {"intersection-1 (pool)", "mixed-1"}
    capsys.readouterr()
    # Each mistake alone (a configuration error is one line: the first problem found).
    for where, value, expected in [(("profiles", "smoke"), "all", ("profiles.smoke.dictionary", "'all'")),
                                   (("datasets", "worldcup2014"), "pool",
                                    ("datasets.worldcup2014", "dictionary: pool searches the dataset's own pool"))]:
        edited = yaml.safe_load(yaml.safe_dump(config))
        edited[where[0]][where[1]]["dictionary"] = value
        path.write_text(yaml.safe_dump(edited))
        assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "identity",
                     "--results", str(results), "--config", str(path)]) == 2
        err = capsys.readouterr().err
        assert all(text in err for text in expected), err


def test_ten_seeds_split_bench_and_table_with_the_all_background_floor(smoke_stores, tmp_path, capsys):
    """`split --seeds 0-9` then `bench --seeds 0-9` at smoke size; the iou_weighted table states its floor."""
    from synthcal.data import load_split

    smoke_stores.copy(["intersection-1"], tmp_path / "data")
    store = tmp_path / "data" / "intersection-1.zarr"
    results = tmp_path / "results"
    assert bench(tmp_path / "data", results, "identity", seeds="0-9") == 2  # not drawn yet: says how
    assert "synthcal split" in capsys.readouterr().err
    assert main(["split", str(store), "--seeds", "0-9"]) == 0
    assert bench(tmp_path / "data", results, "identity", seeds="0-9") == 0
    out = capsys.readouterr().out
    assert "10 runs (0 failed)" in out and "over 10 seeds" in out and "iou (%)" in out  # iou: the default
    assert "floor" not in out  # the default reading has none worth stating
    assert main(["table", str(results), "--metric", "iou_weighted"]) == 0
    floor = [line for line in capsys.readouterr().out.splitlines() if line.startswith("all-background floor: ")]
    # Independently: per seed, the mean over scored test images of (background share of the true view)².
    frame = collect_results(results)
    per_seed = []
    for seed, run_id in zip(frame["seed"], frame["run_id"], strict=True):
        scored = pd.read_csv(results / "runs" / run_id / "metrics.csv").dropna(subset=["iou_weighted"])
        test = load_split(store, "test", int(seed))
        truths = test.semantics[np.isin(test.indices, scored["pool_index"])]
        per_seed.append(np.mean([np.mean(t == 0) ** 2 for t in truths]))
    assert floor == [f"all-background floor: {100 * np.mean(per_seed):.2f}"]


# --- issue 23: the estimator's code in the run's identity, leftovers, spawned processes, crashes -------


PLUGIN = "synthcal_edited_plugin"
PLUGIN_SOURCE = '''from synthcal.estimators import IdentityEstimator


class Fixed(IdentityEstimator):
    def predict(self, images):
        return {body}
'''


def run_json_times(results: Path) -> dict[str, int]:
    return {p.parent.name: p.stat().st_mtime_ns for p in (results / "runs").glob("*/run.json")}


def test_an_edited_plugin_runs_again_and_rerun_runs_on_demand(data, tmp_path, monkeypatch, capsys):
    folder = tmp_path / "plugins"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    source = folder / f"{PLUGIN}.py"

    def write(body: str) -> None:
        source.write_text(PLUGIN_SOURCE.format(body=body))
        for cached in folder.glob(f"__pycache__/{PLUGIN}.*"):  # the same size within a second would reuse it
            cached.unlink()

    write("super().predict(images)")
    results = tmp_path / "results"
    assert bench(data, results, f"{PLUGIN}:Fixed") == 0
    assert "2 runs: 0 reused, 2 to run" in capsys.readouterr().out
    first = run_json_times(results)
    assert bench(data, results, f"{PLUGIN}:Fixed") == 0
    assert "2 runs: 2 reused, 0 to run" in capsys.readouterr().out and run_json_times(results) == first

    write("[[[float('nan')] * 3] * 3] * len(images)")  # predict edited: the new code must run
    assert bench(data, results, f"{PLUGIN}:Fixed") == 1
    out = capsys.readouterr().out
    assert "2 runs: 0 reused, 2 to run" in out and "all 8 estimates invalid: non-finite entries" in out
    edited = set(run_json_times(results)) - set(first)
    assert len(edited) == 2 and all(name.startswith("intersection-1_Fixed_s") for name in edited)

    write("super().predict(images)")  # the first code again: its runs, by the same ids
    assert bench(data, results, f"{PLUGIN}:Fixed") == 0
    assert "2 runs: 2 reused, 0 to run" in capsys.readouterr().out
    assert bench(data, results, f"{PLUGIN}:Fixed", extra=("--rerun",)) == 0
    assert "2 runs: 0 reused, 2 to run" in capsys.readouterr().out
    again = run_json_times(results)
    assert all(again[name] != first[name] for name in first)


def test_code_versions_hash_relative_paths_and_bytes_only(tmp_path):
    from synthcal.estimators.version import BUNDLED_PACKAGES, bundled_code_version, source_digest

    package = ROOT / "synthcal"
    copy = tmp_path / "elsewhere" / "synthcal"
    for name in BUNDLED_PACKAGES:  # the same code in another folder, with other modification times
        shutil.copytree(package / name, copy / name, ignore=shutil.ignore_patterns("__pycache__"))
    assert bundled_code_version(copy) == bundled_code_version()
    with (copy / "models" / "unet.py").open("a") as stream:
        stream.write("\n# an edit\n")
    assert bundled_code_version(copy) != bundled_code_version()

    one, two = tmp_path / "a", tmp_path / "b"
    for folder, line_end in ((one, "\n"), (two, "\r\n")):  # a Windows checkout reads the same
        folder.mkdir()
        (folder / "plugin.py").write_text(f"x = 1{line_end}", newline="")
    assert source_digest([("plugin.py", one / "plugin.py")]) == source_digest([("plugin.py", two / "plugin.py")])
    assert source_digest([("plugin.py", one / "plugin.py")]) != source_digest([("other.py", one / "plugin.py")])


def test_a_killed_sweeps_exchange_folders_are_swept(data, tmp_path, capsys):
    gone = subprocess.Popen(["true"])
    gone.wait()  # a sweep that was killed: its process no longer exists
    results = tmp_path / "results"
    left, live = results / ".exchange-left", results / ".exchange-live"
    for folder, parent in ((left, gone.pid), (live, os.getpid())):
        folder.mkdir(parents=True)
        (folder / "request.json").write_text(json.dumps({"parent": parent}))
    assert bench(data, results, "identity", seeds="0") == 0
    assert not left.exists() and live.exists()  # another sweep's, still running, is kept
    assert [p.name for p in results.iterdir() if p.name.startswith(".exchange-")] == [live.name]


def _alive(pid: int) -> bool:
    """Whether a process runs (a zombie waiting for its parent to read its status does not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_a_process_a_plugin_starts_ends_with_its_run(data, tmp_path, monkeypatch):
    spawned = tmp_path / "spawned.pid"
    monkeypatch.setenv("SYNTHCAL_TEST_SPAWNED", str(spawned))
    assert bench(data, tmp_path / "results", f"{FAULTY}:SpawningEstimator", seeds="0") == 0
    pid = int(spawned.read_text())
    deadline = time.monotonic() + 5
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(pid)


def test_a_crash_dump_goes_to_the_runs_log_and_the_terminal_gets_one_line(data, tmp_path, capfd):
    results = tmp_path / "results"
    assert bench(data, results, f"{FAULTY}:SegfaultingEstimator", seeds="0") == 1
    err = capfd.readouterr().err
    (run_id,) = [p.name for p in (results / "runs").iterdir()]
    log = results / "runs" / run_id / "crash.log"
    assert err.splitlines() == [f"synthcal: run {run_id}: predict: killed by signal 11 (SIGSEGV); "
                                f"crash dump in {log}"]
    dump = log.read_text()
    assert "Fatal Python error: Segmentation fault" in dump and "in predict" in dump
    assert record_of(results, run_id)["log"] == str(log)


# --- issue 24: runs side by side ---------------------------------------------------------------

RENDEZVOUS = "synthcal_concurrent_plugins:RendezvousEstimator"


def test_workers_run_side_by_side_with_cores_shared_out(data, tmp_path, monkeypatch):
    from synthcal.utils.dispatch import usable_cores

    monkeypatch.setenv("SYNTHCAL_TEST_RENDEZVOUS", str(tmp_path / "meet"))
    (tmp_path / "meet").mkdir()
    assert bench(data, tmp_path / "results", RENDEZVOUS, extra=("--workers", "2")) == 0
    histories = [record_of(tmp_path / "results", run_id)["history"]
                 for run_id in collect_results(tmp_path / "results")["run_id"]]
    assert len(histories) == 2  # seeds 0 and 1, each met the other while fitting: they ran at once
    assert all(h["met"] and h["threads"] == run_threads(2) for h in histories)
    assert run_threads(2) == min(max(1, usable_cores() // 2), int(os.environ.get("OMP_NUM_THREADS") or 10**6))


@pytest.mark.parametrize(("omp", "expected"), [(None, 8), ("1", 1), ("3", 3), ("16", 8), ("0", 8), ("2,1", 8),
                                               ("many", 8)])
def test_a_runs_threads_share_the_cores_at_most_as_many_as_the_user_set(monkeypatch, omp, expected):
    """16 cores over 2 workers: 8 threads a run, fewer where OMP_NUM_THREADS (a positive count) says so."""
    import synthcal.eval.harness as harness

    monkeypatch.setattr(harness, "usable_cores", lambda: 16)
    if omp is None:
        monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    else:
        monkeypatch.setenv("OMP_NUM_THREADS", omp)
    assert run_threads(2) == expected


def test_threads_fix_each_runs_count_whatever_the_workers(data, tmp_path, monkeypatch):
    """--threads 2 with --workers 2: each run gets 2 torch threads, not the cores shared out (1 on CI's 2 cores,
    and 1 under the suite's OMP_NUM_THREADS; torch gives at most one thread per core)."""
    monkeypatch.setenv("SYNTHCAL_TEST_RENDEZVOUS", str(tmp_path / "meet"))
    (tmp_path / "meet").mkdir()
    assert bench(data, tmp_path / "results", RENDEZVOUS, extra=("--workers", "2", "--threads", "2")) == 0
    histories = [record_of(tmp_path / "results", run_id)["history"]
                 for run_id in collect_results(tmp_path / "results")["run_id"]]
    assert len(histories) == 2 and all(h["met"] and h["threads"] == min(2, os.cpu_count() or 1) for h in histories)
    assert run_threads(2, 3) == 3 and run_threads(1, 1) == 1


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, "2"])
def test_a_sweep_with_threads_that_are_not_a_count_writes_nothing(data, tmp_path, threads):
    runs = expand_runs(data, ["intersection-1"], ["identity"], [0], "smoke")
    with pytest.raises(ValueError, match=f"threads: expected a positive count of torch threads per run, got "
                                         f"{re.escape(repr(threads))}"):
        run_sweep(runs, tmp_path / "results", threads=threads)
    assert not (tmp_path / "results").exists()


def test_a_sweep_whose_cache_links_to_nothing_stops_before_any_run(data, tmp_path, capsys):
    """A results folder sharing another's cache through a link whose target is gone (a reset machine): one error
    naming the link and its target, not a FileExistsError in every run."""
    results = tmp_path / "results"
    results.mkdir()
    (results / "cache").symlink_to("../elsewhere/cache")
    said = f"{results / 'cache'}: a link to ../elsewhere/cache, which does not exist"
    assert bench(data, results, "identity", seeds="0") == 2
    assert f"synthcal: error: --results: {said}" in capsys.readouterr().err
    runs = expand_runs(data, ["intersection-1"], ["identity"], [0], "smoke")
    with pytest.raises(ValueError, match=re.escape(said)):
        run_sweep(runs, results)
    assert list((results / "runs").iterdir()) == []
    (tmp_path / "elsewhere" / "cache").mkdir(parents=True)
    assert len(run_sweep(runs, results, progress=False)) == 1


def test_bench_says_when_reused_runs_trained_at_another_thread_count(data, tmp_path, capsys):
    """A resumed sweep whose --workers gives its runs another torch thread count than the reused runs had."""
    results = tmp_path / "results"
    assert bench(data, results, "identity", seeds="0-1") == 0
    capsys.readouterr()
    records = sorted((results / "runs").glob("*/run.json"))
    ours = run_threads(1)
    for path, threads in zip(records, (ours, ours + 3), strict=True):  # as a torch run records it
        record = json.loads(path.read_text())
        record["machine"]["torch_threads"] = threads
        path.write_text(json.dumps(record))
    assert bench(data, results, "identity", seeds="0-1") == 0
    out = capsys.readouterr().out
    assert (f"bench: 1 of the 2 reused runs trained at another torch thread count (1 at {ours + 3}) than this "
            f"sweep's runs get ({ours}, --workers 1)") in out
    assert bench(data, results, "identity", seeds="0-1", extra=("--threads", str(ours + 3))) == 0
    assert (f"bench: 1 of the 2 reused runs trained at another torch thread count (1 at {ours}) than this "
            f"sweep's runs get ({ours + 3}, --threads {ours + 3})") in capsys.readouterr().out
    records[1].write_text(records[1].read_text().replace(f'"torch_threads": {ours + 3}', f'"torch_threads": {ours}'))
    assert bench(data, results, "identity", seeds="0-1") == 0
    assert "torch thread count" not in capsys.readouterr().out


def test_bench_says_when_reused_runs_trained_on_another_cpu_instruction_set(data, tmp_path, capsys):
    """A sweep resumed on a machine whose torch picks another instruction set (the proposed model's last digits)."""
    results = tmp_path / "results"
    assert bench(data, results, "identity", seeds="0-1") == 0
    capsys.readouterr()
    ours = torch.backends.cpu.get_cpu_capability()
    records = sorted((results / "runs").glob("*/run.json"))
    for path, capability in zip(records, ("AVX-ELSEWHERE", None), strict=True):  # None: a record without one
        record = json.loads(path.read_text())
        record["machine"].pop("cpu_capability", None)  # the identity estimator never imports torch
        if capability is not None:
            record["machine"]["cpu_capability"] = capability
        path.write_text(json.dumps(record))
    assert bench(data, results, "identity", seeds="0-1") == 0
    assert (f"bench: 1 of the 2 reused runs trained on another CPU instruction set (1 on AVX-ELSEWHERE) than "
            f"this machine's torch uses ({ours})") in capsys.readouterr().out
    records[0].write_text(records[0].read_text().replace("AVX-ELSEWHERE", ours))
    assert bench(data, results, "identity", seeds="0-1") == 0
    assert "instruction set" not in capsys.readouterr().out


def test_two_workers_score_as_one_and_train_a_shared_stage_once(data, tmp_path, capsys):
    """baseline and proposed need the same Siamese: run at once, one trains it, the other waits and loads it.
    At a fixed thread count (--threads), two workers' figures are one worker's to the bit."""
    models = ("baseline", "proposed", "identity")
    assert bench(data, tmp_path / "one", *models, seeds="0", extra=("--threads", "1")) == 0
    assert bench(data, tmp_path / "two", *models, seeds="0", extra=("--workers", "2", "--threads", "1")) == 0
    one, two = (collect_results(tmp_path / name).set_index("run_id") for name in ("one", "two"))
    assert sorted(one.index) == sorted(two.index) and len(one) == 3
    trained = [record_of(tmp_path / "two", run_id).get("history", {}) for run_id in two.index]
    assert sum("siamese" in history for history in trained) == 1
    assert len(list((tmp_path / "two" / "cache" / "siamese").glob("*.pt"))) == 1
    for run_id in one.index:
        a, b = (pd.read_csv(tmp_path / name / "runs" / run_id / "metrics.csv") for name in ("one", "two"))
        pd.testing.assert_frame_equal(a, b)
        if one.loc[run_id, "model"] != "identity":
            assert record_of(tmp_path / "two", run_id)["machine"]["torch_threads"] == 1


def test_invalid_truth_in_a_store_is_one_line_naming_it(data, tmp_path, monkeypatch, capsys):
    """A TruthError met while scoring (a damaged truth in the store) ends bench with one line, exit 2."""
    import synthcal.eval.harness as harness
    from synthcal.eval.metrics import TruthError

    def damaged(*args, **kwargs):
        raise TruthError("S.zarr: true homography of sample 3: not a finite (3, 3) matrix")

    monkeypatch.setattr(harness, "evaluate", damaged)
    assert bench(data, tmp_path / "results", "identity", seeds="0") == 2
    err = capsys.readouterr().err
    assert err.splitlines() == ["synthcal: error: S.zarr: true homography of sample 3: not a finite (3, 3) matrix"]


def test_a_sweep_is_timed_by_the_finished_runs_most_alike(tmp_path):
    """The preview's estimate reads the finished runs with the same estimator, training, segmentation, device
    and dataset (the proposed model's end-to-end runs took twice its step-by-step ones in one folder, twenty-first
    session; a World Cup 2014 run a quarter of an intersection's, twenty-fifth), then those alike but in another
    dataset, and only without such runs every run of the estimator."""
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=400.0)
    write_run(tmp_path, "proposed", "dice", 1, 0.6, 1e-4, seconds=500.0)
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=120.0, dataset="worldcup2014")
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=800.0, training="end-to-end")
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=60.0, training="end-to-end", device="cuda")
    seconds = recorded_seconds(tmp_path)

    def run(training: str, segmentation: str = "ground-truth", device: str | None = None,
            estimator: str = "proposed", dataset: str = "intersection-1") -> Run:
        return Run(dataset=dataset, store="s.zarr", mixed=None, store_hash="h", estimator=estimator,
                   model=estimator, seed=2, training=training, segmentation=segmentation, device=device)

    assert expected_seconds(run("step-by-step"), seconds) == 450.0
    assert expected_seconds(run("step-by-step", dataset="worldcup2014"), seconds) == 120.0
    assert expected_seconds(run("end-to-end"), seconds) == 800.0
    assert expected_seconds(run("end-to-end", device="cuda"), seconds) == 60.0
    # no finished run of the dataset: the runs alike in the other datasets
    assert expected_seconds(run("step-by-step", dataset="mixed-1"), seconds) == pytest.approx(1020.0 / 3)
    assert expected_seconds(run("end-to-end", dataset="worldcup2014"), seconds) == 800.0
    # no finished run alike: every run of the estimator (the UNet's runs would be slower; nothing better is known)
    assert expected_seconds(run("step-by-step", segmentation="unet"), seconds) == pytest.approx(1880.0 / 5)
    assert expected_seconds(run("step-by-step", estimator="sha2020"), seconds) is None


def test_a_sweep_without_runs_of_its_dataset_is_timed_by_runs_on_as_many_train_images(tmp_path):
    """Runs of other datasets time a new dataset's runs by those that trained on as many images: a sweep of
    intersection-3 timed by World Cup 2014's runs (167 frames) and mixed-1's (1,500 of 3,000) was told 33 min
    and took 49 (twenty-seventh session). Only without runs on as many images, every one alike but in size."""
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=240.0, dataset="worldcup2014", train=167)
    write_run(tmp_path, "proposed", "dice", 0, 0.6, 1e-4, seconds=540.0, dataset="mixed-1", train=3000)
    write_run(tmp_path, "proposed", "dice", 1, 0.6, 1e-4, seconds=600.0, dataset="mixed-1", train=3000)
    seconds = recorded_seconds(tmp_path)
    assert trained_images({"max_train": 1500}, 3000) == 1500 and trained_images(None, 3000) is None
    run = Run(dataset="intersection-3", store="s.zarr", mixed=None, store_hash="h", estimator="proposed",
              model="proposed", seed=2, training="step-by-step", segmentation="ground-truth")
    assert expected_seconds(run, seconds, train_images=1500) == 570.0
    assert expected_seconds(run, seconds, train_images=167) == 240.0
    # on a number of images no run trained on: the line through the per-size means of every run alike in
    # estimator, training, segmentation and device (not their plain mean, 460 s)
    slope, intercept = np.polyfit([167, 1500], [240.0, 570.0], 1)
    assert estimate_seconds(run, seconds, train_images=500) == (pytest.approx(intercept + slope * 500),
                                                                "other train sizes")
    assert expected_seconds(run, seconds, train_images=10) == pytest.approx(max(0.0, intercept + slope * 10))
    # runs on one size only: in proportion (World Cup's 167 frames against intersection-3's 1,500)
    only_worldcup = {key: values for key, values in seconds.items() if key[-1] == "worldcup2014"}
    assert expected_seconds(run, only_worldcup, train_images=1500) == pytest.approx(240.0 * 1500 / 167)
    # a run that does not train: the plain mean, not said to be scaled
    assert estimate_seconds(run, seconds) == (pytest.approx(460.0), "estimator")


def test_a_sweep_timed_by_runs_on_other_train_sizes_scales_them_and_says_so(data, tmp_path, monkeypatch, terminal,
                                                                           capsys):
    """Intersection-3's sha2020-ccbv runs were told 3 min each from World Cup 2014's (167 frames) and took 21
    (thirty-fourth session): runs on another number of train images are scaled, and the preview names them."""
    from synthcal import cli

    write_run(tmp_path, "sha2020", "top-mse", 0, 0.5, 1e-4, seconds=6000.0, dataset="worldcup2014", device="cpu",
              train=3000)
    monkeypatch.setattr(cli, "CONFIRM_SECONDS", 0.0)  # every sweep asks; the answer is no: nothing trains
    terminal("n")
    assert bench(data, tmp_path, "sha2020", seeds="0", extra=("--loss", "top-mse")) == 1
    line = next(text for text in capsys.readouterr().out.splitlines() if text.startswith("estimated time: "))
    assert line.endswith("(from the recorded times of finished runs; sha2020 scaled from runs on other train sizes)")
    assert "100 min" not in line  # the run on 1,500 images took 100 min; this one trains on the smoke store's few
