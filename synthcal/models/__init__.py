"""The paper's Section 3 as PyTorch modules on tensors (SPEC §7).

* :mod:`.unet` — RGB → 4-class logits (:class:`UNet`), cross-entropy.
* :mod:`.siamese` — semantic-map embeddings (:class:`SiameseNet`), contrastive loss,
  chunked nearest-neighbour search over a dictionary.
* :mod:`.matching` — ground-truth matches (lowest MSE / ``L_Top-MSE``) by GEMM.
* :mod:`.stn` — baseline (paper and CCBV) and proposed STNs, :func:`compose_homography`.
* :mod:`.warp` — cheirality-masked warping (nearest: exactly the renderer;
  bilinear: differentiable).
* :mod:`.losses` — MSE, Dice, ``L_Top-MSE``, ``L_Top-Dice`` (MSE's reduction over
  classes: ``class_reduction``, :data:`CLASS_REDUCTIONS`).
* :mod:`.composite` — UNet → Siamese → STN → warp and the end-to-end objective.

Convention: homographies map bird's-eye pixels to image pixels,
``x_img ~ H (u, v, 1)ᵀ`` (SPEC §2); maps are (B, C, H, W) one-hot/soft or (B, H, W)
class ids. All code is device-agnostic (it follows its inputs' ``.device``).
"""

from .composite import STN_TEMPLATES, CompositeModel, CompositeOutput, end_to_end_weights
from .device import device_from_name
from .losses import (
    CLASS_REDUCTION,
    CLASS_REDUCTIONS,
    dice_loss,
    mse_loss,
    one_hot_maps,
    top_dice_loss,
    top_mse_loss,
    topological_combination,
    warp_loss,
)
from .matching import MatchResult, match_ground_truth, merge_matches, pairwise_scores
from .siamese import SiameseNet, contrastive_loss, nearest_embeddings
from .stn import (
    BaselineSTN,
    CcbvBlock,
    CcbvSTN,
    LocBlock,
    ProposedSTN,
    SelfAttention2d,
    ccbv_hidden,
    compose_homography,
    h_bar_matrix,
)
from .unet import UNet, segmentation_loss
from .warp import cheirality_mask, ground_coordinates, warp_semantic

__all__ = [
    "CLASS_REDUCTION",
    "CLASS_REDUCTIONS",
    "STN_TEMPLATES",
    "BaselineSTN",
    "CcbvBlock",
    "CcbvSTN",
    "ccbv_hidden",
    "CompositeModel",
    "CompositeOutput",
    "LocBlock",
    "MatchResult",
    "ProposedSTN",
    "SelfAttention2d",
    "SiameseNet",
    "UNet",
    "cheirality_mask",
    "compose_homography",
    "contrastive_loss",
    "device_from_name",
    "dice_loss",
    "end_to_end_weights",
    "ground_coordinates",
    "h_bar_matrix",
    "match_ground_truth",
    "merge_matches",
    "mse_loss",
    "nearest_embeddings",
    "one_hot_maps",
    "pairwise_scores",
    "segmentation_loss",
    "top_dice_loss",
    "top_mse_loss",
    "topological_combination",
    "warp_loss",
    "warp_semantic",
]
