"""The front door (issue 21): ``import synthcal`` is cheap and every public name resolves."""

from __future__ import annotations

import ast
import inspect
import json
import subprocess
import sys
from pathlib import Path

import pytest

import synthcal

HEAVY = ("torch", "cv2", "pandas", "zarr")
ROOT = Path(__file__).resolve().parents[1]


def _in_fresh_python(code: str) -> dict:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_synthcal_loads_no_heavy_dependency():
    loaded = _in_fresh_python(f"import json, sys, synthcal; print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")
    assert loaded == []


def test_asking_for_a_name_imports_what_it_needs_then():
    # The check above could pass because the names never load anything; this one fails then.
    loaded = _in_fresh_python("import json, sys, synthcal; synthcal.SplitDataset; "
                              f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")
    # SplitDataset's module reads stores (zarr) and leaves torch until an item is asked for.
    assert "zarr" in loaded and "torch" not in loaded


def test_every_public_name_resolves_with_a_runnable_example():
    exports = synthcal.EXPORTS
    assert set(synthcal.__all__) == {"__version__", *exports}
    for name, target in exports.items():
        module, _, attribute = target.partition(":")
        value = getattr(synthcal, name)
        assert value is getattr(sys.modules[module], attribute), name
        assert ">>> " in (inspect.getdoc(value) or ""), f"{name}: no example in its docstring"
    assert set(dir(synthcal)) >= set(exports)


def test_no_public_name_is_shadowed_by_a_subpackage():
    # `synthcal.generate` would be the subpackage once anything imported it, never the function.
    submodules = {path.stem if path.suffix == ".py" else path.name for path in (ROOT / "synthcal").iterdir()
                  if path.suffix == ".py" or (path / "__init__.py").is_file()}
    assert not set(synthcal.EXPORTS) & submodules


def test_type_checking_imports_mirror_the_exports():
    # mypy sees the names through the TYPE_CHECKING block: it must say what EXPORTS says.
    tree = ast.parse((ROOT / "synthcal" / "__init__.py").read_text())
    block = next(node for node in tree.body if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING")
    imported = {alias.asname or alias.name: f"{node.module}:{alias.name}"
                for node in block.body if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert imported == synthcal.EXPORTS


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        synthcal.no_such_name  # noqa: B018
