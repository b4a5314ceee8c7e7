"""Setting up an OpenStreetMap scene (issue 24 item 7): the README's example runs as written against the
shipped extract, the printed entry's path is relative to the YAML it is for, a missing file shows where it
was looked for, and `info` prints a scene's licence."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from osm_fixtures import CENTER, junction

from synthcal.cli import main
from synthcal.config import load_config

ROOT = Path(__file__).resolve().parents[2]
EXTRACT = ROOT / "examples" / "osm" / "esplanadi.osm.pbf"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SYNTHCAL_CACHE", str(tmp_path_factory.mktemp("cache")))


def readme_osm_commands() -> str:
    """The first ``` block of the README's OpenStreetMap section."""
    text = (ROOT / "README.md").read_text()
    start = text.index("\n## Intersections from OpenStreetMap\n")
    match = re.compile(r"^```\n(.*?)^```$", re.S | re.M).search(text, start)
    assert match is not None
    return match.group(1)


def test_the_shipped_extract_is_small_and_licensed():
    assert 0 < EXTRACT.stat().st_size < 300_000
    licence = (EXTRACT.parent / "LICENCE.md").read_text()
    assert "© OpenStreetMap contributors" in licence and "ODbL" in licence


def test_the_readme_osm_example_runs_as_written(tmp_path):
    commands = readme_osm_commands()
    assert "examples/osm/esplanadi.osm.pbf" in commands and "synthcal table" in commands
    (tmp_path / "examples").symlink_to(ROOT / "examples")  # the commands run from the repository's root
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "OMP_NUM_THREADS": "1"}
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", commands], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "licence      ODbL-1.0; © OpenStreetMap contributors" in done.stdout
    assert re.search(r"\| esplanadi \| \**\d+\.\d+", done.stdout), done.stdout[-2000:]
    entry = yaml.safe_load((tmp_path / "work" / "esplanadi.yaml").read_text())["scenes"]["esplanadi"]["osm"]
    assert entry["file"] == "../examples/osm/esplanadi.osm.pbf"


def test_the_printed_entry_is_relative_to_the_yaml_it_is_for(tmp_path, capsys):
    (tmp_path / "maps").mkdir()
    source = junction(tmp_path / "maps" / "junction.osm")
    target = tmp_path / "configs" / "here.yaml"
    target.parent.mkdir()
    argv = ["osm", str(source), "--center", f"{CENTER[0]},{CENTER[1]}", "--size", "60,80", "--ppm", "2",
            "--name", "j", "-o", str(tmp_path / "pictures"), "--yaml", str(target)]
    assert main(argv) == 0
    target.write_text(capsys.readouterr().out)
    entry = yaml.safe_load(target.read_text())["scenes"]["j"]["osm"]
    assert entry["file"] == "../maps/junction.osm"
    config = load_config(target)
    assert os.path.samefile(config.config.scenes["j"].osm.file, source)
    assert "j" in config.dataset_names and "intersection-1" in config.dataset_names


def test_a_missing_extract_shows_where_it_was_looked_for(tmp_path, capsys, monkeypatch):
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    path = folder / "datasets.yaml"
    path.write_text(yaml.safe_dump({
        "scenes": {"j": {"osm": {"file": "junction.osm.pbf", "center": list(CENTER)}}},
        "datasets": {"j": {"scene": "j", "grid": "intersection", "pool_size": 8}}}))
    monkeypatch.chdir(tmp_path)  # the file is looked for beside the YAML, not here
    assert main(["generate", "j", "--profile", "smoke", "--quiet", "--out", "out", "--config",
                 "elsewhere/datasets.yaml"]) == 2
    err = capsys.readouterr().err
    assert "osm.file: file not found" in err and str(folder / "junction.osm.pbf") in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_the_junction_family_figure_is_made_as_docs_osm_says(tmp_path):
    text = (ROOT / "docs" / "osm.md").read_text()
    start = text.index("\n### A junction family\n")
    commands = re.compile(r"^```\n(.*?)^```$", re.S | re.M).search(text, start)
    assert commands is not None and "junction_family.py" in commands.group(1)
    (tmp_path / "examples").symlink_to(ROOT / "examples")  # the commands run from the repository's root
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "OMP_NUM_THREADS": "1"}
    script = commands.group(1).replace("python ", f"{sys.executable} ")
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    import cv2

    picture = cv2.imread(str(tmp_path / "docs" / "osm_junction_family.png"))
    tiles = min(4, len((tmp_path / "work" / "j.csv").read_text().splitlines()) - 1)  # --datasets 4 of the rows
    assert tiles == 4 and f"{tiles} scenes" in done.stdout
    assert picture.shape[1] == tiles * (208 + 8)  # one 208-px tile and its margin per junction of the snippet
    assert (ROOT / "docs" / "osm_junction_family.png").stat().st_size < 300_000
