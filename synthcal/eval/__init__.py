"""Evaluation: the metrics (SPEC §8: :mod:`.metrics`, the checks and the paper's IoU;
:mod:`.polygon`, the exact sports-field IoUs; :mod:`.reprojection`, pixel errors;
:mod:`.scoring`, a batch of images and its summary), the harness that runs estimators
over datasets and seeds (:mod:`.runs`: which runs a sweep has; :mod:`.isolation`: one
estimator in a process of its own; :mod:`.harness`: executing runs and sweeps,
reading the results), and its output (:mod:`.statistics`: paired differences and the
all-background floor; :mod:`.tables`: the paper's result tables; :mod:`.report`:
``synthcal table``'s text; :mod:`.archive`: a results folder's runs as one CSV, read back in
its place; :mod:`.plots`; :mod:`.segmentation`: the UNet's own
per-class IoU/Dice, ``synthcal segmentation``).

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).
"""

from synthcal.config import METRICS
from synthcal.eval.metrics import check_homography, iou, readings
from synthcal.eval.polygon import iou_part, iou_whole
from synthcal.eval.scoring import completeness, evaluate, summarize
from synthcal.eval.tables import LAYOUTS, aggregate, format_table, paper_results, table_frame

__all__ = [
    "METRICS",
    "check_homography",
    "iou",
    "readings",
    "iou_part",
    "iou_whole",
    "evaluate",
    "completeness",
    "summarize",
    "LAYOUTS",
    "aggregate",
    "table_frame",
    "format_table",
    "paper_results",
]
