"""The frozen UNet's maps made once per fit, against each reader making its own.

With the UNet in the loop (``segmentation: unet``), four readers need the frozen UNet's
maps of the same items after its stage: the Siamese (every epoch), the retrieval of the
STN's templates, the STN's inputs, and the validation scores. synthcal makes them once
per learning rate (:func:`synthcal.training.with_unet_maps`; the validation split's once
too). Baseline, measured in the same run: the same fit with the estimator keeping none,
so each reader makes its own (the Siamese once per fit, as :func:`train_siamese` does on
its own; the retrieval and the STN's examples once each; the validation examples twice,
for the per-epoch scores and the rate's score) — the code before this change.

Printed per way: the items the frozen UNet segments in one fit (counted) and the fit's
wall time, best of ``--repeat``, the two ways taking turns; and the ratio. The stages
run for ``--epochs`` each (the saving is a fixed amount of work per fit: a full quick
profile's fit has more epochs around it, so its ratio is smaller; the seconds saved are
the same).

Run (a store with a validation split, e.g. ``synthcal generate intersection-1 --profile quick --splits``):
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/unet_maps.py --store DATA/intersection-1.zarr [--items 600]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch

import synthcal
import synthcal.estimators.paper as paper
from synthcal.data import read_scene
from synthcal.models import UNet
from synthcal.training import TrainingData


@contextmanager
def counted_unet(items: list[int]) -> Iterator[None]:
    """Count the items the UNet segments in eval mode (frozen) while the block runs."""
    forward = UNet.forward

    def counting(self: UNet, x: torch.Tensor) -> torch.Tensor:
        if not self.training:
            items.append(len(x))
        return forward(self, x)

    UNet.forward = counting  # type: ignore[method-assign]
    try:
        yield
    finally:
        UNet.forward = forward  # type: ignore[method-assign]


@contextmanager
def maps_per_reader() -> Iterator[None]:
    """The baseline: the estimator keeps no maps, and builds the validation examples per call."""
    keep, examples = paper.with_unet_maps, paper.PaperEstimator._validation_examples

    def without(data: TrainingData, unet: Any, device: Any, chunk: int = 256) -> TrainingData:
        return dataclasses.replace(data, unet_maps=None)

    def afresh(self: paper.PaperEstimator, *args: Any) -> Any:
        self._validation = None
        return examples(self, *args)

    paper.with_unet_maps = without  # type: ignore[assignment]
    paper.PaperEstimator._validation_examples = afresh  # type: ignore[method-assign]
    try:
        yield
    finally:
        paper.with_unet_maps = keep
        paper.PaperEstimator._validation_examples = examples  # type: ignore[method-assign]


def timed_fit(store: Path, items: int, epochs: int) -> tuple[float, int]:
    """(seconds, frozen items) of one step-by-step fit of ``proposed`` with the UNet, quick sizes."""
    settings = synthcal.load_config().training("quick").settings()
    settings.update(unet_epochs=epochs, siamese_epochs=epochs, stn_epochs=epochs, patience=epochs, select=None,
                    max_train=items)
    splits = {name: synthcal.load_split(store, name, seed=0) for name in ("train", "dictionary", "validation")}
    estimator = paper.PaperEstimator(model="proposed", segmentation="unet", settings=settings, device="cpu")
    frozen: list[int] = []
    with counted_unet(frozen):
        started = time.perf_counter()
        estimator.fit(splits["train"], splits["dictionary"], read_scene(store), validation=splits["validation"])
        seconds = time.perf_counter() - started
    return seconds, sum(frozen)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--store", type=Path, required=True)
    parser.add_argument("--items", type=int, default=600, help="train items (max_train)")
    parser.add_argument("--epochs", type=int, default=1, help="epochs of each stage")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    results: dict[str, list[tuple[float, int]]] = {"per reader (baseline)": [], "once per fit": []}
    for _ in range(args.repeat):
        with maps_per_reader():
            results["per reader (baseline)"].append(timed_fit(args.store, args.items, args.epochs))
        results["once per fit"].append(timed_fit(args.store, args.items, args.epochs))
    validation = len(synthcal.load_split(args.store, "validation", seed=0))
    print(f"{args.store.name}: {args.items} train items, {validation} validation, {args.epochs} epoch(s) per stage")
    print("| maps of the frozen UNet | items segmented per fit | fit s (best) | ratio |")
    print("|---|---:|---:|---:|")
    base = min(s for s, _ in results["per reader (baseline)"])
    for way, runs in results.items():
        best = min(s for s, _ in runs)
        print(f"| {way} | {runs[0][1]:,} | {best:.1f} | {best / base:.2f} |")


if __name__ == "__main__":
    main()
