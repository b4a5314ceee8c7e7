"""The scripts of docs/sweeps/ as modules, and the parts of docs/reproduction.md their tests read."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / "docs" / "reproduction.md"


def sweep_script(name: str) -> ModuleType:
    """``docs/sweeps/<name>.py`` imported as a module (the scripts are run by hand, not installed).

    Their folder goes on ``sys.path`` as it does when a script is run, so a script finds the helpers beside it
    (``report_figures``).
    """
    folder = ROOT / "docs" / "sweeps"
    if str(folder) not in sys.path:
        sys.path.append(str(folder))
    path = folder / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"sweeps_{name}", path)
    assert spec is not None and spec.loader is not None, path
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # a dataclass of the script looks its module up while it is defined
    spec.loader.exec_module(module)
    return module


def report_section(heading: str) -> str:
    """The text of reproduction.md from ``heading`` (a ``## `` line's start) to the next ``## `` heading."""
    return REPORT.read_text(encoding="utf-8").split(heading, 1)[1].split("\n## ", 1)[0]


def table_rows(lines: str) -> list[list[str]]:
    """The cells of each Markdown table row in ``lines``, the ``| cell |`` header and the separator left out."""
    return [line.strip("| ").split(" | ") for line in lines.splitlines()
            if line.startswith("| ") and not line.startswith("| cell")]
