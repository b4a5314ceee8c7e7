"""The user's path, round 2 (issue 24): a preview before big runs, and the small CLI seams."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from synthcal import cli
from synthcal.cli import main
from synthcal.generate.splits import draw_splits

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "datasets.yaml"


def never_asked(*args):
    raise AssertionError("asked off a terminal")


def generate(out: Path, *extra: str) -> list[str]:
    return ["generate", "intersection-1", "--out", str(out), "--quiet", "--config", str(CONFIG), *extra]


def store_bytes(store: Path) -> int:
    return sum(f.stat().st_size for f in store.rglob("*") if f.is_file())


# --- item 3: a preview before a run --------------------------------------------------------------

def test_generate_off_a_terminal_never_asks_nor_measures_and_a_rerun_is_already_complete(tmp_path, monkeypatch,
                                                                                          capsys):
    monkeypatch.setattr(cli, "CONFIRM_SECONDS", 0.0)  # every run is "big": only the terminal decides
    monkeypatch.setattr(cli, "CONFIRM_BYTES", 0.0)
    monkeypatch.setattr("builtins.input", never_asked)
    monkeypatch.setattr("synthcal.generate.preview.estimate_generation", never_asked)  # no question, no measuring
    assert main(generate(tmp_path, "--profile", "smoke")) == 0
    preview, done = capsys.readouterr().out.splitlines()
    assert preview.startswith("intersection-1: 48 samples here with 1 worker") and "not estimated" in preview
    assert done.startswith(f"{tmp_path / 'intersection-1.zarr'}  48 samples  ") and done.endswith(" s")

    assert main(generate(tmp_path, "--profile", "smoke")) == 0  # nothing to do: no preview, no time
    assert capsys.readouterr().out.splitlines() == [f"{tmp_path / 'intersection-1.zarr'}  48 samples  already complete"]


def test_generate_on_a_terminal_measures_the_disk_it_will_take(tmp_path, terminal, monkeypatch, capsys):
    monkeypatch.setattr(cli, "CONFIRM_BYTES", 0.0)  # asks, and is answered yes
    terminal("y")
    assert main(generate(tmp_path, "--profile", "smoke")) == 0
    preview = capsys.readouterr().out.splitlines()[0]
    assert preview.startswith("intersection-1: 48 samples, about ") and "on disk" in preview
    assert "here with 1 worker (measured on 8 samples)" in preview
    # The disk estimate, from 8 samples compressed in memory, against what the store holds.
    number, unit = preview.split("about ")[1].split(" on disk")[0].split()
    estimated = float(number) * {"kB": 1e3, "MB": 1e6}[unit]
    assert 0.5 < estimated / store_bytes(tmp_path / "intersection-1.zarr") < 2


def test_a_big_generate_asks_on_a_terminal_and_no_writes_nothing(tmp_path, terminal, capsys):
    terminal("n")
    out = tmp_path / "out"
    assert main(generate(out)) == 1  # no profile: the paper's 200,000 samples
    captured = capsys.readouterr()
    assert captured.out.startswith("intersection-1: 200,000 samples, about ") and " GB on disk" in captured.out
    assert "[y/N]" in captured.err and "nothing generated" in captured.err
    assert not out.exists()


def test_yes_does_not_ask(tmp_path, terminal, monkeypatch):
    monkeypatch.setattr(cli, "CONFIRM_SECONDS", 0.0)
    monkeypatch.setattr("builtins.input", never_asked)
    terminal("n")
    assert main(generate(tmp_path, "--profile", "smoke", "--yes")) == 0
    assert (tmp_path / "intersection-1.zarr").is_dir()


@pytest.fixture(scope="module")
def bench_data(smoke_stores, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bench-data")
    smoke_stores.copy(["intersection-1"], out)
    draw_splits(out / "intersection-1.zarr", seeds=[0, 1])
    return out


def bench(data: Path, results: Path, seeds: str, *extra: str) -> list[str]:
    return ["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "identity", "--seeds", seeds,
            "--results", str(results), "--profile", "smoke", "--device", "cpu", "--quiet", *extra]


def test_bench_counts_reused_runs_and_estimates_from_recorded_times(bench_data, tmp_path, monkeypatch, terminal,
                                                                    capsys):
    results = tmp_path / "results"
    assert main(bench(bench_data, results, "0")) == 0
    out = capsys.readouterr().out
    assert "bench: 1 runs: 0 reused, 1 to run" in out or "1 run: 0 reused, 1 to run" in out
    assert f"estimated time: unknown (no finished run of identity in {results} to time by)" in out

    monkeypatch.setattr(cli, "CONFIRM_SECONDS", 0.0)  # now every sweep is "big": on a terminal, "n" stops it
    terminal("n")
    assert main(bench(bench_data, results, "0-1")) == 1
    captured = capsys.readouterr()
    assert "2 runs: 1 reused, 1 to run" in captured.out
    assert "estimated time: 1 × " in captured.out and " s (identity) ≈ " in captured.out
    assert "[y/N]" in captured.err and "no run started" in captured.err
    assert len(list((results / "runs").glob("*/run.json"))) == 1


# --- item 8: the small seams ---------------------------------------------------------------------

def test_n_is_spelled_both_ways_on_generate_and_show(tmp_path, capsys):
    assert main(generate(tmp_path, "--profile", "smoke", "-n", "16")) == 0
    assert "16 samples" in capsys.readouterr().out
    store = tmp_path / "intersection-1.zarr"
    for flag in ("-n", "--n"):
        assert main(["show", str(store), flag, "2", "-o", str(tmp_path / f"m{flag}.png")]) == 0
    assert (tmp_path / "m-n.png").is_file() and (tmp_path / "m--n.png").is_file()


def test_a_file_as_out_is_one_line_saying_it_must_be_a_folder(tmp_path, capsys):
    afile = tmp_path / "afile.txt"
    afile.write_text("mine")
    assert main(generate(afile, "--profile", "smoke")) == 2
    err = capsys.readouterr().err
    assert err == f"synthcal: error: --out {afile}: a file of that name exists; --out names a folder\n"
    assert afile.read_text() == "mine"


@pytest.mark.parametrize(("argv", "suggestion"), [
    (["intersection-l", "--profile", "smoke"], "did you mean 'intersection-"),
    (["intersection-1", "--profile", "smok"], "(did you mean 'smoke'?)"),
])
def test_unknown_names_get_a_did_you_mean(tmp_path, capsys, argv, suggestion):
    assert main(["generate", *argv, "--out", str(tmp_path / "out"), "--config", str(CONFIG)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and suggestion in err
    assert not (tmp_path / "out").exists()


def test_an_unguarded_script_with_workers_is_one_line(tmp_path):
    script = tmp_path / "make_data.py"
    script.write_text(textwrap.dedent(f"""
        import synthcal
        synthcal.generate_store("intersection-1", {str(tmp_path / "out")!r}, profile="smoke", workers=2)
    """))
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert done.returncode == 1
    assert done.stderr.count("Traceback") == 1 and "lock" not in done.stderr.lower()
    assert f"{script}: workers > 1 start processes that import this script again" in done.stderr.splitlines()[-1]
    assert 'if __name__ == "__main__":' in done.stderr.splitlines()[-1]
    assert not (tmp_path / "out").exists()

    guarded = tmp_path / "guarded.py"
    body = textwrap.indent(script.read_text(), "    ")
    guarded.write_text(f'if __name__ == "__main__":\n{body}')
    done = subprocess.run([sys.executable, str(guarded)], capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "intersection-1.zarr").is_dir()
