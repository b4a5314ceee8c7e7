"""What is imported where: torch (seconds of import) only when a torch object is asked for.

Every harness run starts a fresh process (:mod:`synthcal.eval.isolation`), and the CLI
answers ``--version`` and ``--help`` at once, so neither may pay for torch when the
estimator or command does not use it. Each check runs in a fresh interpreter: this
process has long imported torch.
"""

import json
import subprocess
import sys

import pytest

from synthcal.generate.splits import draw_splits


def fresh(code: str) -> dict:
    """Run ``code`` in a new interpreter; it prints one JSON object, returned here."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


TORCH = "sorted(m for m in sys.modules if m == 'torch' or m.startswith('torch.'))"


def test_importing_synthcal_data_imports_no_torch():
    seen = fresh(f"import sys, json; import synthcal.data; print(json.dumps({{'torch': {TORCH}}}))")
    assert seen["torch"] == []


@pytest.mark.parametrize("estimator", ["identity", "template"])
def test_a_numpy_estimators_run_process_imports_no_torch(estimator, smoke_stores, tmp_path):
    """The run's process, from its imports through loading the splits, fit and predict."""
    store = smoke_stores.copy(["intersection-1"], tmp_path)["intersection-1"]
    draw_splits(store, seeds=[0])
    run = {"dataset": "intersection-1", "store": str(store), "mixed": None, "store_hash": "", "estimator": estimator,
           "model": estimator, "seed": 0}
    seen = fresh("import sys, json; from pathlib import Path; "
                 "from synthcal.eval.isolation import estimate_in_process, run_child; from synthcal.eval.runs import Run; "
                 f"out = estimate_in_process(Run(**{run!r}), Path({str(tmp_path)!r}), False, lambda stage: None); "
                 f"print(json.dumps({{'torch': {TORCH}, 'error': out['error'], 'sizes': out['sizes'], "
                 "'estimates': len(out['estimates'])}))")
    assert seen["error"] == "" and seen["estimates"] == seen["sizes"]["test"] > 0
    assert seen["torch"] == []


def test_version_imports_no_torch():
    seen = fresh("import sys, json, contextlib, io\nfrom synthcal.cli import main\n"
                 "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
                 "    try:\n        main(['--version'])\n    except SystemExit:\n        pass\n"
                 f"print(json.dumps({{'torch': {TORCH}, 'out': out.getvalue()}}))")
    assert seen["out"].startswith("synthcal ") and seen["torch"] == []

