"""Training the stages of the paper's models (SPEC §7) and caching the shared ones.

* :mod:`synthcal.training.resolution` — the networks' working resolution;
* :mod:`synthcal.training.cache` — trained stages on disk, built once;
* :mod:`synthcal.training.examples` — what the stages read: a split at the working
  resolution, its maps and the STN's examples;
* :mod:`synthcal.training.stages` — UNet, Siamese, STN and end-to-end training;
* :mod:`synthcal.training.validation` — a fitted STN's estimates of held-out items and their ``iou``.

Imports of synthcal only :mod:`synthcal.models`, :mod:`synthcal.data`, :mod:`synthcal.store`,
:mod:`synthcal.config` and :mod:`synthcal.utils` (tests/test_architecture.py).
"""

from synthcal.training.cache import StageCache, digest, held_out_cache_key, train_cache_key, unet_cache_key
from synthcal.training.examples import (
    ClassMapLogits,
    StnExamples,
    TrainingData,
    input_maps,
    reduce_scene,
    with_unet_maps,
)
from synthcal.training.resolution import (
    NUM_CLASSES,
    reduce_class_map_batches,
    reduce_class_maps,
    reduce_images,
    resolution_matrix,
)
from synthcal.training.stages import (
    MATCHING_SCORES,
    PAPER_END_TO_END_EPOCHS,
    WARP_LOSS_NAMES,
    best_epoch,
    composite_model,
    embed_templates,
    end_to_end_stage,
    estimate,
    inverse_frequency_weights,
    retrieve_templates,
    segmentation_class_iou,
    segmentation_validation_loss,
    stn_templates,
    train_end_to_end,
    train_siamese,
    train_stn,
    train_unet,
    validation_loss,
)
from synthcal.training.validation import (
    class_iou,
    held_out_estimates,
    orient_homographies,
    true_views,
    validation_iou,
)

__all__ = [
    "NUM_CLASSES",
    "PAPER_END_TO_END_EPOCHS",
    "WARP_LOSS_NAMES",
    "MATCHING_SCORES",
    "resolution_matrix",
    "reduce_class_map_batches",
    "reduce_class_maps",
    "reduce_images",
    "digest",
    "train_cache_key",
    "held_out_cache_key",
    "unet_cache_key",
    "StageCache",
    "TrainingData",
    "reduce_scene",
    "composite_model",
    "ClassMapLogits",
    "input_maps",
    "inverse_frequency_weights",
    "with_unet_maps",
    "embed_templates",
    "retrieve_templates",
    "stn_templates",
    "train_unet",
    "train_siamese",
    "train_stn",
    "StnExamples",
    "validation_loss",
    "validation_iou",
    "true_views",
    "held_out_estimates",
    "orient_homographies",
    "class_iou",
    "segmentation_validation_loss",
    "segmentation_class_iou",
    "best_epoch",
    "end_to_end_stage",
    "train_end_to_end",
    "estimate",
]
