"""The instruction set torch's own CPU kernels use: what it costs one run, and what it changes in it.

PyTorch picks its vectorised CPU kernels by the instruction set it finds
(``torch.backends.cpu.get_cpu_capability()``: ``AVX512``, ``AVX2``, ``DEFAULT``); the
environment variable ``ATEN_CPU_CAPABILITY`` lowers it. A run records the capability in
its ``machine`` record (:func:`synthcal.utils.machine.machine_record`) and the runs table in
its ``cpu_capability`` column, because two machines that differ only there train the same
run to different last bits wherever a kernel of torch's own does the sums. Measured here on
the STN stage (:func:`synthcal.training.train_stn`, true maps, Top-MSE, one torch thread)
of both models, each capability in a process of its own:

* wall time per step at each capability ÷ at this machine's own, the baseline measured in
  the same run (best of ``--repeat`` calls in each process);
* whether the weights after the stage equal those at this machine's capability, and the
  largest difference.

The baseline STN (convolutions and linear layers: oneDNN and MKL, which choose their
kernels by the processor themselves, not by ``ATEN_CPU_CAPABILITY``) is the control; the
proposed STN adds :class:`synthcal.models.stn.SelfAttention2d`, whose
``scaled_dot_product_attention`` is one of torch's own kernels.

Run: .venv/bin/python benchmarks/run_capability.py [--size 128 72 --batch 32] [--repeat 3]
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

try:
    from timing import add_stn_stage_arguments, best_of, compared_weights
except ImportError:  # run as a module from the repository root
    from benchmarks.timing import add_stn_stage_arguments, best_of, compared_weights

LR = 1e-3
# From the richest to the plainest: a process can lower its capability, never raise it.
CAPABILITIES = ("AVX512", "AVX2", "DEFAULT")


def stage(size: tuple[int, int], batch: int, batches: int, epochs: int, repeat: int, out: Path) -> None:
    """In this process: train both STNs, save their weights under ``out``, print the capability and ms/step as JSON."""
    import torch

    from synthcal.models import BaselineSTN, ProposedSTN
    from synthcal.training import train_stn

    sys.path.insert(0, str(Path(__file__).parent))
    from training import training_data

    torch.set_num_threads(1)
    data = training_data(batch * batches, size)
    steps = batches * epochs
    report: dict[str, object] = {"capability": torch.backends.cpu.get_cpu_capability()}
    for name, cls in (("baseline", BaselineSTN), ("proposed", ProposedSTN)):
        torch.manual_seed(0)
        initial = cls(8, image_size=size)
        train_stn(copy.deepcopy(initial), data, None, "top-mse", 1, batch, LR, torch.device("cpu"))  # warm-up
        trained: list[torch.nn.Module] = []  # the last call's STN, whose weights are compared
        report[name] = best_of(repeat, lambda initial=initial, trained=trained: trained.append(train_stn(
            copy.deepcopy(initial), data, None, "top-mse", epochs, batch, LR, torch.device("cpu")))) / steps * 1e3
        torch.save(trained[-1].state_dict(), out / f"{name}.pt")
    print(json.dumps(report))


def measured(capability: str | None, args: argparse.Namespace, out: Path) -> dict[str, object]:
    """:func:`stage` in a fresh process at ``capability`` (None: the machine's own)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env.pop("ATEN_CPU_CAPABILITY", None)
    if capability is not None:
        env["ATEN_CPU_CAPABILITY"] = capability.lower()
    out.mkdir(parents=True, exist_ok=True)
    command = [sys.executable, __file__, "--stage", str(out), "--size", *map(str, args.size), "--batch",
               str(args.batch), "--batches", str(args.batches), "--epochs", str(args.epochs), "--repeat",
               str(args.repeat)]
    done = subprocess.run(command, env=env, check=True, capture_output=True, text=True)
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def compared(a: Path, b: Path) -> tuple[bool, float]:
    """:func:`compared_weights` of two saved state dicts."""
    import torch

    return compared_weights(torch.load(a), torch.load(b))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_stn_stage_arguments(parser)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--stage", type=Path, help=argparse.SUPPRESS)  # the child process's output folder
    args = parser.parse_args()
    if args.stage is not None:
        stage((args.size[0], args.size[1]), args.batch, args.batches, args.epochs, args.repeat, args.stage)
        return
    with tempfile.TemporaryDirectory() as tmp:
        own = measured(None, args, Path(tmp) / "own")
        lower = CAPABILITIES[CAPABILITIES.index(str(own["capability"])) + 1:] \
            if own["capability"] in CAPABILITIES else ()
        print(f"== STN stage, {args.size[0]}x{args.size[1]}, batch {args.batch}, "
              f"{args.batches * args.epochs} steps, L_Top-MSE, 1 torch thread, best of {args.repeat}; "
              f"this machine: {own['capability']}")
        if not lower:
            print("nothing to compare: no instruction set below this machine's in", ", ".join(CAPABILITIES))
        for capability in lower:
            other = measured(capability, args, Path(tmp) / capability)
            for name in ("baseline", "proposed"):
                same, largest = compared(Path(tmp) / "own" / f"{name}.pt", Path(tmp) / capability / f"{name}.pt")
                ratio = float(other[name]) / float(own[name])  # type: ignore[arg-type]
                print(f"{name:8s} {own['capability']} {own[name]:7.1f} ms/step | {other['capability']} "
                      f"{other[name]:7.1f} ms/step | ratio {ratio:5.3f} | same weights: {same} "
                      f"(largest difference {largest:.2e})")


if __name__ == "__main__":
    main()
