"""The paper's models as estimators (SPEC §7, §9): UNet → Siamese → STN.

>>> import tempfile, synthcal
>>> from synthcal.estimators import load_estimator
>>> tmp = tempfile.TemporaryDirectory()
>>> store = synthcal.generate_store("intersection-1", tmp.name, profile="smoke")
>>> train, dictionary, test = (synthcal.load_split(store, split) for split in ("train", "dictionary", "test"))
>>> settings = synthcal.load_config().training("smoke").settings()   # tiny networks, an epoch each
>>> est = load_estimator("proposed", training="step-by-step", loss="top-mse", matching="top-mse",
...                      settings=settings, device="cpu")
>>> est.fit(train, dictionary, train.scene)
>>> est.predict(test.images).shape      # one bird's-eye → image homography per test image
(8, 3, 3)
>>> tmp.cleanup()

Options
-------
The option values are defined once, in :mod:`synthcal.config`.

``model``
    ``proposed`` (the paper's STN: LocBlocks, self-attention, three FC layers),
    ``baseline`` (Sha et al.'s plain localisation network, as the paper describes
    it) or ``ccbv`` (Sha et al.'s as the public CCBV re-implementation builds it:
    residual conv–BN–LeakyReLU blocks, FC 9216 → 4096 → 1024 → 8 at 256 × 144;
    :class:`synthcal.models.CcbvSTN`, which ignores ``stn_width``). Table label
    ``proposed`` / ``sha2020`` / ``sha2020-ccbv``
    (:data:`synthcal.config.MODEL_LABELS`), with ``+bn`` or ``+no-bn`` appended
    when ``settings.batch_norm`` departs from the STN's own default
    (:func:`model_label`), so that an ablation row never averages with the
    model's plain runs.
``training``
    ``step-by-step``: UNet (cross-entropy), then Siamese (contrastive loss, pairs
    from the ground-truth matching), then STN (``L_warp``), each with its own loss
    and the earlier stages frozen. ``end-to-end``: all three from scratch with
    ``η L_CE + τ L_con + γ L_warp`` and the warm-up of SPEC §7, its thresholds
    scaled to ``settings.end_to_end_epochs``
    (:func:`synthcal.training.end_to_end_stage`).
``loss``
    ``L_warp``: ``mse``, ``dice``, ``top-mse``, ``top-dice``.
``matching``
    score defining each train image's correct template: ``mse`` or ``top-mse``.
``segmentation``
    ``unet``: a UNet segments the images; :meth:`predict` takes RGB.
    ``ground-truth``: no UNet is trained; the Siamese and STN are trained on the
    true semantic maps of the train split, and at test time the harness passes the
    test images' true maps to :meth:`predict_semantic` (the protocol's optional
    method, :class:`synthcal.estimators.SemanticEstimator`). The
    segmentation is then perfect — and the same — for every compared estimator,
    which isolates matching and STN and makes CPU studies affordable.
    :meth:`predict` (pixels) raises in that mode: there is nothing to segment with.
``settings``
    a profile's :class:`synthcal.config.TrainingSettings` (sizes, epochs, working
    resolution, batch size, learning rate), as a dict or the model. Two of its
    fields are protocol choices: ``stn_template`` — the template the STN reads in
    training, ``retrieved`` (default: the Siamese's nearest, as at test time; in
    step-by-step the frozen trained Siamese's, computed once; end-to-end the current
    joint embedding's) or ``ground-truth`` (lowest matching score); and
    ``class_reduction`` — ``sum`` (default) or ``mean`` over the class channels in
    MSE, ``L_Top-MSE`` and the matching scores (SPEC §7, docs/decisions.md).
    ``batch_norm`` switches the STN's batch normalisation (None: the STN's default:
    on for ``proposed`` and ``ccbv``, off for ``baseline``).
``device``
    ``auto`` (CUDA when available), ``cpu``, ``cuda``…: the same code on both.
``cache_dir``
    where the shared stages are kept (the harness passes ``RESULTS/cache``): the
    UNet depends only on the train split and its settings, the Siamese also on
    the dictionary, the matching score and the UNet (or the true maps), so
    step-by-step runs that differ only in the STN or its loss train each of them
    once. Keys hash the arrays themselves and the bundled models' code
    (:func:`~synthcal.estimators.version.bundled_code_version`), so a changed split
    or an edited model is a new key; the
    ground-truth matches are keyed by the matching score and ``class_reduction``,
    the Siamese by the matches themselves; the dictionary's embedding by the
    trained Siamese is cached too (``embedding/``, once per dictionary and
    Siamese). The STN is never cached (every run trains its own), so
    ``stn_template`` keys nothing shared. A lazy dictionary (the pool dictionary,
    :mod:`synthcal.data.pool`) is streamed: reduced to the working resolution and
    matched 512 templates at a time, never held at full size.
    :attr:`trained_stages` lists what the last :meth:`fit` trained rather than
    loaded, :attr:`history` their per-epoch mean losses. End-to-end training
    shares nothing.

Validation and selection
------------------------
``fit``'s ``validation`` split (the harness passes it when the settings ask) is
all that ``settings.patience`` and ``settings.select`` read, never test. The
score is by default the **validation ``L_warp`` of the estimates**: each validation map
gets the template the trained Siamese retrieves (as a test image would), the
STN refines it, and the run's own loss compares the views
(:func:`synthcal.training.validation_loss`; docs/decisions.md says why);
``settings.selection_score: iou`` scores the same estimates by 1 − their mean ``iou``
at the working resolution instead (:func:`synthcal.training.validation_iou`).
``patience``: the step-by-step STN is scored after every epoch, the best epoch's
weights kept, training stopped after ``patience`` epochs without a better score;
with the UNet in the loop (step-by-step) the UNet too, by its validation
cross-entropy (:func:`synthcal.training.segmentation_validation_loss`).
``select: {learning_rate: [...]}``: the whole model is fitted at each rate and the
best-scoring fit kept; :attr:`selection` records ``{split, grid, scores, chosen,
score}``. A rate is one setting for every stage, so the cached UNet and Siamese
at a rate are shared by all the runs (models, losses) that try it — unless
``settings.unet_learning_rate`` fixes the step-by-step UNet's own: then every rate
tried, and every model, reads that one UNet, and a model's choice of rate no longer
picks its UNet too.
With the UNet in the loop, the validation maps also give the UNet's IoU per class
(``history["unet-class-iou"]``, :func:`synthcal.training.segmentation_class_iou`);
where the kept UNet all but misses a class (:data:`MISSED_CLASS_IOU`, on at least
:data:`MISSED_CLASS_SHARE` of the pixels) ``fit`` records it (``history["unet-missed-classes"]``,
the class ids; ``[]``: none) and warns (:class:`MissedClassWarning`):
a falling cross-entropy does not show it, and every later stage then works without
that class (docs/decisions.md, "The UNet's loss").
``seed``
    seeds weight initialisation and batch order.
"""

from __future__ import annotations

import dataclasses
import inspect
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from functools import partial
from pathlib import Path
from typing import Any, ClassVar, TypedDict, TypeVar, cast

import numpy as np
import torch
from torch import Tensor, nn

from synthcal.config import (
    LOSSES,
    MATCHINGS,
    MODEL_LABELS,
    MODELS,
    SEGMENTATIONS,
    TRAININGS,
    ClassReduction,
    Loss,
    Matching,
    Model,
    Segmentation,
    Training,
    TrainingSettings,
)
from synthcal.estimators.protocol import SceneLike, SplitLike
from synthcal.estimators.version import bundled_code_version
from synthcal.models import (
    BaselineSTN,
    CcbvSTN,
    ProposedSTN,
    SiameseNet,
    UNet,
    device_from_name,
    match_ground_truth,
    merge_matches,
    one_hot_maps,
    warp_loss,
)
from synthcal.training import (
    MATCHING_SCORES,
    NUM_CLASSES,
    WARP_LOSS_NAMES,
    ClassMapLogits,
    StageCache,
    StnExamples,
    TrainingData,
    best_epoch,
    composite_model,
    digest,
    embed_templates,
    estimate,
    held_out_cache_key,
    inverse_frequency_weights,
    reduce_class_map_batches,
    reduce_class_maps,
    reduce_images,
    reduce_scene,
    resolution_matrix,
    retrieve_templates,
    segmentation_class_iou,
    segmentation_validation_loss,
    stn_templates,
    train_cache_key,
    train_end_to_end,
    train_siamese,
    train_stn,
    train_unet,
    true_views,
    unet_cache_key,
    validation_iou,
    validation_loss,
    with_unet_maps,
)

__all__ = ["STN_CLASSES", "BATCH_NORM_DEFAULTS", "model_label", "PaperEstimator", "ProposedEstimator",
           "BaselineEstimator", "CcbvEstimator"]

# The STN of each ``model`` option.
STN_CLASSES: dict[Model, type[nn.Module]] = {"proposed": ProposedSTN, "baseline": BaselineSTN, "ccbv": CcbvSTN}
# Each STN's own batch-norm default, read from its signature (one place states it).
BATCH_NORM_DEFAULTS: dict[Model, bool] = {
    model: bool(inspect.signature(cls).parameters["batch_norm"].default) for model, cls in STN_CLASSES.items()}


def model_label(model: Model, batch_norm: bool | None = None) -> str:
    """Table label of a ``model`` run: :data:`MODEL_LABELS`, ``+bn`` / ``+no-bn`` when ``batch_norm``
    departs from the STN's default.

    >>> model_label("baseline"), model_label("baseline", True), model_label("proposed", False)
    ('sha2020', 'sha2020+bn', 'proposed+no-bn')
    """
    if batch_norm is None or batch_norm == BATCH_NORM_DEFAULTS[model]:
        return MODEL_LABELS[model]
    return MODEL_LABELS[model] + ("+bn" if batch_norm else "+no-bn")

# Batches of images scored per forward pass at test time.
_PREDICT_BATCH = 64

# A class the kept UNet "all but misses": at least this share of the validation pixels, and an IoU under this.
# The quick profile's plain-loss UNets that never learnt the bicycle path (2.9 % of the pixels) scored 0.00.
MISSED_CLASS_SHARE = 0.005
MISSED_CLASS_IOU = 0.10


class MissedClassWarning(UserWarning):
    """The kept UNet all but misses a class of the validation split (:meth:`PaperEstimator.fit`)."""

_Option = TypeVar("_Option", bound=str)
_Module = TypeVar("_Module", bound=nn.Module)
_Estimator = TypeVar("_Estimator", bound="PaperEstimator")


def checked_choice(name: str, value: str, allowed: Sequence[_Option]) -> _Option:
    """``value`` as one of ``allowed`` (a vocabulary of :mod:`synthcal.config`), or a ValueError naming it."""
    for option in allowed:
        if value == option:
            return option
    raise ValueError(f"{name} must be one of {', '.join(allowed)}; got {value!r}")


# Templates of a lazy (pool) dictionary read, reduced and matched per batch: bounds memory
# (a batch of 512 maps at 256 × 144 encodes to ~230 MB in the ground-truth matching).
_TEMPLATE_BATCH = 512


def row_batches(rows: Any, size: int) -> Iterator[tuple[int, np.ndarray]]:
    """``(start, rows[start:start + size])`` of any array-like with ``len`` and slicing (a lazy one reads them)."""
    for start in range(0, len(rows), size):
        yield start, np.asarray(rows[start:start + size])


def streamed_match(queries: Tensor, templates: Any, score: str, reduction: ClassReduction,
                    device: torch.device) -> Tensor:
    """(Q,) ground-truth template index of (Q, H, W) class-id ``queries`` among (T, H, W) ``templates``
    read in batches: the same as one :func:`match_ground_truth` over all (:func:`merge_matches`)."""
    best = None
    for start, rows in row_batches(templates, _TEMPLATE_BATCH):
        part = match_ground_truth(queries, torch.from_numpy(rows).to(device), score, class_reduction=reduction)
        best = merge_matches(best, part, start)
    if best is None:
        raise ValueError("the dictionary is empty: no template to match")
    return best.index.cpu()


class _Common(TypedDict):
    """Keywords every training function takes."""

    batch_size: int
    lr: float
    device: torch.device
    seed: int
    progress: bool


def _ranking(scores: Sequence[float], k: int) -> tuple[bool, float]:
    """Sort key of fit ``k``: a NaN score (a diverged fit) after every number, then lower first."""
    return bool(np.isnan(scores[k])), scores[k]


def _best(scores: Sequence[float]) -> int:
    """The fit kept: the lowest score, the first of equal ones."""
    return min(range(len(scores)), key=lambda k: _ranking(scores, k))


class PaperEstimator:
    """The paper's UNet → Siamese → STN pipeline behind the estimator interface.

    Args: see the module docstring.
    """

    label = "proposed"
    # The ``model`` a subclass fixes (the class-level label of its runs, :meth:`variant_label`).
    model_option: ClassVar[Model] = "proposed"

    def __init__(self, model: Model = "proposed", training: Training = "step-by-step", loss: Loss = "top-mse",
                 matching: Matching = "top-mse", segmentation: Segmentation = "unet",
                 settings: TrainingSettings | dict[str, Any] | None = None, device: str = "auto",
                 cache_dir: str | Path | None = None, seed: int = 0, progress: bool = False) -> None:
        # Checked at run time too: values come from the command line and configs.
        self.model: Model = checked_choice("model", model, MODELS)
        self.training: Training = checked_choice("training", training, TRAININGS)
        self.loss: Loss = checked_choice("loss", loss, LOSSES)
        self.matching: Matching = checked_choice("matching", matching, MATCHINGS)
        self.segmentation: Segmentation = checked_choice("segmentation", segmentation, SEGMENTATIONS)
        if isinstance(settings, TrainingSettings):
            settings = settings.model_dump()
        self.settings = TrainingSettings(**(settings or {}))
        self.device = device_from_name(device)
        self.cache = StageCache(cache_dir)
        self.seed = int(seed)
        self.progress = progress
        self.label = model_label(self.model, self.settings.batch_norm)
        self.trained_stages: list[str] = []
        self.history: dict[str, list[float] | list[int]] = {}
        # Cache keys of the kept fit's shared stages (``unet``, ``siamese``): the harness records them,
        # so a run's UNet is found again by the key it had (synthcal.segmentation_quality).
        self.stage_keys: dict[str, str] = {}
        self.selection: dict[str, Any] | None = None
        self._fitted: dict[str, Any] | None = None
        self._held_out: TrainingData | None = None
        self._scene_ids: Tensor | None = None
        # The validation items' true views, drawn once per fit: the same for every rate (:meth:`_scorer`).
        self._true_views: Tensor | None = None
        # The current learning rate's validation examples (:meth:`_validation_examples`).
        self._validation: tuple[StnExamples, Tensor] | None = None

    @classmethod
    def variant_label(cls, settings: TrainingSettings | Mapping[str, Any] | None) -> str:
        """The table label of this class's runs under ``settings`` (a run's, before any instance exists)."""
        batch_norm = settings.batch_norm if isinstance(settings, TrainingSettings) else (settings or {}).get(
            "batch_norm")
        return model_label(cls.model_option, batch_norm)

    # --- building blocks ------------------------------------------------------------------

    @property
    def uses_unet(self) -> bool:
        return self.segmentation == "unet"

    # Each network is initialised from the seed, whatever was built before it.

    def _unet(self) -> UNet:
        s = self.settings
        torch.manual_seed(self.seed)
        return UNet(num_classes=NUM_CLASSES, width=s.unet_width, depth=s.unet_depth)

    def _siamese(self) -> SiameseNet:
        torch.manual_seed(self.seed)
        return SiameseNet(NUM_CLASSES, embedding_dim=self.settings.embedding_dim, width=self.settings.siamese_width)

    def _stn(self, work_size: tuple[int, int]) -> nn.Module:
        options: dict[str, Any] = {} if self.model == "ccbv" else {"width": self.settings.stn_width}
        if self.settings.batch_norm is not None:
            options["batch_norm"] = self.settings.batch_norm
        torch.manual_seed(self.seed)
        return STN_CLASSES[self.model](2 * NUM_CLASSES, image_size=work_size, **options)

    def _data(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike) -> tuple[TrainingData, dict[str, str]]:
        """The train split and dictionary at the working resolution, the ground-truth
        matches, and the digests that key the cached stages."""
        semantics = np.asarray(train.semantics)[: self.settings.max_train]
        full_size = (semantics.shape[2], semantics.shape[1])
        work_size = tuple(self.settings.work_size or full_size)
        A = torch.from_numpy(resolution_matrix(full_size, work_size))
        images = np.asarray(train.images)[: len(semantics)] if self.uses_unet else None
        homographies = np.asarray(dictionary.homographies, np.float64)
        # The code is in every stage's key (they all derive from this one): edited models retrain.
        keys = {"train": train_cache_key(bundled_code_version(), semantics, images, full_size, work_size)}
        if isinstance(dictionary.semantics, np.ndarray):  # in memory (a split): as it always was
            full = np.asarray(dictionary.semantics)
            templates = reduce_class_maps(full, work_size)
            keys["dictionary"] = digest(full, homographies)
            match = self._match(semantics, keys, lambda queries, score, reduction: match_ground_truth(
                queries, torch.from_numpy(full).to(self.device), score, class_reduction=reduction).index.cpu())
        else:  # lazy (a pool dictionary): streamed, reduced batch by batch; never whole at full size
            templates = reduce_class_map_batches(row_batches(dictionary.semantics, _TEMPLATE_BATCH),
                                                 len(dictionary.semantics), work_size)
            keys["dictionary"] = digest("streamed", templates, homographies, full_size)
            match = self._match(semantics, keys, lambda queries, score, reduction: streamed_match(
                queries, dictionary.semantics, score, reduction, self.device))
        keys["match"] = digest(match)
        scene_map, scene_frame = reduce_scene(scene.semantic, self.settings.scene_downsample)
        data = TrainingData(
            images=None if images is None else reduce_images(images, work_size),
            semantics=reduce_class_maps(semantics, work_size),
            homographies=A @ torch.from_numpy(np.asarray(train.homographies, np.float64)[: len(semantics)]),
            match=match,
            templates=templates,
            template_homographies=A @ torch.from_numpy(homographies),
            scene=scene_map,
            scene_frame=scene_frame,
            work_size=work_size,
        )
        return data, keys

    def _match(self, semantics: np.ndarray, keys: dict[str, str],
               compute: Callable[[Tensor, str, ClassReduction], Tensor]) -> Tensor:
        """(K,) ground-truth template of each (K, H, W) train map, cached by the train and dictionary keys."""
        score, reduction = MATCHING_SCORES[self.matching], self.settings.class_reduction
        queries = torch.from_numpy(semantics).to(self.device)
        match, _ = self.cache.cached("match", digest(keys["train"], keys["dictionary"], score, reduction),
                                     lambda: compute(queries, score, reduction))
        return cast(Tensor, match)

    def _log(self, stage: str) -> list[float]:
        """The per-epoch mean losses of a stage trained by this fit (:attr:`history`); ``<stage>-validation``:
        its per-epoch validation scores, also for a stage loaded from the cache (:meth:`_stage`)."""
        return cast(list[float], self.history.setdefault(stage, []))

    def _stage(self, name: str, key: str, module: _Module,
               train: Callable[[_Module, list[float]], nn.Module]) -> _Module:
        """Load ``module``'s weights from the cache, or train it there and record it.

        A stage scored on validation (the UNet under ``patience``) keeps its scores beside
        its weights, saved first, so that a run loading it still knows the epoch kept."""
        scores = f"{name}-validation"

        def build() -> dict[str, Any]:
            state = train(module, self._log(name)).state_dict()
            if self.history.get(scores):
                self.cache.save(scores, key, torch.tensor(self.history[scores], dtype=torch.float64))
            return state

        state, trained = self.cache.cached(name, key, build)
        if trained:
            self.trained_stages.append(name)
        else:
            module.load_state_dict(state)
            kept = self.cache.load(scores, key)
            if kept is not None:
                self.history[scores] = kept.tolist()
        return module.to(self.device).eval()

    def _embedding(self, siamese_key: str, dictionary_key: str, siamese: SiameseNet, data: TrainingData) -> Tensor:
        """(T, D) the dictionary embedded by the trained Siamese, once per (dictionary, Siamese):
        cached beside the stages (a pool dictionary of ~46,500 templates is worth keeping)."""
        key = digest("embedding", siamese_key, dictionary_key, data.work_size)
        embedding, _ = self.cache.cached("embedding", key, lambda: embed_templates(siamese, data, self.device).cpu())
        return cast(Tensor, embedding)

    # --- fitting --------------------------------------------------------------------------

    def fit(self, train: SplitLike, dictionary: SplitLike, scene: SceneLike,
            validation: SplitLike | None = None) -> None:
        """Train the stages on ``train`` against ``dictionary`` over ``scene`` (SPEC §9).

        ``validation``: the held-out split ``settings.patience`` and ``settings.select``
        read (module docstring); required by them, unused otherwise.

        Raises:
            ValueError: ``patience`` or ``select`` without a validation split.
        """
        s = self.settings
        if (s.patience is not None or s.select is not None) and validation is None:
            asked = "patience" if s.select is None else "select"
            raise ValueError(f"settings.{asked}: needs a validation split, and none was given (draw one with "
                             f"`synthcal split STORE --validation N`)")
        if s.unet_learning_rate is not None and (self.training == "end-to-end" or not self.uses_unet):
            why = "trains every stage jointly at one rate" if self.uses_unet else "has no UNet (segmentation " \
                f"{self.segmentation!r})"
            raise ValueError(f"settings.unet_learning_rate {s.unet_learning_rate:g}: a step-by-step UNet's own rate, "
                             f"and this {self.training} run {why}")
        self.trained_stages, self.selection = [], None
        data, keys = self._data(train, dictionary, scene)
        self._held_out = None if validation is None else self._validation_data(validation, data)
        self._scene_ids = torch.from_numpy(np.asarray(scene.semantic))  # what validation_iou draws
        self._true_views = None
        if validation is not None and self.uses_unet:  # only the UNet's cache key reads it
            keys["held_out"] = held_out_cache_key(np.asarray(validation.semantics), np.asarray(validation.images))
        grid = (s.learning_rate,) if s.select is None else s.select.learning_rate
        scores: list[float] = []
        kept: tuple[dict[str, Any] | None, dict[str, list[float] | list[int]], dict[str, str]] = (None, {}, {})
        try:
            for rate in grid:
                self.settings, self.history, self.stage_keys = s.model_copy(update={"learning_rate": rate}), {}, {}
                self._fit_at(train, dictionary, data, keys)
                scores.append(float("nan") if s.select is None else self._validation_score())
                if _best(scores) == len(scores) - 1:
                    kept = (self._fitted, self.history, self.stage_keys)  # only the best fit so far is held
        finally:
            self.settings, self._validation = s, None  # the kept fit may be an earlier rate's
        self._fitted, self.history, self.stage_keys = kept
        self._warn_missed_classes(s.unet_learning_rate or (s.learning_rate if s.select is None
                                                            else grid[_best(scores)]))
        if s.select is not None:
            self.selection = {"split": "validation", "score": self._score_name(),
                              "grid": {"learning_rate": list(grid)}, "scores": {"learning_rate": scores},
                              "chosen": {"learning_rate": grid[_best(scores)], **self._chosen_epochs()}}

    def _warn_missed_classes(self, learning_rate: float) -> None:
        """Warn where the kept UNet all but misses a class that holds at least :data:`MISSED_CLASS_SHARE` of the
        validation pixels (IoU under :data:`MISSED_CLASS_IOU`): its maps then lack that class for every later
        stage, while its falling cross-entropy says nothing of it (docs/decisions.md, "The UNet's loss")."""
        iou = self.history.get("unet-class-iou")
        if iou is None or self._held_out is None:
            return
        counts = torch.bincount(self._held_out.semantics.flatten().long(), minlength=NUM_CLASSES)[:NUM_CLASSES]
        share = (counts / counts.sum().clamp(min=1)).tolist()
        classes = [k for k in range(NUM_CLASSES) if share[k] >= MISSED_CLASS_SHARE and iou[k] < MISSED_CLASS_IOU]
        self.history["unet-missed-classes"] = classes  # the run's record keeps it: the report flags the run
        missed = [f"class {k} (IoU {100 * iou[k]:.1f} %, {100 * share[k]:.1f} % of the pixels)" for k in classes]
        if missed:
            warnings.warn(f"the UNet (seed {self.seed}, learning rate {learning_rate:g}, at most "
                          f"{self.settings.unet_epochs} epochs) all but misses {', '.join(missed)} on the validation "
                          "split: try training.unet_class_weights: inverse-frequency or more unet_epochs "
                          "(docs/decisions.md, \"The UNet's loss\")", MissedClassWarning, stacklevel=3)

    def _chosen_epochs(self) -> dict[str, int]:
        """``unet_epochs`` / ``stn_epochs``: the kept UNet's and STN's best validation epochs (under ``patience``)."""
        return {f"{stage}_epochs": best_epoch(scores) + 1 for stage in ("unet", "stn")
                if (scores := self.history.get(f"{stage}-validation"))}

    def _validation_data(self, validation: SplitLike, data: TrainingData) -> TrainingData:
        """The validation split at the working resolution, beside the train split's dictionary and scene."""
        semantics = np.asarray(validation.semantics)
        A = torch.from_numpy(resolution_matrix((semantics.shape[2], semantics.shape[1]), data.work_size))
        images = reduce_images(np.asarray(validation.images), data.work_size) if self.uses_unet else None
        return dataclasses.replace(
            data, images=images, semantics=reduce_class_maps(semantics, data.work_size),
            homographies=A @ torch.from_numpy(np.asarray(validation.homographies, np.float64)),
            match=torch.zeros(len(semantics), dtype=torch.long), unet_maps=None)

    def _validation_examples(self, siamese: SiameseNet, unet: nn.Module | None,
                             embedding: Tensor) -> tuple[StnExamples, Tensor]:
        """Validation items with the templates the Siamese retrieves for them, and those templates' ``A H_k``.

        Made once per learning rate (the STN's per-epoch scores and the rate's final score
        read the same ones: the UNet and Siamese are frozen by then).
        """
        if self._validation is None:
            held_out = with_unet_maps(cast(TrainingData, self._held_out), unet, self.device)
            if unet is not None:  # read from the maps just made: no other pass of the UNet
                self.history["unet-class-iou"] = segmentation_class_iou(unet, held_out).tolist()
            retrieved = retrieve_templates(siamese, held_out, unet, self.device, dictionary=embedding)
            self._validation = (StnExamples(held_out, retrieved, unet, self.device),
                                held_out.template_homographies[retrieved].to(self.device))
        return self._validation

    def _score_name(self) -> str:
        """What :attr:`selection`'s scores are, in words."""
        if self.settings.selection_score == "iou":
            return "1 − iou of the estimates (working resolution)"
        return f"L_warp ({self.loss}) of the estimates"

    def _scorer(self, siamese: SiameseNet, unet: nn.Module | None,
                embedding: Tensor) -> Callable[[nn.Module | None], float]:
        """The validation score of an STN's estimates, lower better: ``settings.selection_score``'s
        (module docstring)."""
        examples, homographies = self._validation_examples(siamese, unet, embedding)
        if self.settings.selection_score == "iou":
            scene = cast(Tensor, self._scene_ids)
            if self._true_views is None:  # they depend on the held-out homographies only, not on the rate
                self._true_views = true_views(examples, scene)
            truth = self._true_views
            return lambda stn: 1.0 - validation_iou(stn, examples, homographies, scene, truth)
        criterion = warp_loss(WARP_LOSS_NAMES[self.loss], self.settings.class_reduction)
        return lambda stn: validation_loss(stn, examples, homographies, criterion)

    def _validation_score(self) -> float:
        """The fitted model's validation score of its estimates (:meth:`_scorer`)."""
        f = self._check_fitted()
        return self._scorer(f["siamese"], f["unet"], f["embedding"])(f["stn"])

    def _fit_at(self, train: SplitLike, dictionary: SplitLike, data: TrainingData, keys: dict[str, str]) -> None:
        """One fit under the current settings (one learning rate); sets :attr:`_fitted`."""
        s, device = self.settings, self.device
        self._validation = None
        common = _Common(batch_size=s.batch_size, lr=s.learning_rate, device=device, seed=self.seed,
                         progress=self.progress)
        unet: nn.Module | None
        embedding: Tensor | None = None
        stn: nn.Module | None
        if self.training == "end-to-end":
            unet = self._unet() if self.uses_unet else ClassMapLogits()
            siamese, stn = self._siamese(), self._stn(data.work_size)
            composite = composite_model(unet, siamese, stn, data, self.loss, s.class_reduction, s.stn_template,
                                        self._unet_class_weights(data))
            train_end_to_end(composite, data, self.uses_unet, s.end_to_end_epochs, log=self._log("end-to-end"),
                             **common)
            self.trained_stages.append("end-to-end")
        else:
            data, unet, siamese, embedding = self._shared_stages(data, keys, common)
            stn = self._refiner(data, unet, siamese, embedding, common)
        self._fitted = {
            "unet": unet if self.uses_unet else None,
            "siamese": siamese.eval(),
            "stn": None if stn is None else stn.eval(),
            "embedding": embed_templates(siamese, data, device) if embedding is None else embedding.to(device),
            "templates": data.templates.to(device),
            "template_homographies": data.template_homographies.to(device),
            "dictionary_homographies": np.asarray(dictionary.homographies, np.float64),
            "A": resolution_matrix((train.semantics.shape[2], train.semantics.shape[1]), data.work_size),
            "work_size": data.work_size,
        }

    def _shared_stages(self, data: TrainingData, keys: dict[str, str],
                       common: _Common) -> tuple[TrainingData, nn.Module | None, SiameseNet, Tensor]:
        """Step-by-step: the UNet (None under ``segmentation: ground-truth``) and the Siamese, each
        loaded from the cache or trained into it, and the dictionary embedded by the Siamese. Their
        keys hold neither the model nor its STN settings: every step-by-step run on the same data
        and stage settings shares them. ``data`` comes back with the UNet's maps kept
        (:func:`with_unet_maps`) for the stages after it."""
        s = self.settings
        unet_key = None
        unet = None
        if self.uses_unet:
            # Under patience the UNet keeps its best epoch by validation cross-entropy, as the STN does by L_warp.
            held_out = self._held_out if s.patience is not None else None
            rate = s.unet_learning_rate or s.learning_rate
            unet_common = common.copy()
            unet_common["lr"] = rate
            unet_key = unet_cache_key(keys["train"], s.unet_width, s.unet_depth, s.unet_epochs, s.batch_size,
                                      rate, self.seed, held_out_key=keys.get("held_out"),
                                      patience=None if held_out is None else s.patience,
                                      class_weights=s.unet_class_weights)
            weights = self._unet_class_weights(data)
            validate = None if held_out is None else partial(segmentation_validation_loss, held_out=held_out,
                                                              class_weights=weights)
            unet = self._stage("unet", unet_key, self._unet(), lambda m, log: train_unet(
                m, data, s.unet_epochs, log=log, validate=validate, patience=s.patience,
                scores=self._log("unet-validation") if validate else None, class_weights=weights, **unet_common))
            data = with_unet_maps(data, unet, self.device)
        siamese_key = digest("siamese", keys["train"], keys["dictionary"], self.matching, keys["match"], unet_key,
                             s.siamese_width, s.embedding_dim, s.siamese_epochs, s.batch_size, s.learning_rate,
                             self.seed)
        self.stage_keys.update({"siamese": siamese_key} if unet_key is None else {"unet": unet_key,
                                                                                  "siamese": siamese_key})
        siamese = self._stage("siamese", siamese_key, self._siamese(), lambda m, log: train_siamese(
            m, data, unet, s.siamese_epochs, log=log, **common))
        return data, unet, siamese, self._embedding(siamese_key, keys["dictionary"], siamese, data)

    def _unet_class_weights(self, data: TrainingData) -> Tensor | None:
        """(C,) weights of the UNet's cross-entropy under ``unet_class_weights`` (None: the plain one),
        from the train maps at the working resolution."""
        if self.settings.unet_class_weights is None or not self.uses_unet:
            return None
        return inverse_frequency_weights(data.semantics)

    def _refiner(self, data: TrainingData, unet: nn.Module | None, siamese: SiameseNet, embedding: Tensor,
                 common: _Common) -> nn.Module | None:
        """Step-by-step: the STN, trained on the templates ``stn_template`` names (never cached).
        None: no refinement (a subclass's choice)."""
        s = self.settings
        templates = stn_templates(s.stn_template, data, siamese, unet, self.device, dictionary=embedding)
        validate = None if s.patience is None else self._scorer(siamese, unet, embedding)
        stn = train_stn(self._stn(data.work_size), data, unet, self.loss, s.stn_epochs, log=self._log("stn"),
                        templates=templates, class_reduction=s.class_reduction, validate=validate,
                        patience=s.patience, scores=self._log("stn-validation") if validate else None, **common)
        self.trained_stages.append("stn")
        return stn

    # --- prediction -----------------------------------------------------------------------

    def _from_maps(self, maps: Tensor) -> np.ndarray:
        """(B, 4, h, w) input maps on the device → (B, 3, 3) full-resolution homographies."""
        f = self._check_fitted()
        H_work = estimate(maps, f["siamese"], f["stn"], f["embedding"], f["templates"],
                          f["template_homographies"], f["work_size"])
        return np.linalg.solve(f["A"], H_work.cpu().numpy())

    def _check_fitted(self) -> dict[str, Any]:
        if self._fitted is None:
            raise RuntimeError(f"{type(self).__name__}: call fit() first")
        return self._fitted

    def predict(self, images: np.ndarray) -> np.ndarray:
        """(B, H, W, 3) uint8 RGB → (B, 3, 3) float64 bird's-eye → image homographies."""
        f = self._check_fitted()
        if f["unet"] is None:
            raise RuntimeError("fitted with segmentation='ground-truth': it estimates from true class maps "
                               "(predict_semantic), not from pixels")
        out = []
        for start in range(0, len(images), _PREDICT_BATCH):
            rgb = reduce_images(np.asarray(images[start:start + _PREDICT_BATCH]), f["work_size"])
            with torch.no_grad():
                maps = f["unet"](rgb.to(self.device).float().div_(255.0)).softmax(dim=1)
            out.append(self._from_maps(maps))
        return np.concatenate(out) if out else np.empty((0, 3, 3))

    def predict_semantic(self, semantics: np.ndarray) -> np.ndarray:
        """(B, H, W) uint8 class maps → (B, 3, 3) float64 homographies (UNet skipped)."""
        f = self._check_fitted()
        out = []
        for start in range(0, len(semantics), _PREDICT_BATCH):
            ids = reduce_class_maps(np.asarray(semantics[start:start + _PREDICT_BATCH]), f["work_size"])
            out.append(self._from_maps(one_hot_maps(ids.to(self.device), NUM_CLASSES)))
        return np.concatenate(out) if out else np.empty((0, 3, 3))


def fixed_options(*names: str) -> Callable[[type[_Estimator]], type[_Estimator]]:
    """Give a subclass that fixes ``names`` the parent's signature without them.

    Its ``__init__(**options)`` forwards everything; the explicit signature lets
    callers (the harness) see which options it takes, hence which axes apply.
    """
    def fix(cls: type[_Estimator]) -> type[_Estimator]:
        signature = inspect.signature(PaperEstimator.__init__)
        init = cast(Any, cls.__init__)  # a function object: it takes the attribute inspect reads
        init.__signature__ = signature.replace(
            parameters=[p for name, p in signature.parameters.items() if name not in names])
        return cls
    return fix


@fixed_options("model")
class ProposedEstimator(PaperEstimator):
    """The paper's proposed model (bundled name ``proposed``)."""

    label = "proposed"
    model_option = "proposed"

    def __init__(self, **options: Any) -> None:
        super().__init__(model="proposed", **options)


@fixed_options("model")
class BaselineEstimator(PaperEstimator):
    """Sha et al.'s baseline STN, as the paper describes it, in the same pipeline (bundled names
    ``baseline``, ``sha2020``)."""

    label = "sha2020"
    model_option = "baseline"

    def __init__(self, **options: Any) -> None:
        super().__init__(model="baseline", **options)


@fixed_options("model")
class CcbvEstimator(PaperEstimator):
    """Sha et al.'s STN as the public CCBV re-implementation builds it, in the same pipeline
    (bundled name ``sha2020-ccbv``; :class:`synthcal.models.CcbvSTN`)."""

    label = "sha2020-ccbv"
    model_option = "ccbv"

    def __init__(self, **options: Any) -> None:
        super().__init__(model="ccbv", **options)
