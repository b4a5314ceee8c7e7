"""A run's torch thread count: what more threads buy one run, and what they change in it.

``bench`` gives each run ``cores // workers`` torch threads (:func:`synthcal.eval.harness.run_threads`),
so a run's thread count follows ``--workers`` — and the thread count orders torch's sums,
so the same run trains to other weights (docs/benchmark.md). Whether a run should keep a
fixed thread count instead depends on what the extra threads buy. Measured here on the
STN stage (:func:`synthcal.training.train_stn`, true maps, Top-MSE) of both models:

* wall time per step at ``--threads`` (default: every usable core) ÷ at one thread, the
  baseline measured in the same run, the two taking turns (best of ``--repeat``);
* whether the two trainings end with the same weights (``same weights``), and the largest
  weight difference (running statistics included); and, as the control, whether every
  one-thread repeat ends with the same weights as the first.

Run on an otherwise idle machine (wall time: other jobs on the cores distort it):
    .venv/bin/python benchmarks/run_threads.py [--size 128 72 --batch 32] [--threads 2] [--repeat 3]
"""

from __future__ import annotations

import argparse
import copy
import time

import torch
from torch import nn

from synthcal.models import BaselineSTN, ProposedSTN
from synthcal.training import TrainingData, train_stn
from synthcal.utils.dispatch import usable_cores

try:
    from timing import add_stn_stage_arguments, compared_weights
    from training import training_data
except ImportError:  # run as a module from the repository root
    from benchmarks.timing import add_stn_stage_arguments, compared_weights
    from benchmarks.training import training_data

LR = 1e-3


def trained(initial: nn.Module, data: TrainingData, epochs: int, batch: int, threads: int) -> tuple[nn.Module, float]:
    """A copy of ``initial`` after the STN stage at ``threads`` torch threads, and its wall seconds."""
    torch.set_num_threads(threads)
    started = time.perf_counter()
    stn = train_stn(copy.deepcopy(initial), data, None, "top-mse", epochs, batch, LR, torch.device("cpu"))
    return stn, time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_stn_stage_arguments(parser)
    parser.add_argument("--threads", type=int, default=usable_cores())
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    size = (args.size[0], args.size[1])
    data = training_data(args.batch * args.batches, size)
    steps = args.batches * args.epochs
    print(f"== STN stage at {args.threads} torch threads vs 1: {size[0]}x{size[1]}, batch {args.batch}, "
          f"{steps} steps, L_Top-MSE, wall time, best of {args.repeat}")
    for name, cls in (("baseline", BaselineSTN), ("proposed", ProposedSTN)):
        torch.manual_seed(0)
        initial = cls(8, image_size=size)
        trained(initial, data, 1, args.batch, 1)  # warm-up: the first calls set up the kernels
        one, many, one_stns = [], [], []
        for _ in range(args.repeat):  # the two take turns, so that a burst of load hits both
            one_stn, seconds = trained(initial, data, args.epochs, args.batch, 1)
            one.append(seconds)
            one_stns.append(one_stn)
            many_stn, seconds = trained(initial, data, args.epochs, args.batch, args.threads)
            many.append(seconds)
        # The control: at one thread, every repeat trains to the same weights.
        repeatable = all(torch.equal(a, b) for stn in one_stns[1:] for a, b in zip(
            one_stns[0].state_dict().values(), stn.state_dict().values(), strict=True))
        same, largest = compared_weights(one_stn.state_dict(), many_stn.state_dict())
        print(f"{name:8s} 1 thread {min(one) / steps * 1e3:7.1f} ms/step | {args.threads} threads "
              f"{min(many) / steps * 1e3:7.1f} ms/step | ratio {min(many) / min(one):5.3f} | "
              f"same weights: {same} (largest difference {largest:.2e}); "
              f"1 thread, {args.repeat} repeats alike: {repeatable}")


if __name__ == "__main__":
    main()
