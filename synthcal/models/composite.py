"""The composite model UNet → Siamese → STN → warp, and its end-to-end objective.

Data flow (B images of size W × H, a dictionary of T templates)
--------------------------------------------------------------
1. ``UNet``: RGB (B, 3, H, W) → logits (B, 4, H, W); ``P = softmax(logits)``.
2. ``SiameseNet``: ``P`` → embedding (B, D); nearest dictionary embedding →
   retrieved template ``k`` (not differentiable).
3. STN: ``P ⊕ onehot(template_k)`` (B, 8, H, W) → ``h̄`` (B, 8);
   ``H = N⁻¹ H̄ N H_k`` (:func:`synthcal.models.stn.compose_homography`).
4. Warp: the scene's one-hot map through ``H`` (bilinear, cheirality-masked) →
   ``Ŷ`` (B, 4, H, W).

Gradients reach the UNet through ``P`` (the STN's input and the Siamese's input)
and through ``L_warp``; matching itself passes none.

Objective
---------
``L = η L_CE + τ L_con + γ L_warp`` with ``(η, τ, γ) = end_to_end_weights(epoch)``
(SPEC §7). ``L_con`` pairs each image's embedding with its ground-truth template
(similar) and with the nearest *other* template in the current dictionary
embeddings (dissimilar: the hardest negative). ``L_warp`` compares ``Ŷ`` with the
scene rendered through the *true* homography by the same bilinear renderer, so a
perfect estimate costs exactly 0. The STN reads, with ``stn_template="retrieved"``
(the default), the template the current joint embedding retrieves — the batch's
embeddings (the same forward pass as ``L_con``) against the dictionary embeddings
of :meth:`CompositeModel.refresh_dictionary_embeddings` (the trainer refreshes
them every epoch) — which is what it reads at test time; with ``"ground-truth"``
it reads the template of lowest matching score (teacher forcing).

Example
-------
>>> end_to_end_weights(0), end_to_end_weights(20), end_to_end_weights(40)
((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.05, 0.05, 0.9))
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor, nn

from .losses import CLASS_REDUCTION, one_hot_maps, warp_loss
from .siamese import SiameseNet, contrastive_loss, nearest_embeddings
from .stn import compose_homography
from .unet import UNet, segmentation_loss
from .warp import warp_semantic

__all__ = ["STN_TEMPLATES", "end_to_end_weights", "CompositeOutput", "CompositeModel"]

# The template the STN reads in training: the Siamese's retrieval (as at test time) or the ground truth.
STN_TEMPLATES = ("retrieved", "ground-truth")


def end_to_end_weights(epoch: int) -> tuple[float, float, float]:
    """Loss weights ``(η, τ, γ)`` of end-to-end training at a 0-based epoch.

    Epochs 0–19: (1, 0, 0), segmentation only; 20–39: (0, 1, 0), embedding only;
    40 on: (0.05, 0.05, 0.9). SPEC §7's "epochs ≤ 20" counts from 1: the same
    twenty epochs.
    """
    if epoch < 20:
        return 1.0, 0.0, 0.0
    if epoch < 40:
        return 0.0, 1.0, 0.0
    return 0.05, 0.05, 0.9


@dataclass
class CompositeOutput:
    """Everything :meth:`CompositeModel.forward` computes.

    Attributes:
        logits: (B, C, H, W) UNet logits.
        probabilities: (B, C, H, W) softmax of the logits.
        embedding: (B, D) Siamese embedding of the probabilities.
        match_index: (B,) int64 template given to the STN.
        h_bar: (B, 8) STN output.
        homography: (B, 3, 3) estimated bird's-eye → image homographies (float64).
        warped: (B, C, H, W) scene warped by ``homography`` (bilinear).
    """

    logits: Tensor
    probabilities: Tensor
    embedding: Tensor
    match_index: Tensor
    h_bar: Tensor
    homography: Tensor
    warped: Tensor


class CompositeModel(nn.Module):
    """UNet → Siamese → STN → warp over one scene and one template dictionary.

    The scene and dictionary are non-persistent buffers (they move with
    ``.to(device)`` but stay out of ``state_dict``).

    Args:
        unet: RGB → class logits.
        siamese: map → embedding.
        stn: (map ⊕ template) → 8 values of ``H̄``.
        scene: the bird's-eye scene as (Hs, Ws) integer class ids, or as (C, Hs, Ws)
            float class maps (e.g. the soft, anti-aliased one-hot map a loss samples).
        dictionary_semantic: (T, H, W) integer class ids of the templates.
        dictionary_homography: (T, 3, 3) the templates' homographies.
        num_classes: number of classes C.
        warp_loss_name: ``"mse"``, ``"dice"``, ``"top_mse"`` or ``"top_dice"``.
        margin: contrastive margin.
        class_reduction: ``"sum"`` or ``"mean"`` over classes in MSE-based warp losses.
        stn_template: ``"retrieved"`` or ``"ground-truth"``: the STN's template in training.
        class_weights: (C,) weights of ``L_CE``'s classes (None: the plain cross-entropy).
    """

    # Buffers, declared so that type checkers see Tensors (nn.Module.__getattr__ is untyped).
    scene: Tensor
    dictionary_semantic: Tensor
    dictionary_homography: Tensor
    dictionary_embedding: Tensor
    class_weights: Tensor | None

    def __init__(self, unet: UNet, siamese: SiameseNet, stn: nn.Module, scene: Tensor,
                 dictionary_semantic: Tensor, dictionary_homography: Tensor, num_classes: int = 4,
                 warp_loss_name: str = "top_mse", margin: float = 1.0, class_reduction: str = CLASS_REDUCTION,
                 stn_template: str = "retrieved", class_weights: Tensor | None = None):
        super().__init__()
        if stn_template not in STN_TEMPLATES:
            raise ValueError(f"stn_template must be one of {', '.join(STN_TEMPLATES)}; got {stn_template!r}")
        self.unet, self.siamese, self.stn = unet, siamese, stn
        self.num_classes, self.margin, self.stn_template = num_classes, margin, stn_template
        self.warp_loss = warp_loss(warp_loss_name, class_reduction)
        if not scene.is_floating_point():
            scene = one_hot_maps(scene, num_classes)
        if scene.ndim != 3 or scene.shape[0] != num_classes:
            raise ValueError(f"scene: expected (Hs, Ws) class ids or ({num_classes}, Hs, Ws) class maps, "
                             f"got shape {tuple(scene.shape)}")
        self.register_buffer("scene", scene, persistent=False)
        self.register_buffer("dictionary_semantic", dictionary_semantic.to(torch.uint8), persistent=False)
        self.register_buffer("dictionary_homography", dictionary_homography.double(), persistent=False)
        self.register_buffer("dictionary_embedding", torch.empty(0), persistent=False)
        self.register_buffer("class_weights", class_weights, persistent=False)

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)`` of the images (that of the templates)."""
        return self.dictionary_semantic.shape[-1], self.dictionary_semantic.shape[-2]

    def templates(self, index: Tensor) -> Tensor:
        """(B, C, H, W) one-hot maps of the templates ``index`` (B,)."""
        return one_hot_maps(self.dictionary_semantic[index], self.num_classes, self.scene.dtype)

    @torch.no_grad()
    def refresh_dictionary_embeddings(self, batch_size: int = 256) -> Tensor:
        """Re-embed every template with the current Siamese (eval mode); (T, D)."""
        was_training = self.siamese.training
        self.siamese.eval()
        index = torch.arange(self.dictionary_semantic.shape[0], device=self.dictionary_semantic.device)
        self.dictionary_embedding = torch.cat(
            [self.siamese(self.templates(chunk)) for chunk in index.split(batch_size)]
        )
        self.siamese.train(was_training)
        return self.dictionary_embedding

    def _refine(self, probabilities: Tensor, match_index: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """STN and warp for given templates: (h_bar, homography, warped)."""
        h_bar = self.stn(torch.cat([probabilities, self.templates(match_index)], dim=1))
        H = compose_homography(h_bar, self.dictionary_homography[match_index], self.image_size)
        return h_bar, H, warp_semantic(self.scene, H, self.image_size, "bilinear")

    def forward(self, images: Tensor, match_index: Tensor | None = None) -> CompositeOutput:
        """Run the whole pipeline.

        Args:
            images: (B, 3, H, W) RGB.
            match_index: (B,) templates for the STN; by default the nearest in
                embedding space (the dictionary embeddings are computed on first
                use; call :meth:`refresh_dictionary_embeddings` after training
                the Siamese).

        Returns:
            :class:`CompositeOutput`.
        """
        logits = self.unet(images)
        probabilities = logits.softmax(dim=1)
        embedding = self.siamese(probabilities)
        if match_index is None:
            if self.dictionary_embedding.numel() == 0:
                self.refresh_dictionary_embeddings()
            match_index = nearest_embeddings(embedding.detach(), self.dictionary_embedding).index
        h_bar, H, warped = self._refine(probabilities, match_index)
        return CompositeOutput(logits, probabilities, embedding, match_index, h_bar, H, warped)

    def _retrieve(self, embedding: Tensor) -> Tensor:
        """(B,) nearest template of each (B, D) embedding in the current dictionary embeddings."""
        if self.dictionary_embedding.numel() == 0:
            self.refresh_dictionary_embeddings()
        return nearest_embeddings(embedding.detach(), self.dictionary_embedding).index

    def _hardest_negative(self, embedding: Tensor, positive: Tensor) -> Tensor:
        """Nearest template in the current dictionary embeddings other than ``positive``."""
        if self.dictionary_embedding.numel() == 0:
            self.refresh_dictionary_embeddings()
        distance = torch.cdist(embedding.detach(), self.dictionary_embedding)
        distance.scatter_(1, positive[:, None], float("inf"))
        return distance.argmin(dim=1)

    def _contrastive(self, embedding: Tensor, target_match: Tensor) -> Tensor:
        """``L_con`` of (B, D) embeddings against their (B,) true templates and hardest negatives."""
        negative = self._hardest_negative(embedding, target_match)
        partners = self.siamese(self.templates(torch.cat([target_match, negative])))
        same = torch.cat([torch.ones_like(target_match), torch.zeros_like(negative)])
        return contrastive_loss(embedding.repeat(2, 1), partners, same, self.margin)

    def stn_templates(self, embedding: Tensor, target_match: Tensor) -> Tensor:
        """(B,) templates the STN reads in training: retrieved by (B, D) ``embedding``, or ``target_match``."""
        return target_match if self.stn_template == "ground-truth" else self._retrieve(embedding)

    def _warp_term(self, probabilities: Tensor, stn_match: Tensor, target_homography: Tensor) -> Tensor:
        """``L_warp`` of the STN's estimate from ``stn_match`` against the true view, same renderer."""
        warped = self._refine(probabilities, stn_match)[2]
        with torch.no_grad():
            target = warp_semantic(self.scene, target_homography.to(self.scene.device, torch.float64),
                                   self.image_size, "bilinear")
        return self.warp_loss(warped, target)

    def training_loss(self, images: Tensor, target_semantic: Tensor, target_match: Tensor, epoch: int, *,
                      target_homography: Tensor) -> tuple[Tensor, dict[str, float]]:
        """End-to-end objective ``η L_CE + τ L_con + γ L_warp`` at ``epoch``.

        Only the terms with a non-zero weight are computed.

        Args:
            images: (B, 3, H, W) RGB.
            target_semantic: (B, H, W) class ids of the images.
            target_match: (B,) ground-truth templates (lowest matching score).
            epoch: 0-based epoch (see :func:`end_to_end_weights`).
            target_homography: (B, 3, 3) true homographies, in the frame of the model's
                scene (as ``dictionary_homography``): ``L_warp``'s target is the scene
                rendered through them.

        Returns:
            ``(loss, terms)``: the scalar loss and the float value of each
            computed term (``"ce"``, ``"con"``, ``"warp"``).
        """
        eta, tau, gamma = end_to_end_weights(epoch)
        logits = self.unet(images)
        probabilities = logits.softmax(dim=1)
        total = logits.new_zeros(())
        terms: dict[str, float] = {}
        if eta:
            ce = segmentation_loss(logits, target_semantic, self.class_weights)
            total, terms["ce"] = total + eta * ce, ce.item()
        embedding = self.siamese(probabilities) if tau or (gamma and self.stn_template == "retrieved") else None
        if tau and embedding is not None:
            con = self._contrastive(embedding, target_match)
            total, terms["con"] = total + tau * con, con.item()
        if gamma:
            stn_match = target_match if embedding is None else self.stn_templates(embedding, target_match)
            warp = self._warp_term(probabilities, stn_match, target_homography)
            total, terms["warp"] = total + gamma * warp, warp.item()
        return total, terms
