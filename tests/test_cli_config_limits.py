"""Careless and hostile configurations through `synthcal generate` (issue 23 items 2, 6-9): each is
exit 2 with one line on standard error, no traceback, nothing written."""

from __future__ import annotations

import shutil
import time
from collections import namedtuple
from pathlib import Path

import pytest
from test_cli import ROOT, assert_nothing_written, base_config, run

from synthcal.cli import main
from synthcal.config import MAX_MESSAGE
from synthcal.generate import resources


def refused(code: int, err: str, out: Path) -> str:
    """The one line of a refusal, after checking it is one (exit 2, no traceback, nothing written)."""
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err[:2000]
    assert "Traceback" not in err and lines[0].startswith("synthcal: error: ")
    assert len(lines[0]) <= len("synthcal: error: ") + MAX_MESSAGE
    assert_nothing_written(out)
    return lines[0]


def run_text(tmp_path: Path, text: str, capsys) -> tuple[int, str, Path]:
    """``generate soccer`` with the configuration file spelled as ``text``."""
    path = tmp_path / "datasets.yaml"
    path.write_text(text)
    out = tmp_path / "out"
    code = main(["generate", "soccer", "--profile", "smoke", "--quiet", "--out", str(out), "--config", str(path)])
    return code, capsys.readouterr().err, out


def with_soccer_axis(axis: str, **values: float) -> dict:
    config = base_config()
    config["grids"]["soccer"][axis].update(values)
    return config


# --- item 2 and 6: numbers ------------------------------------------------------------------------

@pytest.mark.parametrize(("axis", "key", "value"), [
    ("pan_deg", "step", float("inf")), ("pan_deg", "step", float("nan")), ("tilt_deg", "start", float("-inf")),
    ("focal_px", "stop", float("inf")),
])
def test_non_finite_grid_numbers(tmp_path, capsys, axis, key, value):
    code, err, out = run(tmp_path, with_soccer_axis(axis, **{key: value}), "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert f"grids.soccer.{axis}.{key}" in line and "finite" in line and repr(value) in line


def test_a_step_giving_too_many_values_names_the_axis(tmp_path, capsys):
    code, err, out = run(tmp_path, with_soccer_axis("pan_deg", step=1e-12), "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "grids.soccer.pan_deg" in line and "1e-12" in line and "raise the step" in line


def test_a_range_whose_width_overflows(tmp_path, capsys):
    code, err, out = run(tmp_path, with_soccer_axis("tilt_deg", start=-1e308, stop=1e308), "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "grids.soccer.tilt_deg" in line and "1e+308" in line


def test_a_grid_over_10_to_the_12_cameras_names_its_largest_axis(tmp_path, capsys):
    config = base_config()
    grid = config["grids"]["soccer"]
    grid["pan_deg"]["step"], grid["tilt_deg"]["step"], grid["focal_px"]["step"] = 1e-4, 1e-4, 1e-2
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "grids.soccer" in line and "pan_deg (500001 values)" in line and "1e+12" in line


def test_a_non_finite_number_elsewhere(tmp_path, capsys):
    config = base_config()
    config["defaults"]["appearance"] = {"brightness": float("inf")}
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    assert "defaults.appearance.brightness" in refused(code, err, out)


# --- item 7: sizes that cannot fit ----------------------------------------------------------------

@pytest.mark.parametrize("size", [[60000, 40000], [16385, 100], [4, 4]])
def test_image_sides_out_of_range(tmp_path, capsys, size):
    config = base_config()
    config["profiles"]["smoke"]["image_size"] = size
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "profiles.smoke.image_size" in line and "16384" in line and str(size) in line


def test_image_sides_that_are_not_integers(tmp_path, capsys):
    config = base_config()
    config["profiles"]["smoke"]["image_size"] = [1e9, 1e9]
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "profiles.smoke.image_size" in line and "1000000000.0" in line


def test_a_run_over_max_memory_names_the_figure_and_the_knobs(tmp_path, capsys):
    code, err, out = run(tmp_path, base_config(), "soccer", "--max-memory", "1M", capsys=capsys)
    line = refused(code, err, out)
    assert "datasets.soccer" in line and "--max-memory (1.0 MiB)" in line
    assert "--workers" in line and "shard_size" in line and "image_size" in line


def test_a_run_over_the_machines_memory(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(resources, "physical_memory", lambda: 2**20)
    code, err, out = run(tmp_path, base_config(), "soccer", capsys=capsys)
    assert "this machine's memory (1.0 MiB)" in refused(code, err, out)


def test_a_store_larger_than_the_free_disk(tmp_path, capsys, monkeypatch):
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(10**6, 10**6 - 1000, 1000))
    code, err, out = run(tmp_path, base_config(), "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "free in" in line and str(tmp_path / "out") in line and "--n" in line


def test_the_estimates_bound_what_a_worker_holds():
    """The memory estimate covers the arrays a shard really holds (rendered at 64 × 36)."""
    from synthcal.config import load_config
    from synthcal.generate.pipeline import load_scene, plan_cameras, render_samples

    spec = load_config(ROOT / "datasets.yaml").resolve("soccer", "smoke")
    scene = load_scene(spec)
    _, homographies = plan_cameras(spec, scene)
    images, semantics = render_samples(scene, homographies[:spec.shard_size], 0, spec)
    held = images.nbytes + 2 * semantics.nbytes + scene.image.nbytes + scene.semantic.nbytes
    assert held < resources.shard_memory(spec, scene.semantic.size) < 3 * held
    assert resources.store_bytes(spec, scene.semantic.size) > spec.pool_size * (images[0].nbytes + semantics[0].nbytes)


# --- item 8: YAML as hostile input ----------------------------------------------------------------

def test_nesting_5000_deep(tmp_path, capsys):
    code, err, out = run_text(tmp_path, "grids: " + "[" * 5000 + "]" * 5000 + "\n", capsys)
    line = refused(code, err, out)
    assert "grids.0.0" in line and "64 levels" in line and "(line 1)" in line


def test_a_billion_laughs(tmp_path, capsys):
    lines = ['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for level in "bcdefghi":
        previous = chr(ord(level) - 1)
        lines.append(f"{level}: &{level} [{', '.join(['*' + previous] * 9)}]")
    started = time.perf_counter()
    code, err, out = run_text(tmp_path, "\n".join(lines) + "\n", capsys)
    assert time.perf_counter() - started < 5
    assert "100000 values" in refused(code, err, out)


def test_an_alias_inside_its_own_anchor(tmp_path, capsys):
    code, err, out = run_text(tmp_path, "grids: &a [*a]\n", capsys)
    assert "contains it" in refused(code, err, out)


def test_a_file_over_10_mib(tmp_path, capsys):
    code, err, out = run_text(tmp_path, "# padding\n" * (2**20 + 1), capsys)
    assert "10 MiB" in refused(code, err, out)


def test_yaml_syntax_errors_are_one_line(tmp_path, capsys):
    code, err, out = run_text(tmp_path, "grids:\n\t- soccer\n", capsys)
    line = refused(code, err, out)
    assert "not valid YAML" in line and "line 2" in line


def test_anchors_and_merge_keys_still_work(tmp_path, capsys):
    text = ((ROOT / "datasets.yaml").read_text()
            .replace("grids:", "grids:\n  copy: &copy\n    pan_deg: {start: -25, stop: 25, step: 1}\n"
                               "    tilt_deg: {start: -15, stop: 0, step: 1}\n"
                               "    focal_px: {start: 500, stop: 800, step: 50}\n"
                               "  merged:\n    <<: *copy\n    jitter: true", 1))
    path = tmp_path / "datasets.yaml"
    path.write_text(text)
    from synthcal.config import load_config

    grids = load_config(path).config.grids
    assert grids["merged"].jitter and grids["merged"].pan_deg == grids["copy"].pan_deg


# --- item 9: accepted silently --------------------------------------------------------------------

@pytest.mark.parametrize("value", [True, "48", 48.0])
def test_a_pool_size_that_is_not_an_integer(tmp_path, capsys, value):
    config = base_config()
    config["datasets"]["soccer"]["pool_size"] = value
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "datasets.soccer.pool_size" in line and "integer" in line and repr(value) in line


def test_a_bool_that_is_a_string(tmp_path, capsys):
    config = base_config()
    config["grids"]["soccer"]["jitter"] = "yes"
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    assert "grids.soccer.jitter" in refused(code, err, out)


def test_duplicate_keys_name_both_lines(tmp_path, capsys):
    text = (ROOT / "datasets.yaml").read_text()
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("  image_size:")) + 1
    text = text.replace("  image_size: [256, 144]", "  image_size: [256, 144]\n  image_size: [512, 288]", 1)
    code, err, out = run_text(tmp_path, text, capsys)
    line = refused(code, err, out)
    assert "defaults.image_size" in line and f"lines {first} and {first + 1}" in line


def test_duplicate_top_level_keys(tmp_path, capsys):
    text = (ROOT / "datasets.yaml").read_text()
    first = text.splitlines().index("version: 1") + 1
    code, err, out = run_text(tmp_path, text + "version: 1\n", capsys)
    assert f": version: duplicate key on lines {first} and {len(text.splitlines()) + 1}" in refused(code, err, out)


def test_a_version_this_code_does_not_read(tmp_path, capsys):
    config = base_config()
    config["version"] = 2
    code, err, out = run(tmp_path, config, "soccer", capsys=capsys)
    line = refused(code, err, out)
    assert "version" in line and "version 1" in line and "(value 2)" in line
