"""The command line when things go wrong (issue 14): Ctrl-C, a full disk, a read-only folder,
an unreachable scheduler, bad numbers, a closed pipe — one line each, the right exit status,
nothing half-written; and the small things (version, help, picture formats, hints, listings)."""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import shlex
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
import zarr

from synthcal import cli
from synthcal.cli import build_parser, main
from synthcal.config import load_config
from synthcal.eval.harness import dataset_store
from synthcal.generate.splits import SplitsResized, draw_splits
from synthcal.store import open_store
from synthcal.store.splits import drawn_seeds
from synthcal.utils.atomic import is_temporary

ROOT = Path(__file__).resolve().parents[1]
TESTS = Path(__file__).resolve().parent
CONFIG = ROOT / "datasets.yaml"
DISPATCH = importlib.import_module("synthcal.utils.dispatch")  # the module; synthcal.utils.dispatch is its function


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"expected one line, got:\n{err}"
    return lines[0]


def temporaries(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if is_temporary(p.name)]


# --- item 3: Ctrl-C ------------------------------------------------------------------------------

def test_importing_the_slow_shards_helper_slows_nothing():
    """Doctest collection imports every module under tests/: the helper must patch only when asked."""
    sys.path.insert(0, str(TESTS))
    try:
        slow = importlib.import_module("synthcal_slow_shards")
    finally:
        sys.path.remove(str(TESTS))
    pipeline = importlib.import_module("synthcal.generate.pipeline")
    assert pipeline.run_shard is not slow.run_shard


def test_sigint_stops_a_two_worker_generate_and_the_rerun_completes(tmp_path, capsys):
    out = tmp_path / "out"
    args = ["generate", "intersection-1", "--profile", "smoke", "--n", "160", "--out", str(out), "--workers", "2",
            "--quiet", "--config", str(CONFIG)]
    # Every shard takes ≥ 1 s (synthcal_slow_shards): 20 shards on 2 workers keep them busy for 10 s.
    code = f"import sys; sys.path.insert(0, {str(TESTS)!r}); import synthcal_slow_shards; synthcal_slow_shards.install(); " \
           "from synthcal.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen([sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    progress = out / ".intersection-1.zarr.progress"
    try:
        deadline = time.monotonic() + 120
        while not (progress.is_dir() and any(progress.glob("*.done"))):  # a shard is done: the workers are rendering
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no shard finished in 120 s"
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=5)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    assert one_line(err) == ("synthcal: interrupted; run the same command again to resume "
                             "(finished shards are kept)")
    done = len(list(progress.glob("*.done")))
    time.sleep(1.0)
    assert len(list(progress.glob("*.done"))) == done < 20, "workers went on rendering after the interrupt"
    partial = out / "intersection-1.zarr.partial"
    assert not (out / "intersection-1.zarr").exists() and not temporaries(partial)
    assert zarr.open_group(zarr.storage.LocalStore(partial, read_only=True), mode="r").attrs["complete"] is False

    assert main(args) == 0  # the same command resumes
    assert main(["verify", str(out / "intersection-1.zarr")]) == 0
    assert f"OK {out / 'intersection-1.zarr'}" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "resumes"), [
    (["scenes"], False),
    (["info", "x.zarr"], False),
    (["generate", "soccer", "--out", "o"], True),
    (["split", "x.zarr"], True),
    (["bench", "--data", "d", "--datasets", "soccer", "--estimator", "identity", "--results", "r"], True),
])
def test_ctrl_c_is_exit_130_for_every_command(monkeypatch, capsys, argv, resumes):
    def interrupted(args: argparse.Namespace) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "run_command", interrupted)
    assert main(argv) == 130
    line = one_line(capsys.readouterr().err)
    assert line.startswith("synthcal: interrupted")
    assert ("run the same command again to resume" in line) == resumes


# --- item 5: messages, not tracebacks ------------------------------------------------------------

def generate_args(out: Path, *extra: str) -> list[str]:
    return ["generate", "intersection-1", "--profile", "smoke", "--out", str(out), "--quiet",
            "--config", str(CONFIG), *extra]


def test_a_full_disk_is_one_line_naming_the_file_and_the_run_resumes(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    write_bytes = Path.write_bytes
    calls = []

    def fills_up(self: Path, data: bytes) -> int:  # the 7th shard file: half written, then the disk is full
        calls.append(self)
        if len(calls) == 7:
            write_bytes(self, data[:len(data) // 2])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # as a failing write(): no file name
        return write_bytes(self, data)

    monkeypatch.setattr(Path, "write_bytes", fills_up)
    assert main(generate_args(out)) == 2
    line = one_line(capsys.readouterr().err)
    failed = calls[6]
    assert line == f"synthcal: error: {failed.parent / failed.name.split('.')[1]}: No space left on device"
    assert str(out / "intersection-1.zarr.partial") in line
    assert not temporaries(out) and not (out / "intersection-1.zarr").exists()

    monkeypatch.setattr(Path, "write_bytes", write_bytes)  # space freed: the same command finishes the store
    assert main(generate_args(out)) == 0
    assert main(["verify", str(out / "intersection-1.zarr")]) == 0


def test_a_full_disk_while_creating_the_store_leaves_nothing(tmp_path, monkeypatch, capsys):
    from synthcal.store import format as store_format  # the pipeline imports create_store from it as it runs

    create_store = store_format.create_store

    def fills_up(path: Path, *args, **kwargs) -> None:
        create_store(path, *args, **kwargs)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # zarr's own writes name no file

    monkeypatch.setattr(store_format, "create_store", fills_up)
    out = tmp_path / "out"
    assert main(generate_args(out)) == 2
    partial = out / "intersection-1.zarr.partial"
    assert one_line(capsys.readouterr().err) == f"synthcal: error: {partial}: No space left on device"
    assert sorted(p.name for p in out.iterdir()) == [".intersection-1.lock"]  # the lock file alone, as always


def test_a_read_only_out_folder_is_one_line(tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    out.mkdir()
    real_open = os.open

    def read_only(path, flags, *args, **kwargs):  # what the kernel answers in a read-only folder
        if Path(path).parent == out and flags & os.O_CREAT:
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", read_only)
    assert main(generate_args(out)) == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"synthcal: error: {out / 'intersection-1.zarr'}: ") and "Read-only file system" in line
    assert not any(out.iterdir())


def test_an_unreachable_scheduler_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(DISPATCH, "CONNECT_TIMEOUT", 1.0)
    out = tmp_path / "out"
    started = time.monotonic()
    assert main(generate_args(out, "--scheduler", "tcp://127.0.0.1:1")) == 2
    assert time.monotonic() - started < 20  # not Dask's 30 s
    assert one_line(capsys.readouterr().err) == \
        "synthcal: error: Dask scheduler 'tcp://127.0.0.1:1': no answer within 1 s"
    assert not out.exists()


def test_a_malformed_scheduler_address_is_named(tmp_path, capsys):
    assert main(generate_args(tmp_path / "out", "--scheduler", "not an address:::")) == 2
    line = one_line(capsys.readouterr().err)
    assert "'not an address:::': not a scheduler address" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("value", ["0", "-3", "many"])
def test_show_needs_a_positive_count(tmp_path, capsys, value):
    try:  # argparse's exit status, returned or raised as SystemExit
        code = main(["show", str(tmp_path / "x.zarr"), "-n", value, "-o", str(tmp_path / "m.png")])
    except SystemExit as stop:
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert f"argument -n/--n: must be an integer ≥ 1 (value '{value}')" in err and "Traceback" not in err
    assert not (tmp_path / "m.png").exists()


@pytest.mark.parametrize("command", ["info", "datasets"])
def test_a_closed_pipe_ends_quietly(smoke_stores, command):
    argv = ["info", str(smoke_stores.path("soccer"))] if command == "info" else ["datasets", "--config", str(CONFIG)]
    read, write = os.pipe()
    os.close(read)  # the reader is gone before anything is written (`| head` that has exited)
    try:
        proc = subprocess.run([sys.executable, "-m", "synthcal.cli", *argv], stdout=write, stderr=subprocess.PIPE,
                              text=True, timeout=120)
    finally:
        os.close(write)
    assert proc.returncode == 141 and proc.stderr == ""


# --- item 9: small things ------------------------------------------------------------------------

def test_version(capsys):
    from synthcal import __version__

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == f"synthcal {__version__}"


def test_every_argument_of_every_command_has_help():
    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = [f"{name}: {action.dest}" for name, sub in [("synthcal", parser), *commands.choices.items()]
               for action in sub._actions if not (action.help or "").strip()]
    assert not missing
    assert {c.dest for c in commands._choices_actions} == set(commands.choices), "a command without help"
    assert all(c.help for c in commands._choices_actions)


@pytest.mark.parametrize("value", ["0", "-2"])
@pytest.mark.parametrize("command", ["generate", "demo"])
def test_workers_must_be_positive(tmp_path, capsys, command, value):
    argv = [command, *(["soccer"] if command == "generate" else []), "--out", str(tmp_path / "o"), "--workers", value]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert f"argument --workers: must be an integer ≥ 1 (value '{value}')" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value", ["0", "-2", "two"])
def test_bench_threads_must_be_positive(tmp_path, capsys, value):
    argv = ["bench", "--data", str(tmp_path / "d"), "--datasets", "soccer", "--estimator", "identity",
            "--results", str(tmp_path / "r"), "--threads", value]
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert f"argument --threads: must be an integer ≥ 1 (value '{value}')" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize(("name", "magic"), [("m.jpg", b"\xff\xd8\xff"), ("m.JPEG", b"\xff\xd8\xff"),
                                             ("m.png", b"\x89PNG\r\n\x1a\n")])
def test_show_writes_the_format_its_name_says(smoke_stores, tmp_path, capsys, name, magic):
    output = tmp_path / name
    assert main(["show", str(smoke_stores.path("soccer")), "-n", "2", "-o", str(output)]) == 0
    assert output.read_bytes().startswith(magic) and not temporaries(tmp_path)


def test_show_refuses_an_unknown_picture_format(tmp_path, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["show", str(tmp_path / "x.zarr"), "-o", str(tmp_path / "m.gif")])
    assert stop.value.code == 2
    assert "unknown picture format '.gif'" in capsys.readouterr().err


def test_the_hint_for_missing_split_seeds_is_a_command_that_works(smoke_stores, tmp_path, capsys):
    stores = smoke_stores.copy(["intersection-1"], tmp_path / "data")
    draw_splits(stores["intersection-1"], seeds=(0,))
    bench = ["bench", "--data", str(tmp_path / "data"), "--datasets", "intersection-1", "--estimator", "identity",
             "--seeds", "5,7", "--results", str(tmp_path / "results"), "--config", str(CONFIG)]
    assert main(bench) == 2
    line = one_line(capsys.readouterr().err)
    hint = line.partition("run `")[2].rstrip("`")
    assert hint == f"synthcal split {stores['intersection-1']} --seeds 5,7"
    assert main(shlex.split(hint)[1:]) == 0
    assert drawn_seeds(open_store(stores["intersection-1"])) == (0, 5, 7)


def test_split_warns_when_it_replaces_splits_of_other_sizes(smoke_stores, tmp_path):
    store = smoke_stores.copy(["intersection-2"], tmp_path)["intersection-2"]
    assert main(["split", str(store), "--seeds", "0,1"]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same sizes: nothing replaced, no warning
        assert main(["split", str(store), "--seeds", "0,1"]) == 0
    expected = (f"{store}: seed 1: replacing its splits (train 24, test 8, dictionary 12, validation 4) with train 10, "
                "test 8, dictionary 12, validation 4; results computed on the old splits no longer match them")
    with pytest.warns(SplitsResized) as caught:
        assert main(["split", str(store), "--seeds", "1", "--train", "10"]) == 0
    assert [str(w.message) for w in caught] == [expected]
    assert cli.format_warning(warnings.formatwarning, caught[0].message, SplitsResized, "", 0) == \
        f"synthcal: warning: {expected}\n"


def test_datasets_lists_every_name_generate_and_bench_accept(tmp_path, capsys):
    import yaml

    config = yaml.safe_load(CONFIG.read_text())
    config["datasets"]["my-copy"] = {"scene": "soccer", "grid": "soccer", "pool_size": 10}
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    assert main(["datasets", "--config", str(path), "--profile", "smoke"]) == 0
    lines = capsys.readouterr().out.splitlines()
    listed = {line.split()[0]: line for line in lines if line and not line.isupper() and line[0].islower()}
    loaded = load_config(path)
    # a mix's label: mixed-K for intersection-K, else mixed-TARGET (mixed-family-1, mixed-blank-1)
    mixes = {f"mixed-{target.removeprefix('intersection-')}" for target in config["mixed_dictionaries"]}
    assert {"mixed-1", "mixed-4", "mixed-5", "mixed-family-1", "mixed-blank-1"} <= mixes
    assert set(loaded.dataset_names) | mixes == set(listed)
    assert "worldcup2014" in listed and "my-copy" in listed and "10 samples" in listed["my-copy"]
    assert "48 samples" in listed["intersection-1"]  # the smoke profile's pool
    for label in listed:  # every label names a dataset of the configuration (mixed-K: intersection-K)
        store, _ = dataset_store(tmp_path, label)
        assert store.name.removesuffix(".zarr") in loaded.dataset_names


def test_progress_bars_only_on_a_terminal(tmp_path, capsys, monkeypatch):
    from synthcal.utils.progress import interactive, show_progress

    class Terminal:
        def isatty(self) -> bool:
            return True

    assert interactive(Terminal()) and not show_progress()  # pytest's captured stderr is no terminal
    assert main(["generate", "soccer", "--profile", "smoke", "--out", str(tmp_path), "--config", str(CONFIG)]) == 0
    err = capsys.readouterr().err
    assert "sample" not in err and "%|" not in err, err
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert show_progress() and not show_progress(False)


@pytest.mark.parametrize("command", ["scene", "show"])
def test_a_picture_into_a_read_only_folder_names_the_picture(smoke_stores, tmp_path, monkeypatch, capsys, command):
    """Issue 23: the error names the output file, never atomic_write's temporary beside it."""
    import io

    folder = tmp_path / "read-only"
    folder.mkdir()
    real_open = io.open

    def read_only(file, mode="r", *args, **kwargs):  # what the kernel answers in a read-only folder (as root too)
        if isinstance(file, (str, os.PathLike)) and Path(file).parent == folder and set(mode) & set("wax+"):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(file))
        return real_open(file, mode, *args, **kwargs)

    monkeypatch.setattr(io, "open", read_only)
    picture = folder / "picture.png"
    argv = ["scene", "intersection-1"] if command == "scene" else ["show", str(smoke_stores.path("soccer")), "-n", "2"]
    assert main([*argv, "-o", str(picture)]) == 2
    assert one_line(capsys.readouterr().err) == f"synthcal: error: {picture}: Permission denied"
    assert not any(folder.iterdir())


def test_a_selection_score_with_nothing_to_rank_stops_bench_before_any_run(tmp_path, capsys):
    argv = ["bench", "--data", str(tmp_path / "data"), "--datasets", "intersection-1", "--estimator", "proposed",
            "--results", str(tmp_path / "results"), "--profile", "smoke", "--selection-score", "iou", "--yes"]
    assert main(argv) == 2
    line = one_line(capsys.readouterr().err)
    assert "selection_score 'iou'" in line and "set patience or select too" in line
    assert not (tmp_path / "results" / "runs").exists()
