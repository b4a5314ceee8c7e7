"""Every byte of a store under its manifest (issue 23, items 1 and 5): any single change to any file is found.

(b) of the issue: for a smoke store with splits and a mixed dictionary, every file
of the store is enumerated (not a sample) and, one at a time, has a byte flipped,
is truncated, is deleted; ``verify_store`` must report a problem naming that file.
Then the command line: a damaged split or metadata document is one line, exit 2,
no traceback, nothing written, wherever the store is opened.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from synthcal.cli import main
from synthcal.data import load_split
from synthcal.generate.splits import draw_splits
from synthcal.store import MANIFEST_FILE, CorruptStore, read_manifest, verify_store, write_manifest

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "datasets.yaml"
TARGET = "intersection-1"
SOURCES = [f"intersection-{k}" for k in range(2, 6)]


@pytest.fixture(scope="module")
def sealed(smoke_stores, tmp_path_factory) -> Path:
    """intersection-1 with seed 0's splits and mixed dictionary (its sources beside it); never written to after."""
    stores = smoke_stores.copy([TARGET, *SOURCES], tmp_path_factory.mktemp("sealed"))
    draw_splits(stores[TARGET], seeds=[0], mixed=True)
    return stores[TARGET]


@pytest.fixture
def store(sealed, tmp_path) -> Path:
    """A copy to damage, with the sources beside it."""
    for name in SOURCES:
        (tmp_path / f"{name}.zarr").symlink_to(sealed.parent / f"{name}.zarr")
    return Path(shutil.copytree(sealed, tmp_path / sealed.name))


def every_file(store: Path) -> list[Path]:
    """Each file under the store folder, found by walking it (independent of the manifest's own listing)."""
    return sorted(p for p in store.rglob("*") if p.is_file())


def flip(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x40
    path.write_bytes(bytes(data))


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])


DAMAGE = {"flipped": flip, "truncated": truncate, "deleted": Path.unlink}


def test_the_store_covers_metadata_splits_and_the_mixed_dictionary(sealed):
    names = {p.relative_to(sealed).as_posix() for p in every_file(sealed)}
    assert {"zarr.json", "image/zarr.json", "splits/seed-0/test/c/0",
            "splits/seed-0/mixed_dictionary/index/c/0", MANIFEST_FILE} <= names
    assert set(read_manifest(sealed).files) == names - {MANIFEST_FILE}
    assert verify_store(sealed).ok


@pytest.mark.parametrize("damage", DAMAGE)
def test_any_single_change_to_any_file_is_reported_naming_it(store, damage):
    files = every_file(store)
    assert len(files) > 40  # image, semantic, homography, camera, scene, splits, mixed dictionary, metadata
    missed = []
    for path in files:
        original = path.read_bytes()
        DAMAGE[damage](path)
        problems = verify_store(store).problems
        if not any(str(path) in problem for problem in problems):
            missed.append(f"{path.relative_to(store)}: {problems}")
        path.write_bytes(original)  # restored: the next file is the only change
    assert not missed, "\n".join(missed)
    assert verify_store(store).ok


def run_cli(capsys, *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    return status, capsys.readouterr().err


def files_of(folder: Path) -> dict[str, int]:
    return {p.relative_to(folder).as_posix(): p.stat().st_mtime_ns for p in folder.rglob("*")}


def assert_one_line(status: int, err: str, *expected: str) -> None:
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and lines[0].startswith("synthcal: error: "), err
    assert "Traceback" not in err and all(text in lines[0] for text in expected), err


def test_a_deleted_split_chunk_is_refused_everywhere(store, tmp_path, capsys):
    """Item 1: without the manifest's cover, bench scored another test set."""
    lost = store / "splits/seed-0/test/c/0"
    lost.unlink()
    before = files_of(tmp_path)
    for argv in (["info", str(store)], ["split", str(store), "--seeds", "0"],
                 ["show", str(store), "-o", str(tmp_path / "show.png")],
                 ["bench", "--data", str(tmp_path), "--datasets", TARGET, "--estimator", "identity", "--seeds", "0",
                  "--results", str(tmp_path / "results"), "--profile", "smoke", "--config", str(CONFIG), "--quiet"]):
        assert_one_line(*run_cli(capsys, *argv), f"{lost}: missing", f"synthcal verify {store}")
    assert files_of(tmp_path) == before  # nothing written: no results, no picture, no resealed manifest
    with pytest.raises(CorruptStore, match=f"{lost}: missing"):
        load_split(store, "test", seed=0)
    assert main(["verify", str(store)]) == 1 and f"  {lost}: missing" in capsys.readouterr().out


def test_a_split_array_added_by_hand_is_refused(store, capsys):
    planted = store / "splits/seed-0/holdout"
    shutil.copytree(store / "splits/seed-0/test", planted)
    assert_one_line(*run_cli(capsys, "info", str(store)), f"{planted / 'zarr.json'}: a file the manifest does not list")


def damage_root(store: Path) -> Path:
    path = store / "zarr.json"
    path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    return path


def delete_image_metadata(store: Path) -> Path:
    path = store / "image/zarr.json"
    path.unlink()
    return path


def change_shape(store: Path) -> Path:
    path = store / "image/zarr.json"
    meta = json.loads(path.read_text())
    meta["shape"][1] += 1
    path.write_text(json.dumps(meta))
    return path


@pytest.mark.parametrize("damage", [damage_root, delete_image_metadata, change_shape])
def test_damaged_metadata_is_one_line_wherever_the_store_is_opened(store, tmp_path, damage, capsys):
    """Item 5: a truncated root zarr.json, a deleted image/zarr.json, a changed shape."""
    path = damage(store)
    before = files_of(tmp_path)
    for argv in (["info", str(store)], ["info", str(store), "--json"], ["split", str(store), "--seeds", "0"],
                 ["bench", "--data", str(tmp_path), "--datasets", TARGET, "--estimator", "identity", "--seeds", "0",
                  "--results", str(tmp_path / "results"), "--profile", "smoke", "--config", str(CONFIG), "--quiet"]):
        assert_one_line(*run_cli(capsys, *argv), str(path))
    assert files_of(tmp_path) == before
    status = main(["verify", str(store)])
    out, err = capsys.readouterr()
    assert status == 1 and f"  {path}: " in out and not err


def test_a_damaged_manifest_is_one_line(store, capsys):
    path = store / MANIFEST_FILE
    path.write_text(path.read_text().replace('"state": "sealed"', '"state": "sealed" '))  # one byte more
    assert_one_line(*run_cli(capsys, "info", str(store)), f"{path}: seal")
    path.unlink()
    assert_one_line(*run_cli(capsys, "info", str(store)), f"{path}: missing")


def test_a_killed_split_drawing_is_finished_by_the_next(store, capsys):
    write_manifest(store, "writing", read_manifest(store).files)  # as a drawer killed after begin() leaves it
    assert_one_line(*run_cli(capsys, "info", str(store)), f"`synthcal split {store}` finishes the job")
    assert main(["split", str(store), "--seeds", "0"]) == 0
    assert read_manifest(store).state == "sealed" and verify_store(store).ok
