"""The README's Python API example runs exactly as written (issue 21)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def first_python_block(text: str, section: str) -> str:
    """The first ```python block after the heading ``section``."""
    start = text.index(f"\n{section}\n")
    match = re.compile(r"^```python\n(.*?)^```$", re.S | re.M).search(text, start)
    assert match is not None, f"README.md: no ```python block under {section!r}"
    return match.group(1)


def test_python_api_example_runs_and_prints_an_iou(tmp_path):
    code = first_python_block(README.read_text(), "## Python API")
    assert "generate_store" in code and "evaluate" in code  # the block the section promises
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    found = re.search(r"IoU (\d+\.\d+)", done.stdout)
    assert found is not None, done.stdout
    assert 0.0 <= float(found.group(1)) <= 1.0
    assert list(tmp_path.iterdir()) == []  # it wrote only in its temporary folder
