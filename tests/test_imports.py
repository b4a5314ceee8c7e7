"""What is imported where: torch (seconds of import) only when a torch object is asked for.

Every harness run starts a fresh process (:mod:`synthcal.eval.isolation`), and the CLI
answers ``--version`` and ``--help`` at once, so neither may pay for torch when the
estimator or command does not use it. Each check runs in a fresh interpreter: this
process has long imported torch.

Likewise a generate worker imports no zarr (≈ 0.1–0.4 s of each worker's start-up):
it writes whole shard files itself (:mod:`synthcal.store.shards`).
"""

import json
import pickle
import subprocess
import sys

import numpy as np
import pytest

from synthcal.generate.pipeline import ShardTask
from synthcal.generate.splits import draw_splits
from synthcal.store import image_layouts, open_store


def fresh(code: str) -> dict:
    """Run ``code`` in a new interpreter; it prints one JSON object, returned here."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


TORCH = "sorted(m for m in sys.modules if m == 'torch' or m.startswith('torch.'))"
ZARR = "sorted(m for m in sys.modules if m == 'zarr' or m.startswith('zarr.'))"


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




def test_a_generate_worker_imports_no_zarr(smoke_config, smoke_stores, tmp_path):
    """A worker's preload (the pipeline module), then one shard rendered again: the store's own bytes, no zarr."""
    store = smoke_stores.copy(["intersection-1"], tmp_path)["intersection-1"]
    spec = smoke_config.resolve("intersection-1", "smoke")
    layouts = image_layouts(store)
    homographies = np.asarray(open_store(store)["homography"][:spec.shard_size])
    written = {name: layout.path(0).read_bytes() for name, layout in layouts.items() if layout.path(0).exists()}
    for name in written:
        layouts[name].path(0).unlink()
    (tmp_path / "progress").mkdir()
    task = ShardTask(spec, layouts, tmp_path / "progress", 0, 0, homographies)
    (tmp_path / "task.pickle").write_bytes(pickle.dumps(task))
    seen = fresh("import sys, json, pickle; import synthcal.generate.pipeline as pipeline; "
                 f"imported = {ZARR}; "
                 f"pipeline.run_shard(pickle.loads(open({str(tmp_path / 'task.pickle')!r}, 'rb').read())); "
                 f"print(json.dumps({{'imported': imported, 'ran': {ZARR}}}))")
    assert written and {name: layouts[name].path(0).read_bytes() for name in written} == written
    assert seen == {"imported": [], "ran": []}
