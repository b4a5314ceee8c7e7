"""Diagnostic estimators: what retrieval alone gives, and the best any retrieval could give.

Convention: every homography maps a bird's-eye pixel to an image pixel,
``x_img ~ H (u, v, 1)ᵀ``, third coordinate = depth (SPEC §2).

``retrieved`` (:class:`RetrievedEstimator`)
    The bundled pipeline without its STN: the dictionary template the trained
    Siamese retrieves, its homography returned as is. The UNet and Siamese are
    the step-by-step stages of :class:`synthcal.estimators.paper.PaperEstimator`,
    through the same stage cache and keys, so a ``retrieved`` run beside a
    ``proposed`` or ``sha2020`` run with the same settings trains no stage of its
    own. ``model − retrieved`` is what the STN adds.
``oracle-template`` (:class:`OracleTemplateEstimator`)
    The dictionary template of lowest matching score against the test image's
    *true* class map — the template the Siamese is trained to retrieve (its
    positives are defined by the same score, :func:`synthcal.models.match_ground_truth`),
    so the best any retrieval could do; ``oracle-template − retrieved`` is what
    retrieval loses.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from synthcal.config import MATCHINGS, Matching, TrainingSettings
from synthcal.estimators.paper import (
    PaperEstimator,
    checked_choice,
    fixed_options,
    row_batches,
    streamed_match,
)
from synthcal.estimators.protocol import SceneLike, SplitLike
from synthcal.models import device_from_name, nearest_embeddings
from synthcal.training import MATCHING_SCORES, TrainingData

__all__ = ["RetrievedEstimator", "OracleTemplateEstimator"]


@fixed_options("model", "training", "loss")
class RetrievedEstimator(PaperEstimator):
    """The Siamese's retrieved template's homography, no STN (bundled name ``retrieved``).

    Takes :class:`PaperEstimator`'s options but ``model``, ``training`` and ``loss``:
    the stages are always step-by-step (an end-to-end Siamese is trained jointly
    with an STN and shares nothing), and with no STN there is neither a model nor
    an ``L_warp``. ``settings`` fields of the STN (``stn_*``, ``batch_norm``) are
    unused; the ones of the UNet and Siamese key the shared stages. Estimates are
    the dictionary's own full-resolution homographies, bit for bit.
    """

    label = "retrieved"

    def __init__(self, **options: Any) -> None:
        super().__init__(training="step-by-step", **options)  # ``model`` stays the default: no STN is built
        self.label = "retrieved"

    @classmethod
    def variant_label(cls, settings: TrainingSettings | Mapping[str, Any] | None) -> str:
        return cls.label  # no STN: nothing of the settings varies the model

    def _refiner(self, data: TrainingData, unet: torch.nn.Module | None, siamese: Any, embedding: torch.Tensor,
                 common: Any) -> None:
        return None

    def _from_maps(self, maps: torch.Tensor) -> np.ndarray:
        """(B, 4, h, w) input maps on the device → (B, 3, 3) homographies of the retrieved templates."""
        f = self._check_fitted()
        with torch.no_grad():
            match = nearest_embeddings(f["siamese"](maps), f["embedding"]).index.cpu().numpy()
        return f["dictionary_homographies"][match].copy()


class OracleTemplateEstimator:
    """The dictionary template of lowest true matching score (bundled name ``oracle-template``).

    A diagnostic that, by definition, reads test truth: the test images' true
    class maps. It reads them only the honest way the harness already offers,
    ``predict_semantic``, which the harness calls with the true maps under
    ``segmentation: ground-truth`` (the same maps every compared estimator then
    reads). It has no segmenter: :meth:`predict` (pixels) raises, so a run under
    ``segmentation: unet`` fails with that reason rather than pretending.
    Nothing is learned; ``fit`` keeps the dictionary.

    The score is the ``matching`` option (``top-mse``, the default, or ``mse``)
    with ``settings.class_reduction``, at the stores' full resolution — the score
    and resolution that define the Siamese's correct templates in training
    (:meth:`PaperEstimator._data`), so this is exactly the template a perfect
    Siamese would retrieve. Ties: the lowest dictionary index.

    Args:
        matching: ``top-mse`` or ``mse``.
        settings: training settings (only ``class_reduction`` is read).
        device: where the scores are computed (``auto``: CUDA when available).
    """

    label = "oracle-template"

    def __init__(self, matching: Matching = "top-mse", settings: TrainingSettings | dict[str, Any] | None = None,
                 device: str = "auto") -> None:
        self.matching: Matching = checked_choice("matching", matching, MATCHINGS)
        if isinstance(settings, TrainingSettings):
            settings = settings.model_dump()
        self.settings = TrainingSettings(**(settings or {}))
        self.device = device_from_name(device)
        self.templates: Any = None
        self.homographies: np.ndarray | None = None

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> None:
        """Keep the dictionary's class maps (as given: a lazy one stays lazy) and homographies."""
        self.templates = dictionary.semantics
        self.homographies = np.asarray(dictionary.homographies, np.float64)

    def predict(self, images: np.ndarray) -> np.ndarray:
        raise RuntimeError("oracle-template reads the test images' true class maps: run it with "
                           "segmentation ground-truth (predict_semantic), not on pixels")

    def predict_semantic(self, semantics: np.ndarray) -> np.ndarray:
        """(B, H, W) uint8 true class maps → (B, 3, 3) float64 homographies of their best templates."""
        if self.homographies is None:
            raise RuntimeError("OracleTemplateEstimator: call fit() first")
        score, reduction = MATCHING_SCORES[self.matching], self.settings.class_reduction
        out = []
        for _, rows in row_batches(semantics, 256):
            # The dictionary is read a block at a time (a lazy pool dictionary is never whole at full size).
            index = streamed_match(torch.from_numpy(rows).to(self.device), self.templates, score, reduction,
                                    self.device)
            out.append(self.homographies[index.numpy()])
        return np.concatenate(out) if out else np.empty((0, 3, 3))
