"""The runs archive: ``synthcal table RESULTS --layout runs --format csv`` read back in place of the folder."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from run_records import write_run

import synthcal
from synthcal.cli import main

BASE = np.array([0.60, 0.62, 0.58, 0.61, 0.63])
SHIFT = np.array([0.030, -0.010, 0.035, 0.020, -0.005])


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Five seeds of sha2020 and proposed on two losses, with choices, seconds, a UNet and a missed class."""
    results = tmp_path_factory.mktemp("results")
    for loss, sign in (("top-mse", 1.0), ("mse", -1.0)):
        for seed in range(5):
            write_run(results, "sha2020", loss, seed, BASE[seed], 0.001, 100.0 + seed, threads=1 + seed % 2,
                      capability="AVX2" if seed == 3 else "AVX512")
            write_run(results, "proposed", loss, seed, BASE[seed] + sign * SHIFT[seed], 0.0003, 200.0 + seed,
                      unet_epochs=20 + seed, missed=[3] if seed == 1 else [])
            for model, iou in (("sha2020", BASE[seed]), ("proposed", BASE[seed] + sign * SHIFT[seed])):
                pd.DataFrame({"pool_index": range(4), "iou": iou + np.array([0.0, 0.01, -0.01, 0.02])}).to_csv(
                    results / "runs" / f"intersection-1_{model}_{loss}_s{seed}" / "metrics.csv", index=False)
    return results


def _table(capsys, *args: str) -> tuple[str, str]:
    assert main(["table", *map(str, args)]) == 0
    captured = capsys.readouterr()
    return captured.out, captured.err


def _write_archive(folder: Path, path: Path, capsys) -> Path:
    out, _ = _table(capsys, folder, "--layout", "runs", "--format", "csv")
    path.write_text(out)
    return path


def test_archive_holds_one_row_per_run_with_what_validation_chose(folder, tmp_path, capsys):
    archive = pd.read_csv(_write_archive(folder, tmp_path / "runs.csv", capsys))
    assert len(archive) == 20 and archive["run_id"].is_unique
    row = archive.set_index("run_id").loc["intersection-1_proposed_mse_s1"]
    assert row["iou"] == pytest.approx(BASE[1] - SHIFT[1])
    assert (row["learning_rate"], row["unet_epochs"], row["stn_epochs"], row["seconds"]) == (0.0003, 21, 11, 201)
    assert row["unet_missed"] == "3" and row["loss"] == "mse" and row["seed"] == 1
    # The torch threads each run's machine record names (a record without one: empty).
    assert np.isnan(row["torch_threads"])
    assert archive.set_index("run_id").loc["intersection-1_sha2020_mse_s1", "torch_threads"] == 2
    # And the instruction set its torch kernels used: a rerun on another one differs in the last bits.
    assert row.isna()["cpu_capability"]
    assert archive.set_index("run_id")["cpu_capability"].filter(like="sha2020_mse").tolist() == \
        ["AVX512", "AVX512", "AVX512", "AVX2", "AVX512"]
    # In Markdown, the keys that vary, the seed, the reading in percent and the choices.
    out, _ = _table(capsys, folder, "--layout", "runs")
    assert "| intersection-1 | proposed | mse | 1 | 63.00 | 0.0003 | 21 | 11 | 201 | intersection-1_proposed_mse_s1 |" \
        in out


@pytest.mark.parametrize("layout", ["report", "models", "runs"])
def test_archive_prints_the_folders_tables(folder, tmp_path, capsys, layout):
    archive = _write_archive(folder, tmp_path / "runs.csv", capsys)
    for fmt in ("csv", "md"):
        from_folder = _table(capsys, folder, "--layout", layout, "--format", fmt)
        from_archive = _table(capsys, archive, "--layout", layout, "--format", fmt)
        assert from_archive == from_folder
    if layout == "report":  # the missed class is named from the archive too
        assert "UNet missed class 3: intersection-1_proposed_mse_s1" in from_archive[0]


def test_archive_pairs_without_a_bootstrap_interval(folder, tmp_path, capsys):
    archive = _write_archive(folder, tmp_path / "runs.csv", capsys)
    paired = [pd.read_csv(io.StringIO(_table(capsys, source, "--paired", "proposed", "sha2020", "--format",
                                             "csv")[0])) for source in (folder, archive)]
    t_columns = ["dataset", "loss", "mean", "std", "t_low", "t_high", "p", "n_pairs", "a_wins"]
    pd.testing.assert_frame_equal(paired[1][t_columns], paired[0][t_columns])
    assert paired[0][["boot_low", "boot_high"]].notna().all().all()  # the folder's per-image scores...
    assert paired[1][["boot_low", "boot_high"]].isna().all().all()  # ... the archive does not keep
    assert paired[1].set_index("loss").loc["top-mse", "mean"] == pytest.approx(100.0 * SHIFT.mean())
    # An archive is a side of --against as a folder is: the same cell and seed pair, A − A is 0.
    out, _ = _table(capsys, folder, "--against", archive, "--paired", "loss=mse", "loss=mse", "--format", "csv")
    across = pd.read_csv(io.StringIO(out))
    assert (across["mean"] == 0.0).all() and (across["n_pairs"] == 5).all()
    report = synthcal.report(archive)
    assert list(report.loc[report["model"] == "proposed", "learning_rates"]) == ["0.0003, " * 4 + "0.0003"] * 2


def test_a_broken_archive_is_one_line_naming_file_row_and_column(folder, tmp_path, capsys):
    archive = pd.read_csv(_write_archive(folder, tmp_path / "runs.csv", capsys), dtype=str)
    bad = tmp_path / "bad.csv"
    archive.drop(columns=["seed", "learning_rate"]).to_csv(bad, index=False)
    assert main(["table", str(bad)]) == 2
    assert f"{bad}: not a runs archive of `synthcal table --layout runs --format csv`: no column 'seed', " \
           f"'learning_rate'" in capsys.readouterr().err
    archive.assign(iou=["0.5"] * 3 + ["n/a"] + ["0.5"] * 16).to_csv(bad, index=False)
    assert main(["table", str(bad)]) == 2
    assert f"{bad}, row 5, column 'iou': 'n/a' is not a number" in capsys.readouterr().err
    archive.assign(seed=["1.5"] * 20).to_csv(bad, index=False)
    assert main(["table", str(bad)]) == 2
    assert f"{bad}, row 2, column 'seed': '1.5' is not an integer" in capsys.readouterr().err
    assert main(["table", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv: no such results folder or runs archive" in capsys.readouterr().err
    # What needs the runs' files says so.
    good = _write_archive(folder, tmp_path / "good.csv", capsys)
    assert main(["table", str(good), "--layout", "diagnostics"]) == 2
    assert f"give the results folder ({good} is a runs archive)" in capsys.readouterr().err
    assert main(["plot", str(good), "--output", str(tmp_path / "plots")]) == 2
    assert "a runs archive; plot reads each run's estimates" in capsys.readouterr().err
    assert not (tmp_path / "plots").exists()
