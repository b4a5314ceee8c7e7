"""Paper-profile training time on one device: each stage's epoch at the published sizes, and whole runs extrapolated.

The paper trains on a GPU and reports no times. This fits the bundled models
(``proposed``, then ``baseline`` = sha2020) step-by-step with the UNet in the loop,
Top-MSE, one learning rate, on seed 0 of each store, for a few epochs per stage, and
times every epoch: an epoch ends when its mean loss enters the stage's log (each step's
``loss.item()`` has synchronised the device by then); an STN epoch includes its pass over
the validation split (patience on, never reached). From the epochs after the first
(which holds the warm-up: cuDNN's algorithm search, the STN's example building) it
extrapolates one run to the profile's epochs (paper: UNet 50, Siamese 50, STN 100).

Baseline, measured in the same run on the same device: the ``quick`` profile (the
2-core sweeps' sizes: 128 × 72, widths 8 / 16 / 16, 1,500 train images), so each figure
is also printed as a ratio paper ÷ quick.

The UNet and Siamese are trained once per store and seed and shared by both models (as
``bench`` shares them through its cache); with ``--select learning_rate=...`` every
rate retrains everything, so a sweep's time is (shared + both STNs + predictions) ×
rates × seeds.

Run (stores: ``synthcal generate intersection-1 intersection-2 --profile quick --splits``;
same 256 × 144 images and 3,000 / 500 / 1,000 / 500 splits as the paper profile's):
    python benchmarks/paper_profile.py --data DATA --datasets intersection-1 intersection-2 --device cuda
    python benchmarks/paper_profile.py --data DATA --datasets intersection-1 --profile demo --baseline smoke   # CPU dry run
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

import synthcal
from synthcal.config import Model
from synthcal.data import read_scene
from synthcal.estimators.paper import PaperEstimator

SHARED_STAGES = ("unet", "siamese")
MODELS: tuple[Model, ...] = ("proposed", "baseline")  # proposed first: it trains the stages baseline then reuses


class EpochClock(list[float]):
    """A stage's loss log that also notes when each epoch's loss arrived."""

    def __init__(self) -> None:
        super().__init__()
        self.started = time.perf_counter()
        self.ends: list[float] = []

    def append(self, value: float) -> None:
        super().append(value)
        self.ends.append(time.perf_counter())

    def durations(self) -> list[float]:
        """Seconds of each epoch, the first from the clock's creation (the stage's start)."""
        return list(np.diff([self.started, *self.ends]))


@dataclass
class Fit:
    """One model's timed fit and prediction."""

    seconds: float
    predict_seconds: float
    test_images: int
    epochs: dict[str, list[float]] = field(default_factory=dict)  # stage → seconds of each epoch


def timed_fit(model: Model, profile: str, epochs: int, store: Path, seed: int, device: str, cache: Path) -> Fit:
    """Fit ``model`` under ``profile``'s sizes for ``epochs`` per stage and predict the test split."""
    settings = synthcal.load_config().training(profile).settings()
    settings.update(unet_epochs=epochs, siamese_epochs=epochs, stn_epochs=epochs, patience=epochs, select=None)
    estimator = PaperEstimator(model=model, segmentation="unet", settings=settings, device=device,
                               cache_dir=cache, seed=seed)
    clocks: dict[str, EpochClock] = {}
    # Every stage's log comes from _log(stage), asked for as the stage starts: time them there.
    estimator._log = lambda stage: clocks.setdefault(stage, EpochClock())  # type: ignore[method-assign]
    splits = {name: synthcal.load_split(store, name, seed=seed) for name in ("train", "dictionary", "validation",
                                                                             "test")}
    started = time.perf_counter()
    estimator.fit(splits["train"], splits["dictionary"], read_scene(store), validation=splits["validation"])
    fitted = time.perf_counter() - started
    started = time.perf_counter()
    test_images = np.asarray(splits["test"].images)
    estimator.predict(test_images)
    predicted = time.perf_counter() - started
    timings: dict[str, list[float]] = {stage: clocks[stage].durations() for stage in SHARED_STAGES if stage in clocks}
    if "stn" in clocks:  # an STN epoch: its training, then its validation pass
        validation = clocks["stn-validation"]
        timings["stn"] = list(np.diff([clocks["stn"].started, *validation.ends]))
    return Fit(fitted, predicted, len(test_images), timings)


def stage_rates(fit: Fit) -> dict[str, tuple[float, float]]:
    """stage → (first epoch, mean later epoch) seconds."""
    return {stage: (times[0], float(np.mean(times[1:])) if len(times) > 1 else times[0])
            for stage, times in fit.epochs.items()}


def full_run(fit: Fit, profile: str) -> float:
    """The fit's seconds at ``profile``'s epochs: its fixed part, plus each stage's first and later epochs."""
    training = synthcal.load_config().training(profile)
    target = {"unet": training.unet_epochs, "siamese": training.siamese_epochs, "stn": training.stn_epochs}
    fixed = fit.seconds - sum(sum(times) for times in fit.epochs.values())
    return fixed + sum(first + (target[stage] - 1) * later for stage, (first, later) in stage_rates(fit).items())


def profile_store(store: Path, profile: str, epochs: int, seed: int, device: str) -> dict[str, Fit]:
    """Both models fitted under ``profile``, sharing one cache (the second reuses the UNet and Siamese)."""
    with tempfile.TemporaryDirectory() as cache:
        return {model: timed_fit(model, profile, epochs, store, seed, device, Path(cache))
                for model in MODELS}


def report(name: str, paper: dict[str, Fit], quick: dict[str, Fit], profiles: tuple[str, str]) -> list[str]:
    """Markdown lines: per stage the later-epoch seconds of both profiles and their ratio; whole runs."""
    lines = [f"\n### {name}\n", f"| stage | {profiles[1]} s/epoch | {profiles[0]} s/epoch | ratio | "
             f"{profiles[0]} first epoch s |", "|---|---:|---:|---:|---:|"]
    rows = [("unet", "proposed"), ("siamese", "proposed"), ("stn", "proposed"), ("stn", "baseline")]
    for stage, model in rows:
        first, later = stage_rates(paper[model])[stage]
        base = stage_rates(quick[model])[stage][1]
        label = stage if stage in SHARED_STAGES else f"stn ({model})"
        lines.append(f"| {label} | {base:.3f} | {later:.3f} | {later / base:.1f} | {first:.2f} |")
    for model in ("proposed", "baseline"):
        p, q = paper[model], quick[model]
        lines.append(f"| predict {p.test_images} test images ({model}) | {q.predict_seconds:.2f} | {p.predict_seconds:.2f} | "
                     f"{p.predict_seconds / q.predict_seconds:.1f} | |")
    seed_total = {prof: sum(full_run(fits[m], prof) + fits[m].predict_seconds for m in fits)
                  for prof, fits in zip(profiles, (paper, quick), strict=True)}
    lines.append(f"| one seed, both models, one rate, full epochs | {seed_total[profiles[1]]:.0f} s | "
                 f"{seed_total[profiles[0]]:.0f} s | {seed_total[profiles[0]] / seed_total[profiles[1]]:.1f} | |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="folder holding NAME.zarr stores with splits")
    parser.add_argument("--datasets", nargs="+", default=["intersection-1"])
    parser.add_argument("--profile", default="paper")
    parser.add_argument("--baseline", default="quick", help="profile measured beside it, the ratios' denominator")
    parser.add_argument("--epochs", type=int, default=3, help="epochs timed per stage (the first is warm-up)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="auto")
    args = parser.parse_args()
    if args.epochs < 2:
        parser.error("--epochs: at least 2 (the first epoch holds the warm-up)")
    device = "cuda" if args.device == "auto" and torch.cuda.is_available() else args.device
    name = torch.cuda.get_device_name() if device.startswith("cuda") else f"cpu, {torch.get_num_threads()} threads"
    print(f"device: {name}; torch {torch.__version__}; {args.epochs} epochs per stage timed; seed {args.seed}")
    for dataset in args.datasets:
        store = args.data / f"{dataset}.zarr"
        fits: dict[str, dict[str, Fit]] = {}
        for profile in (args.baseline, args.profile):
            started = time.perf_counter()
            fits[profile] = profile_store(store, profile, args.epochs, args.seed, device)
            print(f"{dataset} {profile}: {time.perf_counter() - started:.0f} s measured", flush=True)
        print("\n".join(report(dataset, fits[args.profile], fits[args.baseline], (args.profile, args.baseline))),
              flush=True)
    if device.startswith("cuda"):
        print(f"\npeak GPU memory: {torch.cuda.max_memory_allocated() / 2**30:.2f} GiB")


if __name__ == "__main__":
    main()
