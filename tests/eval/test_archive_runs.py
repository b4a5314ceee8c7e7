"""docs/sweeps/archive_runs.py, the script that writes a sweep's runs into the archives kept in git.

A committed archive stands in for a sweep's results folder: ``synthcal table`` reads one in place of a folder and
prints it back row for row, so a slice of it is known without running a sweep.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from sweep_scripts import ROOT, sweep_script

SCRIPT = ROOT / "docs" / "sweeps" / "archive_runs.py"
FOLDER = ROOT / "docs" / "results" / "runs_thirtyseventh.csv"  # intersections 3, 4 and 5, five seeds each
SYNTHCAL = Path(sys.executable).with_name("synthcal")


def _as_printed(archive: Path) -> pd.DataFrame:
    return pd.read_csv(archive, dtype=str, keep_default_na=False)


@pytest.fixture(scope="module")
def script():
    """The script as a module, reading FOLDER with pandas instead of through the CLI (one test runs the CLI)."""
    module = sweep_script("archive_runs")
    module.folder_runs = lambda results, synthcal: _as_printed(results)
    return module


def _archive(script, monkeypatch, out: Path, *arguments: str) -> None:
    monkeypatch.setattr(sys, "argv", ["archive_runs.py", str(FOLDER), str(out), *arguments])
    script.main()


def test_a_slice_through_the_cli_is_the_folders_runs_of_those_keys(tmp_path):
    out = tmp_path / "runs_new.csv"
    subprocess.run([sys.executable, str(SCRIPT), str(FOLDER), str(out), "--where", "dataset=intersection-4",
                    "model=proposed", "--expect", "5", "--synthcal", str(SYNTHCAL)], check=True, capture_output=True)
    folder = _as_printed(FOLDER)
    expected = folder[folder["dataset"] == "intersection-4"].reset_index(drop=True)
    pd.testing.assert_frame_equal(_as_printed(out), expected)


def test_a_second_slice_is_appended_and_a_run_already_there_kept_once(script, monkeypatch, tmp_path):
    out = tmp_path / "runs_new.csv"
    _archive(script, monkeypatch, out, "--where", "dataset=intersection-4", "--expect", "5")
    first = out.read_text(encoding="utf-8")
    _archive(script, monkeypatch, out, "--where", "dataset=intersection-4,intersection-5", "--expect", "10")
    written = _as_printed(out)
    assert out.read_text(encoding="utf-8").startswith(first), "the archive's own rows were rewritten"
    assert len(written) == 10 and written["run_id"].is_unique
    assert list(written["dataset"]) == ["intersection-4"] * 5 + ["intersection-5"] * 5


@pytest.mark.parametrize("arguments, message", [
    (["--where", "dataset=intersection-4", "--expect", "4"], "5 finished runs match, not 4; nothing written"),
    (["--where", "datasets=intersection-4", "--expect", "5"], "--where datasets: no such column"),
    (["--where", "dataset", "--expect", "5"], "--where 'dataset': give KEY=VALUE"),
])
def test_a_slice_that_is_not_the_one_asked_for_leaves_the_archive_as_it_was(script, monkeypatch, tmp_path,
                                                                           arguments, message):
    out = tmp_path / "runs_new.csv"
    _archive(script, monkeypatch, out, "--where", "dataset=intersection-3", "--expect", "5")
    before = out.read_bytes()
    with pytest.raises(SystemExit, match=message):
        _archive(script, monkeypatch, out, *arguments)
    assert out.read_bytes() == before
    assert sorted(path.name for path in tmp_path.iterdir()) == ["runs_new.csv"], "a temporary file was left"


def test_an_archive_of_other_columns_is_not_appended_to(script, monkeypatch, tmp_path):
    out = tmp_path / "runs_new.csv"
    folder = _as_printed(FOLDER)
    folder.drop(columns=["seconds"]).head(2).to_csv(out, index=False)
    before = out.read_bytes()
    with pytest.raises(SystemExit, match="its columns differ"):
        _archive(script, monkeypatch, out, "--where", "dataset=intersection-3", "--expect", "5")
    assert out.read_bytes() == before


def test_a_folder_the_cli_cannot_read_is_one_line_naming_it(tmp_path):
    missing = tmp_path / "results"
    with pytest.raises(SystemExit, match=f"^{missing}: .* no such results folder"):
        sweep_script("archive_runs").folder_runs(missing, str(SYNTHCAL))
