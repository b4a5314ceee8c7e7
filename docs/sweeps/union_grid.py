"""Each model tuned on the union of two learning-rate grids, by validation alone (issue 27, fifth session).

Two results folders hold the same cell run with different ``--select learning_rate=`` grids
(the table refuses both in one folder). A fit at every rate of both grids has been scored on
the validation split (each run's ``selection.scores``), so the union grid's choice per seed is
the run whose chosen rate scored lowest: no test figure is looked at. Prints, per model, the
chosen rate per seed and the test mean ± std, then the paired t interval of proposed − sha2020.

Run: python docs/sweeps/union_grid.py RESULTS_A RESULTS_B --dataset intersection-2 --loss top-mse
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy import stats


def runs(folders: list[Path], dataset: str, loss: str, model: str) -> dict[int, list[dict]]:
    """seed → the finished step-by-step true-map runs of ``model`` on the cell, over every folder."""
    out: dict[int, list[dict]] = {}
    for folder in folders:
        for path in sorted((folder / "runs").glob(f"{dataset}_{model}_step-by-step_{loss}_top-mse_ground-truth_s*/run.json")):
            record = json.loads(path.read_text())
            if record["status"] == "ok" and record["run"]["dataset"] == dataset and not record["run"]["mixed"]:
                out.setdefault(record["run"]["seed"], []).append(record)
    return out


def chosen(records: list[dict]) -> dict:
    """The run whose chosen learning rate scored lowest on validation."""
    def best_score(record: dict) -> float:
        return min(record["selection"]["scores"]["learning_rate"])
    return min(records, key=best_score)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--dataset", default="intersection-2")
    parser.add_argument("--loss", default="top-mse")
    parser.add_argument("--metric", default="iou")
    args = parser.parse_args()
    values: dict[str, dict[int, float]] = {}
    for model in ("sha2020", "proposed"):
        per_seed = runs(args.folders, args.dataset, args.loss, model)
        picks = {seed: chosen(records) for seed, records in sorted(per_seed.items())}
        values[model] = {seed: 100 * r["summary"][args.metric] for seed, r in picks.items()}
        grid = sorted({rate for records in per_seed.values() for r in records
                       for rate in r["selection"]["grid"]["learning_rate"]})
        rates = ", ".join(f"{r['selection']['chosen']['learning_rate']:g}" for r in picks.values())
        v = np.array(list(values[model].values()))
        print(f"{model}: grid {grid}; chosen per seed {rates}; {args.metric} {v.mean():.2f} ± {v.std(ddof=1):.2f} "
              f"({len(v)} seeds)")
    seeds = sorted(set(values["sha2020"]) & set(values["proposed"]))
    d = np.array([values["proposed"][s] - values["sha2020"][s] for s in seeds])
    half = stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d))
    p = stats.ttest_1samp(d, 0.0).pvalue
    print(f"proposed − sha2020: {d.mean():+.2f} [{d.mean() - half:+.2f}, {d.mean() + half:+.2f}], p {p:.3g}, "
          f"{int((d > 0).sum())} of {len(d)} seeds above")


if __name__ == "__main__":
    main()
