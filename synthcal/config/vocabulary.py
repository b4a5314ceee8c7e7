"""The option vocabularies of the bundled models and the benchmark, spelled once.

``Literal`` aliases for signatures (checked by mypy and pydantic) and tuples of their
values in the paper's order (argparse ``choices``, run-time checks). The values are
plain strings: they are what run records, run ids, cache keys and tables contain.

The few facts of the generator that validation needs are recorded here as data:
the names of the built-in scenes (:data:`BUILTIN_SCENE_NAMES`) and the fixed
train/test sizes of each set of given poses (:data:`POSE_SET_SPLITS`).
``synthcal.generate`` checks that its scenes and pose files agree with them.

The names of the evaluation's metrics (:data:`METRICS`, :data:`READINGS`,
:data:`DESCRIPTIONS`, :data:`DEFAULT_READING`) live here too, so that the command
line's parser can offer them without importing :mod:`synthcal.eval.metrics` (which
pulls in OpenCV and pandas); that module defines what each one computes.

This module imports nothing but the standard library.
"""

from __future__ import annotations

import re
from typing import Literal, get_args

__all__ = [
    "Model",
    "Training",
    "Loss",
    "Matching",
    "Segmentation",
    "StnTemplate",
    "ClassReduction",
    "SelectionScore",
    "UnetClassWeights",
    "Dictionary",
    "Images",
    "MODELS",
    "MODEL_LABELS",
    "TRAININGS",
    "LOSSES",
    "MATCHINGS",
    "SEGMENTATIONS",
    "STN_TEMPLATES",
    "CLASS_REDUCTIONS",
    "SELECTION_SCORES",
    "DICTIONARIES",
    "GRID_AXES",
    "BUILTIN_LAYOUT_NAMES",
    "BUILTIN_SCENE_NAMES",
    "POSE_SET_SPLITS",
    "POSE_VALIDATION_FRACTION",
    "READINGS",
    "METRICS",
    "DESCRIPTIONS",
    "DEFAULT_READING",
    "PIXEL_METRICS",
    "FAILURE_SHARES",
    "ConfigError",
    "MAX_MESSAGE",
    "brief",
    "check_dataset_name",
]

# --- option vocabularies (SPEC §7, §9) ------------------------------------------------------------

# The paper's STN (``proposed``), Sha et al.'s localisation network as the paper describes it
# (``baseline``) or as the public CCBV re-implementation builds it (``ccbv``).
Model = Literal["proposed", "baseline", "ccbv"]
# Three stages one after another, each with its own loss, or all at once (SPEC §7).
Training = Literal["step-by-step", "end-to-end"]
# ``L_warp``: plain or topological (patch-wise) MSE / Dice (SPEC §7).
Loss = Literal["top-mse", "mse", "top-dice", "dice"]
# The score that defines each train image's correct template.
Matching = Literal["top-mse", "mse"]
# A trained UNet, or the true class maps for every compared estimator.
Segmentation = Literal["unet", "ground-truth"]
# The template the STN reads in training: the one the Siamese retrieves (as at test time) or the true best.
StnTemplate = Literal["retrieved", "ground-truth"]
# How MSE-based losses and matching scores reduce over the class channels (SPEC §7):
# ``sum``: the squared distance between per-pixel class vectors; ``mean``: that divided by C.
ClassReduction = Literal["sum", "mean"]
# What ranks the fits on the validation split (the STN's epochs, the learning rates): the run's own ``L_warp``
# of the estimates, or 1 − their ``iou`` (the tables' reading, at the working resolution).
SelectionScore = Literal["warp-loss", "iou"]
# A weighting of the UNet's cross-entropy over the classes (None in settings: the paper's plain one).
UnetClassWeights = Literal["inverse-frequency"]
# What ``synthcal bench`` searches: the seed's dictionary split, or every pool sample
# outside the seed's train, test and validation sets (README "The pool dictionary").
Dictionary = Literal["split", "pool"]
# Which RGB images a store holds: every sample's, or only those of drawn splits (synthcal.store.images).
Images = Literal["all", "splits"]

MODELS: tuple[Model, ...] = get_args(Model)
TRAININGS: tuple[Training, ...] = get_args(Training)
LOSSES: tuple[Loss, ...] = get_args(Loss)
MATCHINGS: tuple[Matching, ...] = get_args(Matching)
SEGMENTATIONS: tuple[Segmentation, ...] = get_args(Segmentation)
STN_TEMPLATES: tuple[StnTemplate, ...] = get_args(StnTemplate)
CLASS_REDUCTIONS: tuple[ClassReduction, ...] = get_args(ClassReduction)
SELECTION_SCORES: tuple[SelectionScore, ...] = get_args(SelectionScore)
DICTIONARIES: tuple[Dictionary, ...] = get_args(Dictionary)

# Model option → its label in run records and tables (the paper calls the baseline "sha2020").
MODEL_LABELS: dict[Model, str] = {"proposed": "proposed", "baseline": "sha2020", "ccbv": "sha2020-ccbv"}

GRID_AXES = ("pan_deg", "tilt_deg", "focal_px", "x", "y", "z")

# The built-in intersections painted from a layout (synthcal.scenes.intersection.LAYOUTS): the
# paper's five, then intersection-1's family (its topology, other cross-sections and textures).
BUILTIN_LAYOUT_NAMES: tuple[str, ...] = (
    "intersection-1", "intersection-2", "intersection-3", "intersection-4", "intersection-5",
    "intersection-1a", "intersection-1b", "intersection-1c", "intersection-1d",
)
# The built-in scenes a dataset's ``scene:`` may name besides the file's own
# ``scenes:``, in listing order; synthcal.scenes.BUILTIN_SCENES has exactly these keys.
# After soccer: intersection-1 turned about its centre, and blank (synthcal.scenes.variants).
BUILTIN_SCENE_NAMES: tuple[str, ...] = (
    *BUILTIN_LAYOUT_NAMES, "soccer",
    "intersection-1-turn15", "intersection-1-turn45", "intersection-1-turn90", "intersection-1-blank",
)

# Each set of given poses (``poses:``) → the sizes of its fixed train/test partition
# (worldcup2014: the 209 train_val + 186 test frames; synthcal.generate.worldcup
# checks its annotation files against these).
POSE_SET_SPLITS: dict[str, dict[str, int]] = {"worldcup2014": {"train": 209, "test": 186}}
# The share of a pose set's train part carved out as the validation set when the dataset
# entry sets no splits.validation (worldcup2014: round(0.2 · 209) = 42, leaving 167 to train).
POSE_VALIDATION_FRACTION = 0.2


class ConfigError(ValueError):
    """Invalid configuration; the message names the file, key and value."""


# The longest error message a configuration gets: one terminal line or two, never a wall of text.
MAX_MESSAGE = 300


def brief(text: str, limit: int = MAX_MESSAGE) -> str:
    """``text`` on one line and at most ``limit`` characters (cut with an ellipsis).

    >>> brief("a\\nb " + "c" * 20, 10)
    'a b ccccc…'
    """
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 1] + "…"


# A dataset name becomes a file name (``NAME.zarr``): a plain name, never a path.
_PLAIN_NAME = re.compile(r"[A-Za-z0-9._-]+")


def check_dataset_name(name: str, where: str = "") -> None:
    """Refuse a dataset name that is not a plain file name.

    Plain: letters, digits, ``-``, ``_`` and ``.``, not ``.`` or ``..`` — so
    ``NAME.zarr`` lies inside the output folder.

    >>> check_dataset_name("intersection-1")
    >>> check_dataset_name("../escaped", "datasets.yaml: ")
    Traceback (most recent call last):
    ...
    synthcal.config.vocabulary.ConfigError: datasets.yaml: datasets.../escaped: a dataset name is a plain name: letters, digits, '-', '_' and '.', not '.' or '..' (value '../escaped')

    Raises:
        ConfigError: naming ``where`` (e.g. the file), the key and the value.
    """
    if not isinstance(name, str) or not _PLAIN_NAME.fullmatch(name) or name in (".", ".."):
        raise ConfigError(f"{where}datasets.{name}: a dataset name is a plain name: letters, digits, '-', '_' "
                          f"and '.', not '.' or '..' (value {name!r})")



# --- metric names (SPEC §8; what each computes: synthcal.eval.metrics) -----------------------------

# The paper's IoU, three readings of it (synthcal.eval.metrics' docstring), then the sports-field metrics,
# then the homography literature's pixel errors (synthcal.eval.reprojection).
READINGS = ("iou", "iou_bg", "iou_weighted")
METRICS = (*READINGS, "iou_part", "iou_whole", "reproj_px", "acc@5", "acc@10", "acc@20", "corner_error")
# Metrics in pixels, lower is better, summarised per run by their median (an image may score inf);
# every other metric is a fraction in [0, 1], higher is better, summarised by its mean, shown in percent.
PIXEL_METRICS = ("reproj_px", "corner_error")
# A pixel metric → the summary key of its share of failed (inf) images.
FAILURE_SHARES = {name: f"{name}_failed" for name in PIXEL_METRICS}
# The reading tables, plots and bench summaries show unless told otherwise. Not iou_weighted,
# although it lands nearest the paper's figures: an estimate that sees only background scores
# its floor (~53 on intersection-1), which compresses every difference into the top half of
# the scale; iou counts the classes that matter (docs/benchmark.md, "Readings").
DEFAULT_READING = "iou"
DESCRIPTIONS = {
    "iou": "the paper's IoU read as the mean over classes 1-3 present in either view",
    "iou_bg": "the paper's IoU read as the mean over classes 0-3 (background included) present in either view",
    "iou_weighted": "the paper's IoU read as the Jaccard of classes 0-3 weighted by their share of the true view "
                    "(sklearn jaccard_score average='weighted', as the public re-implementation of Sha et al.)",
    "iou_part": "IoU of the ground seen, on the scene's field (the pitch for soccer)",
    "iou_whole": "IoU of the image against its round trip truth -> ground -> estimate",
    "reproj_px": "image-pixel distance between the estimated and true projections of the scene's 10-px ground "
                 "grid the true view sees, mean per image, median over images (inf: a point behind the camera)",
    "acc@5": "share of test images whose reproj_px is at most 5 px",
    "acc@10": "share of test images whose reproj_px is at most 10 px",
    "acc@20": "share of test images whose reproj_px is at most 20 px",
    "corner_error": "bird's-eye distance between the four image corners sent to the ground by the estimate and "
                    "the truth, mean per image, median over images whose corners all see the ground",
}
