"""Scores of a fitted STN on held-out items: what ranks epochs and learning rates.

Two scores read the same estimates — each validation map gets the template the trained
Siamese retrieves for it, the STN refines that template's homography, as a test image
would go (:class:`synthcal.training.StnExamples` holds the items):

* :func:`synthcal.training.validation_loss`: the run's own ``L_warp`` of the estimates;
* :func:`validation_iou`: their mean ``iou`` — the tables' reading (SPEC §8, classes 1–3
  present in either view) — at the working resolution.

``L_warp`` is what the STN lowers, but it cannot always tell a failed fit from a working
one: on the paper's mix ``mixed-1`` with Top-MSE, the ``L_warp`` of a fit whose every view
lies behind the camera (an empty view) is within 0–11 % of the chosen fits' scores
(docs/reproduction.md, "The cell again" under "The trained models on the paper's mix").
``iou`` scores what the tables report, at the price of a class-id render per item.

Convention:
    Homographies map bird's-eye (scene) pixels to working-resolution image pixels
    (``A H``, SPEC §2). An estimate's sign is fixed by SPEC §2's rule before its view is
    drawn — the bottom-centre pixel ``((w − 1) / 2, h − 1)`` sees the ground in front of
    the camera — as the scorer does (:func:`synthcal.eval.metrics.check_homography`), so a
    view "behind the camera" is scored as the scorer scores it.
"""

from __future__ import annotations

from collections.abc import Iterator

import torch
from torch import Tensor, nn

from synthcal.models import compose_homography, warp_semantic
from synthcal.models.warp import inverse_3x3
from synthcal.training.examples import StnExamples
from synthcal.training.resolution import NUM_CLASSES

__all__ = ["held_out_estimates", "orient_homographies", "class_iou", "true_views", "validation_iou"]


@torch.no_grad()
def held_out_estimates(stn: nn.Module | None, examples: StnExamples, template_homographies: Tensor,
                       batch_size: int = 256) -> Iterator[tuple[Tensor, Tensor, Tensor]]:
    """The STN's estimates of held-out items, batch by batch, in eval mode (then back).

    Args:
        stn: the STN (None: no refinement, the templates' homographies themselves).
        examples: the items and their true views.
        template_homographies: (K, 3, 3) working-resolution ``A H_k`` of each item's template.
        batch_size: items at a time.

    Yields:
        ``(index, H, target)``: (B,) item indices, (B, 3, 3) working-resolution estimates
        and the (B, 4, h, w) true views of the loss's scene.
    """
    was_training = stn is not None and stn.training
    if stn is not None:
        stn.eval()
    try:
        for index in torch.arange(len(examples.templates)).split(batch_size):
            inputs, target = examples.batch(index)
            H = template_homographies[index.to(examples.device)]
            if stn is not None:
                H = compose_homography(stn(inputs), H, examples.data.work_size)
            yield index, H, target
    finally:
        if stn is not None:
            stn.train(was_training)


def orient_homographies(homographies: Tensor, image_size: tuple[int, int]) -> Tensor:
    """Homographies with the sign SPEC §2 fixes: the bottom-centre pixel sees the ground ahead.

    Args:
        homographies: (B, 3, 3) bird's-eye → image, any sign.
        image_size: ``(width, height)`` of the image.

    Returns:
        (B, 3, 3): each one negated where its bottom-centre pixel's ground point lies
        behind the camera (third coordinate of ``H⁻¹ x`` below 0), else as given.

    Example:
        >>> H = torch.eye(3, dtype=torch.float64)[None]
        >>> orient_homographies(-H, (9, 5))[0, 2, 2].item()
        1.0
    """
    width, height = image_size
    bottom_centre = torch.tensor([(width - 1) / 2, height - 1, 1.0], dtype=homographies.dtype,
                                 device=homographies.device)
    depth = inverse_3x3(homographies)[:, 2] @ bottom_centre
    return torch.where((depth < 0)[:, None, None], -homographies, homographies)


def class_iou(predicted: Tensor, target: Tensor, num_classes: int = NUM_CLASSES) -> Tensor:
    """Per-item mean IoU over classes 1 .. num_classes − 1 present in either map (SPEC §8's ``iou``).

    Args:
        predicted: (B, h, w) integer class maps.
        target: (B, h, w) integer class maps, ids below ``num_classes``.
        num_classes: classes 0 .. num_classes − 1, 0 the background (not averaged).

    Returns:
        (B,) float64 IoU in [0, 1]; 1 for an item where neither map shows a foreground class.

    Example:
        >>> class_iou(torch.tensor([[[0, 1, 2, 2]]]), torch.tensor([[[0, 1, 1, 2]]]))  # 1/2 and 1/2
        tensor([0.5000], dtype=torch.float64)
    """
    p = predicted.reshape(len(predicted), -1).long()
    t = target.reshape(len(target), -1).long()
    ious = []
    for c in range(1, num_classes):
        intersection = ((p == c) & (t == c)).sum(1)
        union = ((p == c) | (t == c)).sum(1)
        ious.append(torch.where(union > 0, intersection.double() / union.clamp(min=1).double(), torch.nan))
    per_class = torch.stack(ious, dim=1)
    present = ~per_class.isnan()
    total = torch.where(present, per_class, 0.0).sum(1)
    return torch.where(present.any(1), total / present.sum(1).clamp(min=1), 1.0)


@torch.no_grad()
def true_views(examples: StnExamples, scene: Tensor, batch_size: int = 256) -> Tensor:
    """The class-id views the held-out items' true homographies draw, at the working resolution.

    They never change while a model trains: draw them once and pass them to every
    :func:`validation_iou` of a fit (each epoch, each learning rate).

    Args:
        examples: the items; their true homographies are ``examples.data.homographies``
            (working resolution, the sign SPEC §2 fixes).
        scene: (Hs, Ws) integer class ids of the bird's-eye scene.
        batch_size: items at a time.

    Returns:
        (K, h, w) class ids in the scene's dtype (a store's are uint8), drawn by nearest
        sampling as the generator's renderer does.
    """
    size = examples.data.work_size
    scene = scene.to(examples.device)
    homographies = examples.data.homographies
    return torch.cat([warp_semantic(scene, homographies[index].to(examples.device).double(), size, mode="nearest")
                      for index in torch.arange(len(homographies)).split(batch_size)])


@torch.no_grad()
def validation_iou(stn: nn.Module | None, examples: StnExamples, template_homographies: Tensor,
                   scene: Tensor, truth: Tensor | None = None, batch_size: int = 256) -> float:
    """Mean ``iou`` of the STN's estimates over held-out items, at the working resolution.

    Each estimate, its sign fixed (module docstring), draws the scene's class ids by
    nearest sampling, as the generator's renderer does; :func:`class_iou` compares that
    view with the item's true one (:func:`true_views`).

    Args:
        stn: the STN (None: no refinement, the templates' homographies themselves).
        examples: the items (validation maps ⊕ the retrieved template) and their true
            homographies (``examples.data.homographies``, working resolution).
        template_homographies: (K, 3, 3) working-resolution ``A H_k`` of each item's template.
        scene: (Hs, Ws) integer class ids of the bird's-eye scene (the full map, not the
            loss's reduced one).
        truth: (K, h, w) the items' true views, ``true_views(examples, scene)``; None draws
            them here (pass them when scoring many fits of the same items).
        batch_size: items at a time.

    Returns:
        the item-weighted mean IoU in [0, 1].
    """
    size = examples.data.work_size
    scene = scene.to(examples.device)
    if truth is None:
        truth = true_views(examples, scene, batch_size)
    total, count = 0.0, 0
    for index, H, _ in held_out_estimates(stn, examples, template_homographies, batch_size):
        estimated = warp_semantic(scene, orient_homographies(H.double(), size), size, mode="nearest")
        total += class_iou(estimated, truth[index.to(truth.device)]).sum().item()
        count += len(index)
    return total / max(count, 1)
