"""Does a longer UNet schedule learn the bicycle path? Per-epoch validation scores of the quick profile's UNet.

At the quick profile's 10 epochs the UNet never predicts the bicycle path on three
seeds of five (docs/reproduction.md, "The UNet in the loop"). This trains the same
UNet (quick sizes: 1,500 train images at 128 × 72, width 8, batch 32) for more
epochs on one seed's train split and scores it after every epoch on the seed's
validation split: cross-entropy (what ``patience`` would read) and per-class IoU
(:mod:`synthcal.eval.segmentation`; the plain CE is what
:func:`synthcal.training.stages.segmentation_validation_loss` computes). Nothing is selected here: every epoch is
printed, so the curve shows where the class appears, if it does.

``--weighted``: one reading to measure beside the paper's plain cross-entropy — each
class weighted by its inverse pixel frequency in the train maps (normalised to mean 1),
so the bicycle path's ~3 % of pixels weigh as much as the background's ~68 %
(:func:`~synthcal.training.stages.inverse_frequency_weights`, what
``training.unet_class_weights: inverse-frequency`` uses); the validation CE printed
stays the plain one.

Run (a store of the sweep, e.g. /work/sweep27/data):
    OMP_NUM_THREADS=1 python docs/sweeps/unet_schedule.py --store DATA/intersection-1.zarr --seed 0 --epochs 30
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

import synthcal
from synthcal.eval.segmentation import class_scores, confusion_matrix
from synthcal.models import UNet
from synthcal.training import TrainingData, reduce_class_maps, reduce_images
from synthcal.training.stages import inverse_frequency_weights, train_unet

CLASSES = ("background", "road", "terrain", "bicycle path")


def images_and_maps(store: Path, split: str, seed: int, work_size: tuple[int, int], limit: int | None) -> TrainingData:
    """A split's images and class maps at the working resolution; the fields a UNet does not read are empty."""
    data = synthcal.load_split(store, split, seed=seed)
    semantics = np.asarray(data.semantics)[:limit]
    empty = torch.zeros(0, 3, 3, dtype=torch.float64)
    return TrainingData(images=reduce_images(np.asarray(data.images)[: len(semantics)], work_size),
                        semantics=reduce_class_maps(semantics, work_size), homographies=empty,
                        match=torch.zeros(0, dtype=torch.long), templates=torch.zeros(0, 1, 1, dtype=torch.uint8),
                        template_homographies=empty, scene=torch.zeros(4, 1, 1), scene_frame=torch.eye(3),
                        work_size=work_size)


def validation_scores(unet: torch.nn.Module, held_out: TrainingData) -> tuple[float, np.ndarray]:
    """The paper's plain cross-entropy on the held-out items, and each class's (4,) IoU (argmax), in eval mode."""
    was_training = unet.training
    unet.eval()
    with torch.no_grad():
        logits = torch.cat([unet(held_out.images[index].float() / 255.0)
                            for index in torch.arange(len(held_out)).split(256)])
    unet.train(was_training)
    iou, _ = class_scores(confusion_matrix(held_out.semantics.numpy(), logits.argmax(1).numpy()))
    return F.cross_entropy(logits, held_out.semantics.long()).item(), iou


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--store", type=Path, required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--epochs", type=int, default=30)
    parser.add_argument("--learning-rate", type=float, default=1e-3)
    parser.add_argument("--weighted", action="store_true", help="inverse-frequency class weights (module docstring)")
    args = parser.parse_args()
    settings = synthcal.load_config().training("quick")
    work_size = tuple(settings.work_size)
    train = images_and_maps(args.store, "train", args.seed, work_size, settings.max_train)
    held_out = images_and_maps(args.store, "validation", args.seed, work_size, None)
    weights = None
    if args.weighted:
        weights = inverse_frequency_weights(train.semantics, num_classes=len(CLASSES))
        print("class weights: " + ", ".join(f"{name} {w:.3f}" for name, w in zip(CLASSES, weights, strict=True)))
    torch.manual_seed(args.seed)
    unet = UNet(num_classes=len(CLASSES), width=settings.unet_width, depth=settings.unet_depth)
    print(f"{args.store.name} seed {args.seed}: {len(train)} train, {len(held_out)} validation, lr {args.learning_rate}")
    print("| epoch | train loss | validation CE | " + " | ".join(CLASSES) + " | mean of 1–3 | s |")
    print("|---:|---:|---:|" + "---:|" * len(CLASSES) + "---:|---:|")
    log: list[float] = []
    started = [time.perf_counter()]

    def scored(model: torch.nn.Module) -> float:
        loss, iou = validation_scores(model, held_out)
        iou *= 100
        seconds = time.perf_counter() - started[0]
        started[0] = time.perf_counter()
        print(f"| {len(log)} | {log[-1]:.4f} | {loss:.4f} | " + " | ".join(f"{v:.2f}" for v in iou)
              + f" | {np.nanmean(iou[1:]):.2f} | {seconds:.0f} |", flush=True)
        return loss

    train_unet(unet, train, args.epochs, settings.batch_size, args.learning_rate, torch.device("cpu"),
               seed=args.seed, log=log, validate=scored, class_weights=weights)


if __name__ == "__main__":
    main()
