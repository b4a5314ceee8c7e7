"""The option vocabularies of the bundled models and the benchmark, each spelled once (SPEC §7, §9).

Each vocabulary is a ``Literal`` alias (for signatures, checked by mypy and by
pydantic) and the tuple of its values in the paper's order (for argparse
``choices``, run-time checks and error messages). The values are plain strings:
they are what run records, run ids, cache keys and tables contain.

This module imports nothing of synthcal, so that the configuration, the training
code, the estimators, the harness and the command line can all use it.

>>> LOSSES
('top-mse', 'mse', 'top-dice', 'dice')
>>> MODEL_LABELS["baseline"]
'sha2020'
"""

from __future__ import annotations

from typing import Literal, get_args

__all__ = [
    "Model",
    "Training",
    "Loss",
    "Matching",
    "Segmentation",
    "MODELS",
    "MODEL_LABELS",
    "TRAININGS",
    "LOSSES",
    "MATCHINGS",
    "SEGMENTATIONS",
]

# The paper's STN (``proposed``) or Sha et al.'s localisation network (``baseline``).
Model = Literal["proposed", "baseline"]
# Three stages one after another, each with its own loss, or all at once (SPEC §7).
Training = Literal["step-by-step", "end-to-end"]
# ``L_warp``: plain or topological (patch-wise) MSE / Dice (SPEC §7).
Loss = Literal["top-mse", "mse", "top-dice", "dice"]
# The score that defines each train image's correct template.
Matching = Literal["top-mse", "mse"]
# A trained UNet, or the true class maps for every compared estimator.
Segmentation = Literal["unet", "ground-truth"]

MODELS: tuple[Model, ...] = get_args(Model)
TRAININGS: tuple[Training, ...] = get_args(Training)
LOSSES: tuple[Loss, ...] = get_args(Loss)
MATCHINGS: tuple[Matching, ...] = get_args(Matching)
SEGMENTATIONS: tuple[Segmentation, ...] = get_args(Segmentation)

# Model option → its label in run records and tables (the paper calls the baseline "sha2020").
MODEL_LABELS: dict[Model, str] = {"proposed": "proposed", "baseline": "sha2020"}
