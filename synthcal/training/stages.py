"""Training the stages of the paper's models (SPEC §7).

The stages
----------
* :func:`train_unet` — RGB → 4-class logits, cross-entropy against the true maps.
* :func:`train_siamese` — embeds (B, 4, h, w) maps: the UNet's probabilities, or
  the true one-hot maps under ``segmentation: ground-truth``. Each train map is
  paired with its ground-truth template (similar: the dictionary template of
  lowest matching score, :func:`synthcal.models.match_ground_truth`) and with two
  dissimilar ones: the hardest other template under the current embeddings
  (refreshed every epoch) and a random other one; contrastive loss.
* :func:`train_stn` — the STN reads (input map ⊕ a template), 8 channels, and is
  trained with ``L_warp(Ŷ, Y)``: ``Ŷ`` the scene warped by the composed estimate,
  ``Y`` the scene warped by the true homography through the same bilinear,
  cheirality-masked renderer, so a perfect estimate costs exactly 0. Which
  template (:func:`stn_templates`): ``retrieved`` (the default) — the nearest
  dictionary template by the trained, frozen Siamese, exactly what the STN gets at
  test time, optimal or not (the paper's premise, Sec. 3.1 and 5); or
  ``ground-truth`` — the template of lowest matching score. The Siamese and the
  maps it reads (true maps, or a frozen UNet's in eval mode) do not change while
  the STN trains, so the retrieval is computed once, before the first epoch:
  re-embedding the dictionary every epoch would give the same templates.
  With a validation split and a ``patience`` (:func:`validation_loss`), the STN is
  scored on it after every epoch, the best epoch's weights are kept and training
  stops after ``patience`` epochs without a better score.
* :func:`train_end_to_end` — :meth:`CompositeModel.training_loss` under the warm-up
  schedule scaled to the profile's epoch count (:func:`end_to_end_stage`); its
  STN reads what the current joint embedding retrieves (dictionary re-embedded
  every epoch), or the ground-truth template.

Working resolution: :mod:`synthcal.training.resolution`.

Anti-aliased scene
------------------
``L_warp`` compares views rendered by bilinear sampling of the bird's-eye map.
Where a view pixel covers many scene pixels (far ground, short focal), point
samples of the full-resolution map alias, and their gradient with respect to
``H`` exists only within one scene pixel of a class boundary: most of the view
gives no signal. The loss therefore samples the one-hot scene reduced by
``scene_downsample`` (area average: soft boundaries a few pixels wide) through
``H D⁻¹`` (``D`` the same pixel-centre map as ``A``). Prediction and target go
through the same renderer, so the true homography still costs exactly 0; the
estimates themselves are untouched.

Caching: :mod:`synthcal.training.cache`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import cast

import numpy as np
import torch
from torch import Tensor, nn
from tqdm.auto import tqdm

from synthcal.config import ClassReduction, Loss, Matching, StnTemplate
from synthcal.models import (
    CompositeModel,
    SiameseNet,
    UNet,
    compose_homography,
    contrastive_loss,
    nearest_embeddings,
    one_hot_maps,
    segmentation_loss,
    warp_loss,
)
from synthcal.training.examples import (
    ClassMapLogits,
    StnExamples,
    TrainingData,
    image_batch,
    input_maps,
    template_maps,
    with_unet_maps,
)
from synthcal.training.resolution import NUM_CLASSES
from synthcal.training.validation import held_out_estimates

__all__ = [
    "PAPER_END_TO_END_EPOCHS",
    "WARP_LOSS_NAMES",
    "MATCHING_SCORES",
    "composite_model",
    "embed_templates",
    "retrieve_templates",
    "stn_templates",
    "inverse_frequency_weights",
    "train_unet",
    "segmentation_validation_loss",
    "segmentation_class_iou",
    "train_siamese",
    "train_stn",
    "validation_loss",
    "best_epoch",
    "BestEpoch",
    "end_to_end_stage",
    "train_end_to_end",
    "estimate",
]

# The paper's warm-up thresholds (20, 40) read as fractions of a 100-epoch schedule.
PAPER_END_TO_END_EPOCHS = 100
# The options' spellings (:mod:`synthcal.config`) → the names :mod:`synthcal.models` gives
# its warp losses (:func:`synthcal.models.warp_loss`) and matching scores
# (:func:`synthcal.models.match_ground_truth`).
WARP_LOSS_NAMES: dict[Loss, str] = {"top-mse": "top_mse", "mse": "mse", "top-dice": "top_dice", "dice": "dice"}
MATCHING_SCORES: dict[Matching, str] = {"top-mse": "top_mse", "mse": "mse"}


def _batches(n: int, batch_size: int, generator: torch.Generator) -> Iterator[Tensor]:
    """Shuffled index batches covering ``0..n-1`` once."""
    order = torch.randperm(n, generator=generator)
    yield from order.split(batch_size)


def _record(log: list[float] | None, losses: list[float]) -> None:
    """Append an epoch's mean loss to ``log`` (if one is kept)."""
    if log is not None and losses:
        log.append(float(np.mean(losses)))


def _epochs(epochs: int, desc: str, progress: bool) -> tqdm:
    return tqdm(range(epochs), desc=desc, leave=False, disable=not progress, unit="epoch")


# --- stages --------------------------------------------------------------------------------


def _step(optimiser: torch.optim.Optimizer, loss: Tensor) -> float:
    """One gradient step on ``loss``; returns its value."""
    optimiser.zero_grad(set_to_none=True)
    loss.backward()
    optimiser.step()
    return loss.item()


class BestEpoch:
    """Early stopping on a validation score: keeps the weights of the epoch with the lowest
    score (ties: the later, longer-trained one) and says when ``patience`` epochs passed
    without a better one.

    Args:
        patience: epochs without a better score before stopping (None: never stop).
        scores: the list that receives every epoch's score (None: a new one, :attr:`scores`).
    """

    def __init__(self, patience: int | None = None, scores: list[float] | None = None) -> None:
        self.patience = patience
        self.scores: list[float] = [] if scores is None else scores
        self.best: dict[str, Tensor] | None = None

    def stop_after(self, module: nn.Module, score: float) -> bool:
        """Record the epoch just trained, scoring ``score``; True when training should stop."""
        self.scores.append(score)
        if score <= min(self.scores):
            self.best = {name: value.detach().clone() for name, value in module.state_dict().items()}
        return self.patience is not None and len(self.scores) - 1 - best_epoch(self.scores) >= self.patience

    def restore(self, module: nn.Module) -> None:
        """Load the best epoch's weights into ``module`` (nothing when no epoch was scored)."""
        if self.best is not None:
            module.load_state_dict(self.best)


def inverse_frequency_weights(semantics: Tensor, num_classes: int = NUM_CLASSES) -> Tensor:
    """(C,) float32 weight of each class: the inverse of its pixel share in ``semantics``
    ((K, h, w) class ids), normalised to mean 1 (a class with no pixel counts as one).

    >>> inverse_frequency_weights(torch.tensor([[[0, 0, 0, 1]]]), num_classes=2).tolist()
    [0.5, 1.5]
    """
    counts = torch.bincount(semantics.flatten().long(), minlength=num_classes).double().clamp(min=1)
    weights = 1.0 / counts
    return (weights / weights.mean()).float()


def train_unet(unet: UNet, data: TrainingData, epochs: int, batch_size: int, lr: float, device: torch.device,
               seed: int = 0, progress: bool = False, log: list[float] | None = None,
               validate: Callable[[nn.Module], float] | None = None, patience: int | None = None,
               scores: list[float] | None = None, class_weights: Tensor | None = None) -> UNet:
    """Cross-entropy training of ``unet`` on the train images (SPEC §7). Returns it, trained.

    ``log``, if given, receives the mean loss of every epoch (as for every stage).
    ``class_weights``: (C,) weights of the cross-entropy's classes (None: the paper's
    plain one; :func:`inverse_frequency_weights`).
    ``validate`` (e.g. :func:`segmentation_validation_loss` on the validation split)
    scores the UNet after each epoch into ``scores``; the best epoch's weights are
    returned, and training stops after ``patience`` epochs without a better score
    (None: all), as :func:`train_stn` does.
    """
    torch.manual_seed(seed)
    generator = torch.Generator().manual_seed(seed)
    unet.to(device).train()
    optimiser = torch.optim.Adam(unet.parameters(), lr=lr)
    keeper = BestEpoch(patience, scores)
    bar = _epochs(epochs, "unet", progress)
    for _ in bar:
        losses: list[float] = []
        for index in _batches(len(data), batch_size, generator):
            loss = segmentation_loss(unet(image_batch(data, index, device)), data.semantics[index].to(device),
                                     class_weights)
            losses.append(_step(optimiser, loss))
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
        _record(log, losses)
        if validate is not None and keeper.stop_after(unet, validate(unet)):
            break
    keeper.restore(unet)
    return unet.eval()


@torch.no_grad()
def segmentation_validation_loss(unet: nn.Module, held_out: TrainingData, batch_size: int = 256,
                                 class_weights: Tensor | None = None) -> float:
    """Mean cross-entropy of ``unet`` (eval mode, then back) on held-out items' images against their true maps
    (weighted by ``class_weights`` as in :func:`train_unet`; the batch means are weighted by their items)."""
    was_training = unet.training
    unet.eval()
    device = next(unet.parameters()).device
    total = 0.0
    for index in torch.arange(len(held_out)).split(batch_size):
        logits = unet(image_batch(held_out, index, device))
        total += segmentation_loss(logits, held_out.semantics[index].to(device), class_weights).item() * len(index)
    unet.train(was_training)
    return total / max(len(held_out), 1)


@torch.no_grad()
def segmentation_class_iou(unet: nn.Module, held_out: TrainingData, batch_size: int = 256) -> Tensor:
    """(C,) float64 IoU of each class of ``unet``'s argmax maps on held-out items against their true maps,
    pixels pooled over items (NaN: a class in neither); the maps kept by :func:`with_unet_maps` are read, not
    made again; eval mode, then back.

    What a falling cross-entropy hides: a thin class (the bicycle path at 128 × 72) that the UNet never
    predicts costs the mean loss little (docs/decisions.md, "The UNet's loss").
    """
    was_training = unet.training
    unet.eval()
    device = next(unet.parameters()).device
    intersection = torch.zeros(NUM_CLASSES, dtype=torch.float64)
    union = torch.zeros(NUM_CLASSES, dtype=torch.float64)
    for index in torch.arange(len(held_out)).split(batch_size):
        predicted = input_maps(held_out, index, unet, device).argmax(dim=1).cpu()
        truth = held_out.semantics[index].long()
        for k in range(NUM_CLASSES):
            intersection[k] += ((predicted == k) & (truth == k)).sum().item()
            union[k] += ((predicted == k) | (truth == k)).sum().item()
    unet.train(was_training)
    return torch.where(union > 0, intersection / union.clamp(min=1), torch.full_like(union, float("nan")))


@torch.no_grad()
def embed_templates(siamese: SiameseNet, data: TrainingData, device: torch.device, batch_size: int = 256) -> Tensor:
    """(T, D) embeddings of every template, in eval mode (then back to the previous mode)."""
    was_training = siamese.training
    siamese.eval()
    index = torch.arange(len(data.templates))
    out = torch.cat([siamese(template_maps(data, chunk, device)) for chunk in index.split(batch_size)])
    siamese.train(was_training)
    return out


@torch.no_grad()
def retrieve_templates(siamese: SiameseNet, data: TrainingData, unet: nn.Module | None, device: torch.device,
                       batch_size: int = 256, dictionary: Tensor | None = None) -> Tensor:
    """(K,) int64 nearest dictionary template of every train item by ``siamese`` (eval mode), on the CPU.

    The Siamese reads what it reads at test time: the UNet's probabilities, or the
    true one-hot maps when ``unet`` is None. ``dictionary``: the (T, D) template
    embeddings by this Siamese when already computed (None: embedded here).
    """
    was_training = siamese.training
    siamese.eval()
    if dictionary is None:
        dictionary = embed_templates(siamese, data, device, batch_size)
    dictionary = dictionary.to(device)
    out = [torch.empty(0, dtype=torch.long)]
    for chunk in torch.arange(len(data)).split(batch_size):
        out.append(nearest_embeddings(siamese(input_maps(data, chunk, unet, device)), dictionary).index.cpu())
    siamese.train(was_training)
    return torch.cat(out)


def stn_templates(choice: StnTemplate, data: TrainingData, siamese: SiameseNet, unet: nn.Module | None,
                  device: torch.device, dictionary: Tensor | None = None) -> Tensor:
    """(K,) template each train item's STN input holds: ``retrieved`` by the frozen Siamese or ``ground-truth``.

    ``dictionary``: the (T, D) template embeddings by ``siamese``, if already computed.
    """
    if choice == "ground-truth":
        return data.match
    if choice == "retrieved":
        return retrieve_templates(siamese, data, unet, device, dictionary=dictionary)
    raise ValueError(f"stn_template must be 'retrieved' or 'ground-truth'; got {choice!r}")


def train_siamese(siamese: SiameseNet, data: TrainingData, unet: nn.Module | None, epochs: int, batch_size: int,
                  lr: float, device: torch.device, seed: int = 0, margin: float = 1.0,
                  progress: bool = False, log: list[float] | None = None) -> SiameseNet:
    """Contrastive training on (input map, template) pairs (module docstring). Returns it, trained."""
    torch.manual_seed(seed)
    generator = torch.Generator().manual_seed(seed)
    siamese.to(device).train()
    optimiser = torch.optim.Adam(siamese.parameters(), lr=lr)
    n_templates = len(data.templates)
    if data.unet_maps is None:
        data = with_unet_maps(data, unet, device)
    bar = _epochs(epochs, "siamese", progress)
    for _ in bar:
        losses: list[float] = []
        dictionary = embed_templates(siamese, data, device)
        for index in _batches(len(data), batch_size, generator):
            anchor = siamese(input_maps(data, index, unet, device))
            positive = data.match[index]
            candidates = [positive]
            if n_templates > 1:
                distance = torch.cdist(anchor.detach(), dictionary).cpu()
                distance[torch.arange(len(index)), positive] = float("inf")
                shift = torch.randint(1, n_templates, (len(index),), generator=generator)
                candidates += [distance.argmin(dim=1), (positive + shift) % n_templates]
            partners = torch.cat(candidates)
            same = torch.zeros(len(partners), device=device)
            same[: len(index)] = 1.0
            embedded = siamese(template_maps(data, partners, device))
            loss = contrastive_loss(anchor.repeat(len(partners) // len(index), 1), embedded, same, margin)
            losses.append(_step(optimiser, loss))
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
        _record(log, losses)
    return siamese.eval()


@torch.no_grad()
def validation_loss(stn: nn.Module | None, examples: StnExamples, template_homographies: Tensor,
                    criterion: Callable[[Tensor, Tensor], Tensor], batch_size: int = 256) -> float:
    """Mean ``L_warp`` of the STN's estimates over held-out items, in eval mode (then back).

    Args:
        stn: the STN (None: no refinement, the templates' homographies themselves).
        examples: the items (validation maps ⊕ the template the Siamese retrieves for
            each, as at test time) and their true views.
        template_homographies: (K, 3, 3) working-resolution ``A H_k`` of each item's template.
        criterion: the warp loss (a batch mean).
        batch_size: items at a time.

    Returns:
        the item-weighted mean loss.
    """
    total, count = 0.0, 0
    for index, H, target in held_out_estimates(stn, examples, template_homographies, batch_size):
        total += criterion(examples.warp(H), target).item() * len(index)
        count += len(index)
    return total / max(count, 1)


def best_epoch(scores: Sequence[float]) -> int:
    """0-based epoch of the lowest validation score, the later one on a tie (as :func:`train_stn` keeps).

    >>> best_epoch([3.0, 1.0, 2.0, 1.0, 4.0])
    3
    """
    return len(scores) - 1 - int(np.argmin(np.asarray(scores)[::-1]))


def train_stn(stn: nn.Module, data: TrainingData, unet: nn.Module | None, loss: Loss, epochs: int,
              batch_size: int, lr: float, device: torch.device, seed: int = 0, progress: bool = False,
              log: list[float] | None = None, templates: Tensor | None = None,
              class_reduction: ClassReduction = "sum", validate: Callable[[nn.Module], float] | None = None,
              patience: int | None = None, scores: list[float] | None = None) -> nn.Module:
    """``L_warp`` training of an STN on (input map ⊕ template). Returns it, trained.

    ``templates``: (K,) the template of each train item (:func:`stn_templates`;
    None: the ground-truth ones, ``data.match``). ``class_reduction``: of the
    MSE-based losses. What does not change from batch to batch — each item's
    input and target view — is made once, before the first epoch (:class:`StnExamples`).
    ``validate`` (e.g. :func:`validation_loss` on the validation split) scores the
    STN after each epoch into ``scores``: the weights of the best epoch are returned,
    and training stops after ``patience`` epochs without a better score (None: all).
    """
    torch.manual_seed(seed)
    generator = torch.Generator().manual_seed(seed)
    stn.to(device).train()
    optimiser = torch.optim.Adam(stn.parameters(), lr=lr)
    criterion = warp_loss(WARP_LOSS_NAMES[loss], class_reduction)
    chosen = data.match if templates is None else templates
    examples = StnExamples(data, chosen, unet, device)
    template_homographies = data.template_homographies[chosen].to(device)
    keeper = BestEpoch(patience, scores)
    bar = _epochs(epochs, f"stn {loss}", progress)
    for _ in bar:
        losses: list[float] = []
        for index in _batches(len(data), batch_size, generator):
            inputs, target = examples.batch(index)
            H = compose_homography(stn(inputs), template_homographies[index.to(device)], data.work_size)
            value = criterion(examples.warp(H), target)
            losses.append(_step(optimiser, value))
            bar.set_postfix(loss=f"{losses[-1]:.4f}")
        _record(log, losses)
        if validate is not None and keeper.stop_after(stn, validate(stn)):
            break
    keeper.restore(stn)
    return stn.eval()


def end_to_end_stage(epoch: int, epochs: int, with_unet: bool = True) -> int:
    """The paper-schedule epoch that 0-based ``epoch`` of ``epochs`` plays.

    SPEC §7's thresholds 20 and 40 are read as 20 % and 40 % of a
    :data:`PAPER_END_TO_END_EPOCHS` (100) epoch schedule, scaled to ``epochs``
    with at least one epoch per phase: segmentation for the first
    ``t1 = max(1, round(0.2 E))`` epochs, embedding until ``t2 = max(t1 + 1,
    round(0.4 E))``, then the joint loss. The result feeds
    :func:`synthcal.models.end_to_end_weights`. Without a UNet
    (``segmentation: ground-truth``) there is nothing to segment: the first phase
    is skipped, so the schedule is ``epochs − t1`` epochs long and ``epoch``
    counts from ``t1``.

    >>> [end_to_end_stage(e, 5) for e in range(5)]
    [0, 20, 40, 41, 42]
    >>> [end_to_end_stage(e, 100) for e in (19, 20, 39, 40)]
    [19, 20, 39, 40]
    """
    t1 = max(1, round(0.2 * epochs))
    t2 = max(t1 + 1, round(0.4 * epochs))
    if not with_unet:
        epoch += t1
    p1, p2 = 0.2 * PAPER_END_TO_END_EPOCHS, 0.4 * PAPER_END_TO_END_EPOCHS
    if epoch < t1:
        return int(epoch * p1 // t1)
    if epoch < t2:
        return int(p1 + (epoch - t1) * (p2 - p1) // (t2 - t1))
    return int(p2) + epoch - t2


def composite_model(unet: UNet | ClassMapLogits, siamese: SiameseNet, stn: nn.Module, data: TrainingData,
                    loss: Loss, class_reduction: ClassReduction = "sum",
                    stn_template: StnTemplate = "retrieved", class_weights: Tensor | None = None) -> CompositeModel:
    """:class:`CompositeModel` over the anti-aliased scene of the loss (``class_weights``: of its ``L_CE``).

    Its templates' homographies are given in the reduced scene's frame
    (``A H_k D⁻¹``), so every homography it composes is too, and its scene is the
    soft reduced map; :func:`train_end_to_end` gives it the true homographies in
    the same frame. Used for training only; estimates come from :func:`estimate`.
    """
    # CompositeModel only calls its ``unet`` for logits; ClassMapLogits (true maps) serves as well,
    # though synthcal.models annotates the argument as UNet.
    return CompositeModel(cast(UNet, unet), siamese, stn, data.scene.clone(), data.templates,
                          data.template_homographies @ data.scene_frame, NUM_CLASSES, WARP_LOSS_NAMES[loss],
                          class_reduction=class_reduction, stn_template=stn_template, class_weights=class_weights)


def train_end_to_end(model: CompositeModel, data: TrainingData, with_unet: bool, epochs: int, batch_size: int,
                     lr: float, device: torch.device, seed: int = 0, progress: bool = False,
                     log: list[float] | None = None) -> CompositeModel:
    """``η L_CE + τ L_con + γ L_warp`` under the scaled warm-up (:func:`end_to_end_stage`).

    Without a UNet the model's ``unet`` is a :class:`ClassMapLogits` and its
    inputs are the true one-hot maps.
    """
    torch.manual_seed(seed)
    generator = torch.Generator().manual_seed(seed)
    model.to(device).train()
    optimiser = torch.optim.Adam([p for p in model.parameters() if p.requires_grad], lr=lr)
    skipped = 0 if with_unet else max(1, round(0.2 * epochs))
    bar = _epochs(epochs - skipped, "end-to-end", progress)
    for epoch in bar:
        losses: list[float] = []
        stage = end_to_end_stage(epoch, epochs, with_unet)
        model.refresh_dictionary_embeddings()
        for index in _batches(len(data), batch_size, generator):
            semantics = data.semantics[index].to(device)
            inputs = image_batch(data, index, device) if with_unet else one_hot_maps(semantics, NUM_CLASSES)
            truth = (data.homographies[index] @ data.scene_frame).to(device)  # the model's scene frame
            loss, terms = model.training_loss(inputs, semantics, data.match[index].to(device), stage,
                                              target_homography=truth)
            losses.append(_step(optimiser, loss))
            bar.set_postfix(stage=stage, **{k: f"{v:.4f}" for k, v in terms.items()})
        _record(log, losses)
    return model.eval()


@torch.no_grad()
def estimate(maps: Tensor, siamese: nn.Module, stn: nn.Module, dictionary_embedding: Tensor,
             templates: Tensor, template_homographies: Tensor, work_size: tuple[int, int]) -> Tensor:
    """Inference: retrieve each map's nearest template, refine it with the STN.

    Args:
        maps: (B, 4, h, w) input maps (UNet probabilities or one-hot), on the device.
        siamese: embedding network (eval mode).
        stn: (B, 8, h, w) → (B, 8) (eval mode).
        dictionary_embedding: (T, D) template embeddings.
        templates: (T, h, w) uint8 template class ids, on the device.
        template_homographies: (T, 3, 3) float64 working-resolution ``A H_k``.
        work_size: ``(w, h)``.

    Returns:
        (B, 3, 3) float64 working-resolution homographies.
    """
    match = nearest_embeddings(siamese(maps), dictionary_embedding).index
    h_bar = stn(torch.cat([maps, one_hot_maps(templates[match], NUM_CLASSES, maps.dtype)], dim=1))
    return compose_homography(h_bar, template_homographies[match], work_size)
