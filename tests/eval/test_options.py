"""Estimator options (issue 24 item 2): parsing, validation before any run, identity, labels, precedence."""

import json
from pathlib import Path

import pytest
import yaml

from synthcal.cli import main
from synthcal.estimators import EstimatorError
from synthcal.estimators.options import (
    EstimatorSpec,
    check_options,
    merge_options,
    options_label,
    parse_estimator_spec,
    parse_option_flag,
)
from synthcal.eval.harness import collect_results, expand_runs
from synthcal.generate.splits import draw_splits

ROOT = Path(__file__).resolve().parents[2]
PLUGINS = "synthcal_option_plugins"  # tests/eval/synthcal_option_plugins.py
RECORDING = f"{PLUGINS}:OptionRecordingEstimator"


@pytest.fixture(scope="module")
def data(smoke_stores, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("options-data")
    smoke_stores.copy(["intersection-1"], out)
    draw_splits(out / "intersection-1.zarr", seeds=[0])
    return out


@pytest.fixture(autouse=True)
def plugins(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "tests" / "eval"))


def bench(data: Path, results: Path, *argv: str) -> int:
    return main(["bench", "--data", str(data), "--datasets", "intersection-1", "--seeds", "0", "--results",
                 str(results), "--device", "cpu", "--quiet", *argv])


def config_with(tmp_path: Path, estimators: dict) -> Path:
    config = yaml.safe_load((ROOT / "synthcal" / "datasets.yaml").read_text())
    config["estimators"] = estimators
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def test_values_are_yaml_scalars_and_names_may_be_dotted_paths():
    spec = parse_estimator_spec("sift?ratio=0.7&cross=true&steps=3&mode=fast&name=null")
    assert spec.name == "sift" and spec.options == {"ratio": 0.7, "cross": True, "steps": 3,
                                                               "mode": "fast", "name": None}
    assert [type(v) for v in spec.options.values()] == [float, bool, int, str, type(None)]
    assert parse_option_flag("pkg.module:Class.ratio=1e-3") == ("pkg.module:Class", "ratio", 0.001)
    for bad in ("sift.ratio", "ratio=0.7", "sift.=3", "sift.ratio=[1, 2]"):
        with pytest.raises(EstimatorError, match="--option"):
            parse_option_flag(bad)
    with pytest.raises(EstimatorError, match="option 'ratio' given twice"):
        parse_estimator_spec("sift?ratio=1&ratio=2")


def test_the_command_line_wins_over_the_configuration_key_by_key():
    configured = {"sift": {"ratio": 0.6, "mode": "slow"}, "other": {"x": 1}}
    specs = merge_options(["sift?ratio=0.7&steps=2", "sift", "identity"], configured, ["sift.steps=3"])
    assert [s.options for s in specs] == [{"ratio": 0.7, "mode": "slow", "steps": 3},
                                          {"ratio": 0.6, "mode": "slow", "steps": 3}, {}]
    with pytest.raises(EstimatorError, match="estimator 'surf' is not benched"):
        merge_options(["sift"], {}, ["surf.ratio=1"])


@pytest.mark.parametrize(("options", "message"), [
    ({"ratoi": 0.7}, "option ratoi=0.7: its constructor takes no 'ratoi' (parameters: cross, mode, name, ratio, "
                     "steps)"),
    ({"ratio": "high"}, "option ratio='high': expected float"),
    ({"steps": 2.5}, "option steps=2.5: expected int"),
    ({"steps": True}, "option steps=True: expected int"),
    ({"cross": 1}, "option cross=1: expected bool"),
    ({"mode": "medium"}, "option mode='medium': expected one of 'fast', 'slow'"),
    ({"name": 3}, "option name=3: expected str or None"),
    ({"seed": 1}, "option seed=1: 'seed' is set by bench itself"),
])
def test_options_the_constructor_cannot_take_are_refused(options, message):
    from synthcal_option_plugins import OptionRecordingEstimator

    with pytest.raises(EstimatorError) as error:
        check_options("rec", OptionRecordingEstimator, options)
    assert str(error.value).startswith(f"estimator 'rec': {message}")


def test_fitting_options_a_kwargs_constructor_and_the_harness_keywords_pass():
    from synthcal_option_plugins import AnyOptionEstimator, OptionRecordingEstimator, RequiredOptionEstimator

    check_options("rec", OptionRecordingEstimator, {"ratio": 1, "cross": False, "mode": "slow", "name": None})
    check_options("any", AnyOptionEstimator, {"whatever": "x", "n": 3})
    check_options("req", RequiredOptionEstimator, {"threshold": 0.5})
    with pytest.raises(EstimatorError, match="its constructor requires 'threshold'"):
        check_options("req", RequiredOptionEstimator, {})


def test_options_reach_the_constructor_and_make_runs_of_their_own(data, tmp_path, capsys):
    config = config_with(tmp_path, {RECORDING: {"ratio": 0.6, "mode": "slow"}})
    results = tmp_path / "results"
    assert bench(data, results, "--config", str(config), "--estimator", f"{RECORDING}?ratio=0.7&steps=2",
                 RECORDING, "--option", f"{RECORDING}.steps=3") == 0
    out = capsys.readouterr().out
    frame = collect_results(results).set_index("model")
    expected = {"OptionRecordingEstimator(mode=slow, ratio=0.7, steps=3)": {"ratio": 0.7, "mode": "slow", "steps": 3},
                "OptionRecordingEstimator(mode=slow, ratio=0.6, steps=3)": {"ratio": 0.6, "mode": "slow", "steps": 3}}
    assert sorted(frame.index) == sorted(expected)  # two option sets: two runs, each labelled with its own
    for label, options in expected.items():
        assert label in out  # the table's label
        record = json.loads((results / "runs" / frame.loc[label, "run_id"] / "run.json").read_text())
        assert record["run"]["options"] == options  # recorded in run.json
        received = record["history"]["options"]  # what the constructor received, in the run's own process
        assert {key: received[key] for key in options} == options
        assert received["cross"] is False and received["name"] is None  # defaults kept for the rest
    assert len(set(frame["run_id"])) == 2 and all("ratio0.7" in i or "ratio0.6" in i for i in frame["run_id"])


def test_the_identity_of_a_run_holds_its_options(data):
    plain, other, same = (expand_runs(data, ["intersection-1"], [spec], [0])[0]
                          for spec in (RECORDING, f"{RECORDING}?ratio=0.7", EstimatorSpec(RECORDING, {"ratio": 0.7})))
    assert plain.options is None and other.options == {"ratio": 0.7}
    assert plain.id != other.id == same.id
    assert other.model == options_label("OptionRecordingEstimator", {"ratio": 0.7})
    assert other.model == "OptionRecordingEstimator(ratio=0.7)"


@pytest.mark.parametrize(("argv", "message"), [
    (["--estimator", RECORDING, "--option", f"{RECORDING}.ratoi=0.7"],
     f"estimator {RECORDING!r}: option ratoi=0.7: its constructor takes no 'ratoi'"),
    (["--estimator", f"{RECORDING}?ratio=high"], f"estimator {RECORDING!r}: option ratio='high': expected float"),
    (["--estimator", f"{PLUGINS}:RequiredOptionEstimator"],
     f"estimator '{PLUGINS}:RequiredOptionEstimator': its constructor requires 'threshold'"),
])
def test_bench_refuses_bad_options_in_one_line_before_any_run(data, tmp_path, capsys, argv, message):
    assert bench(data, tmp_path / "results", *argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"synthcal: error: {message}") and err.count("\n") == 1
    assert not (tmp_path / "results").exists()  # nothing run


def test_a_configured_option_is_validated_too_and_a_required_one_satisfied(data, tmp_path, capsys):
    required = f"{PLUGINS}:RequiredOptionEstimator"
    assert bench(data, tmp_path / "bad", "--config", str(config_with(tmp_path, {RECORDING: {"mode": "medium"}})),
                 "--estimator", RECORDING) == 2
    assert "option mode='medium': expected one of 'fast', 'slow'" in capsys.readouterr().err
    assert bench(data, tmp_path / "ok", "--config", str(config_with(tmp_path, {required: {"threshold": 0.5}})),
                 "--estimator", required) == 0
    assert collect_results(tmp_path / "ok")["model"].tolist() == ["RequiredOptionEstimator(threshold=0.5)"]
