"""Every script of ``examples/`` runs at smoke size, in a process of its own, into a given folder (issue 21)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# What each script must print: a number it computed, not just that it ran.
EXPECTED = {
    "own_estimator.py": r"NearestThumbnail\s+\d\.\d+\s+\d\.\d+\s+1\.0",
    "user_scene.py": r"my-crossing\.zarr: 8 test images; classes seen: background \d+%, road [1-9]\d*%",
    "osm_scene.py": r"junction\.zarr: scene 1300 × 1900 px, .*road [1-9]\d*%.*© OpenStreetMap contributors",
    "read_with_zarr.py": r"agrees with the stored semantic map on 100\.0% of pixels",
    "dataloader_loop.py": r"test pixel accuracy \d+\.\d% \(8 images\)",
}


def test_every_example_is_tested():
    assert sorted(path.name for path in EXAMPLES.glob("*.py")) == sorted(EXPECTED)


@pytest.mark.parametrize("script", sorted(EXPECTED))
def test_example_runs(script, tmp_path):
    out = tmp_path / "out"
    env = {**os.environ, "SYNTHCAL_CACHE": str(tmp_path / "cache"), "OMP_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, str(EXAMPLES / script), str(out)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    assert re.search(EXPECTED[script], done.stdout), done.stdout
    assert out.is_dir() and {p.name for p in tmp_path.iterdir()} <= {"cache", "out"}  # wrote only where told
