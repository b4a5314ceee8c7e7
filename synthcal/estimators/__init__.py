"""Estimators: the plug-in interface (SPEC §9), its loader and the bundled estimators.

* :mod:`synthcal.estimators.protocol` — what an estimator is (``fit``, ``predict``);
* :mod:`synthcal.estimators.registry` — a name (an entry point) or ``package.module:Class`` → an instance;
* :mod:`synthcal.estimators.classic` — ``identity``, ``template``, ``ecc``;
* :mod:`synthcal.estimators.paper` — the paper's ``proposed`` and ``baseline`` (``sha2020``) models and
  ``sha2020-ccbv`` (Sha et al.'s STN as the public CCBV code builds it);
* :mod:`synthcal.estimators.diagnostic` — ``retrieved`` (the Siamese's template, no STN) and
  ``oracle-template`` (the template of lowest true matching score);
* :mod:`synthcal.estimators.options` — constructor options from the configuration and the command line;
* :mod:`synthcal.estimators.version` — what an estimator's code is, as a hash in a run's identity.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).
"""

from synthcal.estimators.classic import (
    ColourSegmenter,
    ECCEstimator,
    IdentityEstimator,
    TemplateEstimator,
    ecc_warp,
    match_templates,
    medoid_index,
    one_hot,
)
from synthcal.estimators.protocol import (
    Estimator,
    EstimatorError,
    SceneLike,
    Segmenter,
    SemanticEstimator,
    SplitLike,
)
from synthcal.estimators.registry import (
    ENTRY_POINT_GROUP,
    bundled_estimators,
    known_estimators,
    load_estimator,
    resolve_estimator,
)

__all__ = [
    "ENTRY_POINT_GROUP",
    "Estimator",
    "SemanticEstimator",
    "Segmenter",
    "SplitLike",
    "SceneLike",
    "EstimatorError",
    "ColourSegmenter",
    "IdentityEstimator",
    "TemplateEstimator",
    "ECCEstimator",
    "bundled_estimators",
    "known_estimators",
    "resolve_estimator",
    "load_estimator",
    "one_hot",
    "match_templates",
    "medoid_index",
    "ecc_warp",
]
