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


INTERVAL = re.compile(r"[+−]\d+\.\d\d \[[+−]\d+\.\d\d, [+−]\d+\.\d\d\]")


def test_every_interval_the_readme_quotes_is_one_the_report_prints():
    """The README summarises docs/reproduction.md; a figure there that the report does not print (a rerun changed
    it, a typo) would go unnoticed, since only the report is checked against the archives."""
    readme = README.read_text(encoding="utf-8")
    report = (README.parent / "docs" / "reproduction.md").read_text(encoding="utf-8")
    quoted = INTERVAL.findall(readme)
    assert quoted, "README.md quotes no interval: the pattern no longer matches its figures"
    assert [interval for interval in quoted if interval not in report] == []
