"""Training speed: synthcal's STN stage against a bare PyTorch loop, and training throughputs.

* STN step ÷ bare loop, for ``baseline`` and ``proposed``: the bare loop is the
  irreducible work of one step — STN forward, :func:`synthcal.models.compose_homography`,
  the bilinear warp of the anti-aliased scene (``scene_downsample`` 4 of a
  1,300 × 1,900 map), ``L_Top-MSE`` against the target view, backward, Adam —
  on pre-made tensors (each batch's 8-channel input, template homographies and
  target view, made before the clock starts), in the order synthcal visits them.
  synthcal's step is :func:`synthcal.training.train_stn` on the same split of
  ``batches × batch`` items over ``epochs`` epochs (true maps, ``segmentation:
  ground-truth``), the whole call timed and divided by its number of steps, so
  whatever it does once per fit is spread over the epochs as in a real run. Both
  start from the same weights and end with the same weights (printed: ``same
  weights``). Target ≤ 1.1.
* Training throughput (samples/s) of the UNet and the Siamese (bare steps: forward,
  loss, backward, Adam on pre-made tensors; the Siamese counts pairs) and of both
  STNs (synthcal's step, from the ratio measurement, and the bare loop's).

Timings are the best of ``--repeat`` calls (the machine is shared and noisy; the
STN's bare and synthcal calls take turns, after a warm-up, and are timed in CPU
time, the throughputs in wall time); set
``OMP_NUM_THREADS=1`` as well as ``--threads 1`` (the default) for stable ratios.

Run: OMP_NUM_THREADS=1 .venv/bin/python benchmarks/training.py [--repeat 3] [--size 256 144 --batch 8]
"""

from __future__ import annotations

import argparse
import copy
import time
from collections.abc import Callable

import numpy as np
import torch
from torch import Tensor, nn

from synthcal.generate.camera import homography
from synthcal.models import (
    BaselineSTN,
    ProposedSTN,
    SiameseNet,
    UNet,
    compose_homography,
    contrastive_loss,
    one_hot_maps,
    segmentation_loss,
    warp_loss,
    warp_semantic,
)
from synthcal.training import TrainingData, reduce_scene, train_stn

try:
    from timing import best_of
except ImportError:  # run as a module from the repository root
    from benchmarks.timing import best_of

LR = 1e-3
# CPU time of this process: with one thread, the time spent waiting for a core that other
# jobs hold does not count, which on the shared 2-core machine swung wall-clock ratios by ±30 %.
CLOCK = time.process_time
SCENE_DOWNSAMPLE = 4


def blocky_maps(n: int, size: tuple[int, int], generator: torch.Generator, block: int = 16) -> Tensor:
    """(n, h, w) uint8 class maps of ``block``-pixel squares (content does not change the cost)."""
    width, height = size
    coarse = torch.randint(0, 4, (n, -(-height // block), -(-width // block)), generator=generator,
                           dtype=torch.uint8)
    return coarse.repeat_interleave(block, 1).repeat_interleave(block, 2)[:, :height, :width].contiguous()


def cameras(n: int, size: tuple[int, int], seed: int) -> Tensor:
    """(n, 3, 3) float64 bird's-eye → image homographies of cameras above a 1,300 × 1,900 scene."""
    rng = np.random.default_rng(seed)
    centres = np.stack([rng.uniform(300, 1000, n), rng.uniform(300, 1600, n), rng.uniform(60, 100, n)], 1)
    return torch.from_numpy(homography(rng.uniform(-180, 180, n), rng.uniform(-35, -15, n),
                                       rng.uniform(150, 300, n) * size[0] / 256, centres, size))


def training_data(n: int, size: tuple[int, int], n_templates: int = 64) -> TrainingData:
    """A synthetic train split of ``n`` items and its dictionary at ``size`` (true maps, no images)."""
    g = torch.Generator().manual_seed(0)
    scene_ids = blocky_maps(1, (1300, 1900), g, block=20)[0].numpy()
    scene, frame = reduce_scene(scene_ids, SCENE_DOWNSAMPLE)
    return TrainingData(images=None, semantics=blocky_maps(n, size, g), homographies=cameras(n, size, 1),
                        match=torch.randint(0, n_templates, (n,), generator=g),
                        templates=blocky_maps(n_templates, size, g),
                        template_homographies=cameras(n_templates, size, 2), scene=scene, scene_frame=frame,
                        work_size=size)


def bare_stn_loop(initial: nn.Module, data: TrainingData, batch: int, epochs: int) -> Callable[[], nn.Module]:
    """Bare training of a copy of ``initial`` (module docstring); returns the trained copy.

    Its steps are made before the clock starts, in the order
    :func:`synthcal.training.train_stn` visits them (seed 0), so both follow the same
    trajectory: the cost of Adam's update depends on it (denormal moments).
    """
    scene, frame, size = data.scene, data.scene_frame, data.work_size
    generator = torch.Generator().manual_seed(0)
    steps = []
    for _ in range(epochs):
        for index in torch.randperm(len(data), generator=generator).split(batch):
            template = data.match[index]
            x = torch.cat([one_hot_maps(data.semantics[index]), one_hot_maps(data.templates[template])], dim=1)
            target = warp_semantic(scene, data.homographies[index] @ frame, size)
            steps.append((x, data.template_homographies[template], target))
    criterion = warp_loss("top_mse")

    def run() -> nn.Module:
        stn = copy.deepcopy(initial).train()
        optimiser = torch.optim.Adam(stn.parameters(), lr=LR)
        for x, template_H, target in steps:
            optimiser.zero_grad(set_to_none=True)
            H = compose_homography(stn(x), template_H, size)
            criterion(warp_semantic(scene, H @ frame, size), target).backward()
            optimiser.step()
        return stn

    return run


def bench_stn(size: tuple[int, int], batch: int, batches: int, epochs: int, repeat: int) -> dict[str, float]:
    """Prints each STN's step ÷ the bare loop; returns samples/s by name."""
    data = training_data(batch * batches, size)
    steps = batches * epochs
    print(f"\n== STN step vs bare loop: {size[0]}x{size[1]}, batch {batch}, {len(data)} items x {epochs} epochs "
          f"= {steps} steps, L_Top-MSE, scene 1300x1900 / {SCENE_DOWNSAMPLE}, best of {repeat}")
    rates: dict[str, float] = {}
    for name, cls in (("baseline", BaselineSTN), ("proposed", ProposedSTN)):
        torch.manual_seed(0)
        initial = cls(8, image_size=size)
        bare_loop = bare_stn_loop(initial, data, batch, epochs)

        def ours_loop(initial: nn.Module = initial) -> nn.Module:
            return train_stn(copy.deepcopy(initial), data, None, "top-mse", epochs, batch, LR, torch.device("cpu"))

        # Warm-up (the first calls of a network set up its kernels), and the check that
        # both loops did the same training.
        same = all(torch.equal(a, b) for a, b in zip(bare_loop().state_dict().values(),
                                                     ours_loop().state_dict().values(), strict=True))
        # Rounds alternate so that a burst of load on the shared machine hits both.
        rounds = [(best_of(1, bare_loop, CLOCK), best_of(1, ours_loop, CLOCK)) for _ in range(repeat)]
        bare, ours = (min(times) / steps for times in zip(*rounds, strict=True))
        rates[f"{name} STN (synthcal)"] = batch / ours
        rates[f"{name} STN (bare)"] = batch / bare
        print(f"{name:8s} bare {bare * 1e3:7.1f} ms/step | synthcal {ours * 1e3:7.1f} ms/step | "
              f"ratio {ours / bare:5.3f} | same weights: {same}")
    return rates


def bare_rate(module: nn.Module, loss: Callable[[], Tensor], samples: int, steps: int, repeat: int) -> float:
    """Samples/s of bare Adam steps on ``loss``, after one warm-up step."""
    optimiser = torch.optim.Adam(module.parameters(), lr=LR)

    def run() -> None:
        for _ in range(steps):
            optimiser.zero_grad(set_to_none=True)
            loss().backward()
            optimiser.step()

    optimiser.zero_grad(set_to_none=True)
    loss().backward()
    return samples * steps / best_of(repeat, run)


def bench_throughput(size: tuple[int, int], batch: int, steps: int, repeat: int, stn_rates: dict[str, float]) -> None:
    """Prints the training throughputs (module docstring)."""
    g = torch.Generator().manual_seed(2)
    width, height = size
    images = torch.rand(batch, 3, height, width, generator=g)
    ids = blocky_maps(batch, size, g).long()
    maps, partners = one_hot_maps(ids), one_hot_maps(blocky_maps(batch, size, g))
    same = (torch.arange(batch) % 2 == 0).float()
    unet, siamese = UNet(), SiameseNet()
    rates = {
        "UNet": bare_rate(unet, lambda: segmentation_loss(unet(images), ids), batch, steps, repeat),
        "Siamese (pairs)": bare_rate(siamese, lambda: contrastive_loss(
            *siamese(torch.cat([maps, partners])).chunk(2), same), batch, steps, repeat),
        **stn_rates,
    }
    print(f"\n== training throughput, {width}x{height}, batch {batch}, Adam, best of {repeat}")
    for name, rate in rates.items():
        print(f"{name:24s} {rate:7.1f} samples/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, nargs=2, default=(256, 144), metavar=("W", "H"))
    parser.add_argument("--batch", type=int, default=8)
    parser.add_argument("--batches", type=int, default=4, help="batches per epoch of the STN stage")
    parser.add_argument("--epochs", type=int, default=6, help="epochs of the STN stage")
    parser.add_argument("--steps", type=int, default=3, help="steps per throughput measurement (UNet, Siamese)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    size = (args.size[0], args.size[1])
    rates = bench_stn(size, args.batch, args.batches, args.epochs, args.repeat)
    bench_throughput(size, args.batch, args.steps, args.repeat, rates)


if __name__ == "__main__":
    main()
