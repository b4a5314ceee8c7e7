"""Evaluation: metrics (SPEC §8), the harness that runs estimators over datasets and
seeds (:mod:`.runs`: which runs a sweep has; :mod:`.isolation`: one estimator in a
process of its own; :mod:`.harness`: executing runs and sweeps, reading the results),
the paper's result tables and plots.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).
"""

from synthcal.eval.metrics import (
    METRICS,
    check_homography,
    completeness,
    evaluate,
    iou,
    iou_part,
    iou_whole,
    readings,
    summarize,
)
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
