"""Hand-written run records (``RESULTS/runs/<id>/run.json``), for the tests of what reads a results folder."""

from __future__ import annotations

import json
from pathlib import Path


def write_run(results: Path, model: str, loss: str | None, seed: int, iou: float, lr: float | None,
               seconds: float, dataset: str = "intersection-1", unet_epochs: int | None = None,
               missed: list[int] | None = None, threads: int | None = None,
               scores: list[float] | None = None, training: str = "step-by-step", device: str | None = None,
              train: int | None = None, settings: dict | None = None, capability: str | None = None) -> None:
    """One finished run's record; ``lr`` None: a run that chose nothing (no ``selection``); ``threads``: the torch
    threads its ``machine`` record names (None: a record without one), ``capability`` its ``cpu_capability``; ``scores``: validation's score of each
    learning rate of the grid (None: none recorded); ``train``: the train split's samples used, with training
    settings capping them at 1,500 (None: a record with neither); ``settings``: more resolved training settings."""
    run_id = f"{dataset}_{model}_{loss}_s{seed}" + (f"_{training}" if training != "step-by-step" else "") + (
        f"_{device}" if device else "")
    folder = results / "runs" / run_id
    folder.mkdir(parents=True)
    run = {"dataset": dataset, "model": model, "estimator": model, "seed": seed, "training": training,
           "loss": loss, "matching": "top-mse", "segmentation": "ground-truth", "profile": "quick",
           **({"device": device} if device else {}),
           **({"settings": {**({"max_train": 1500} if train is not None else {}), **(settings or {})}}
              if train is not None or settings else {})}
    record = {"run": run, "id": run_id, "status": "ok", "seconds": seconds,
              **({"sizes": {"train": train, "test": 8, "dictionary": 16}} if train is not None else {}),
              "summary": {"iou": iou, "completeness": 1.0, "n_images": 8},
              "selection": {"chosen": {"learning_rate": lr, "stn_epochs": 10 + seed,
                                       **({"unet_epochs": unet_epochs} if unet_epochs else {})},
                            **({"scores": {"learning_rate": scores}} if scores else {})} if lr else None,
              **({"history": {"unet-missed-classes": missed}} if missed is not None else {}),
              **({"machine": {**({"torch_threads": threads} if threads is not None else {}),
                              **({"cpu_capability": capability} if capability else {})}}
                 if threads is not None or capability else {})}
    (folder / "run.json").write_text(json.dumps(record))
