"""The evaluation harness: metrics (SPEC §8), estimators and their plug-in interface
(SPEC §9), and the paper's result tables.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).
"""

from synthcal.eval.estimators import (
    ECCEstimator,
    Estimator,
    EstimatorError,
    IdentityEstimator,
    Segmenter,
    SemanticEstimator,
    TemplateEstimator,
    known_estimators,
    load_estimator,
    resolve_estimator,
)
from synthcal.eval.metrics import check_homography, completeness, evaluate, iou, iou_part, iou_whole, summarize
from synthcal.eval.tables import LAYOUTS, aggregate, format_table, paper_results, table_frame

__all__ = [
    "Estimator",
    "SemanticEstimator",
    "Segmenter",
    "EstimatorError",
    "IdentityEstimator",
    "TemplateEstimator",
    "ECCEstimator",
    "known_estimators",
    "load_estimator",
    "resolve_estimator",
    "check_homography",
    "iou",
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
