"""What the training stages read: a split at the working resolution, its maps and the STN's examples.

* :class:`TrainingData` — a train (or validation) split and its dictionary at the
  working resolution, with the loss's anti-aliased scene (:func:`reduce_scene`;
  why: :mod:`synthcal.training.stages`, "Anti-aliased scene");
* :func:`input_maps` — the (B, 4, h, w) maps the Siamese and STN read: a frozen
  UNet's probabilities, or the true one-hot maps (:class:`ClassMapLogits` stands in
  for the UNet on true maps inside :class:`synthcal.models.CompositeModel`);
* :func:`with_unet_maps` and :class:`StnExamples` — maps made once per fit and kept,
  memory permitting (:func:`map_cache_bytes`), instead of once per batch.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from synthcal.models import one_hot_maps, warp_semantic
from synthcal.training.resolution import NUM_CLASSES, resolution_matrix

__all__ = [
    "TrainingData",
    "reduce_scene",
    "ClassMapLogits",
    "image_batch",
    "template_maps",
    "input_maps",
    "with_unet_maps",
    "MAP_CACHE_BYTES",
    "map_cache_bytes",
    "StnExamples",
]

@dataclass
class TrainingData:
    """A train split and its dictionary at the working resolution (CPU tensors).

    Attributes:
        images: (K, 3, h, w) uint8 RGB, or None when no UNet is trained.
        semantics: (K, h, w) uint8 class ids.
        homographies: (K, 3, 3) float64 working-resolution homographies ``A H``.
        match: (K,) int64 ground-truth template of each train item.
        templates: (T, h, w) uint8 class ids of the dictionary.
        template_homographies: (T, 3, 3) float64 working-resolution ``A H_k``.
        scene: (4, hs, ws) float one-hot bird's-eye scene, reduced by ``scene_downsample``.
        scene_frame: (3, 3) float64 ``D⁻¹``: reduced-scene pixels → scene pixels; the
            loss warps ``scene`` by ``H @ scene_frame``.
        work_size: ``(w, h)``.
        unet_maps: (K, 4, h, w) float32 the frozen UNet's probabilities of every item, on
            the training device, made once for a fit (:func:`with_unet_maps`); None: made
            batch by batch. They belong to the UNet that made them: pass that one beside.
    """

    images: Tensor | None
    semantics: Tensor
    homographies: Tensor
    match: Tensor
    templates: Tensor
    template_homographies: Tensor
    scene: Tensor
    scene_frame: Tensor
    work_size: tuple[int, int]
    unet_maps: Tensor | None = None

    def __len__(self) -> int:
        return len(self.semantics)


def reduce_scene(semantic: np.ndarray, factor: int) -> tuple[Tensor, Tensor]:
    """The anti-aliased scene of the loss (module docstring).

    Args:
        semantic: (Hs, Ws) class ids.
        factor: reduction factor (1: the scene itself, one-hot).

    Returns:
        ``(scene, scene_frame)``: (4, ⌈Hs/f⌉, ⌈Ws/f⌉) float32 soft one-hot map and the
        (3, 3) float64 ``D⁻¹`` from its pixels to the scene's.
    """
    maps = one_hot_maps(torch.from_numpy(np.asarray(semantic, np.uint8)), NUM_CLASSES)
    height, width = maps.shape[-2:]
    size = (-(-width // factor), -(-height // factor))
    if factor > 1:
        maps = F.interpolate(maps[None], size=size[::-1], mode="area")[0]
    D = resolution_matrix((width, height), size)
    return maps.contiguous(), torch.from_numpy(np.linalg.inv(D))


class ClassMapLogits(nn.Module):
    """Stands in for the UNet under ``segmentation: ground-truth``: one-hot maps → logits.

    ``softmax(20 · onehot)`` is the one-hot map to within ``4e-9``, so the rest of
    :class:`CompositeModel` runs unchanged on true maps. No parameters.
    """

    def forward(self, x: Tensor) -> Tensor:
        return 20.0 * x


def image_batch(data: TrainingData, index: Tensor, device: torch.device) -> Tensor:
    """(B, 3, h, w) float RGB in [0, 1] of items ``index``, for a UNet."""
    if data.images is None:
        raise ValueError("TrainingData.images is None: a UNet needs the train images (segmentation 'unet')")
    return data.images[index].to(device, non_blocking=True).float().div_(255.0)


def input_maps(data: TrainingData, index: Tensor, unet: nn.Module | None, device: torch.device) -> Tensor:
    """(B, 4, h, w) maps the Siamese and STN read: UNet probabilities or true one-hot maps.

    The UNet, if given, is frozen here (no gradient, eval mode by the caller); its maps
    are read from ``data.unet_maps`` when they were kept (:func:`with_unet_maps`).
    """
    if unet is None:
        return one_hot_maps(data.semantics[index].to(device), NUM_CLASSES)
    if data.unet_maps is not None:
        return data.unet_maps[index.to(data.unet_maps.device)].to(device)
    with torch.no_grad():
        return unet(image_batch(data, index, device)).softmax(dim=1)


def with_unet_maps(data: TrainingData, unet: nn.Module | None, device: torch.device,
                   chunk: int = 256) -> TrainingData:
    """``data`` with the frozen ``unet``'s probabilities of every item kept on ``device``.

    Every step-by-step stage after the UNet — the Siamese (every epoch), the
    retrieval of the STN's templates and the STN's inputs — reads the same maps of
    the same items: made once here, each reads them (:func:`input_maps`) instead of
    rerunning the UNet. Equal to the per-batch maps up to float associativity (the
    UNet sees chunks, not batches). Without a UNet (one-hot maps cost nothing to
    remake), or above :func:`map_cache_bytes`, ``data`` comes back without them.
    """
    data = replace(data, unet_maps=None)
    if unet is None or not _fits(data, 4, device):
        return data
    maps = torch.cat([input_maps(data, index, unet, device) for index in torch.arange(len(data)).split(chunk)])
    return replace(data, unet_maps=maps)


def template_maps(data: TrainingData, index: Tensor, device: torch.device) -> Tensor:
    """(B, 4, h, w) one-hot maps of templates ``index``."""
    return one_hot_maps(data.templates[index].to(device), NUM_CLASSES)


# Bytes of maps a fit may keep in the host's memory, each kind on its own: the frozen
# UNet's maps (:func:`with_unet_maps`), the STN's inputs and target views
# (:class:`StnExamples`); above it they are made batch by batch. The quick profile's
# STN examples (1,500 items at 128 × 72) need 0.33 GB, the paper's (3,000 at 256 × 144,
# UNet) 5.3 GB.
MAP_CACHE_BYTES = 4 * 2**30


def map_cache_bytes(device: torch.device) -> int:
    """Bytes of maps a fit may keep on ``device``: :data:`MAP_CACHE_BYTES` on the CPU,
    half the memory a CUDA device has free.

    Made per batch, the paper profile's examples (5.3 GB) rerun the frozen UNet on every
    STN batch of every epoch: an H200 took 5.1 s per proposed-STN epoch, against 1.6 s
    with them kept (benchmarks/README.md, "GPU").
    """
    if device.type == "cuda":
        free, _ = torch.cuda.mem_get_info(device)
        return int(free) // 2
    return MAP_CACHE_BYTES


def _fits(data: TrainingData, bytes_per_value: int, device: torch.device) -> bool:
    """Whether ``bytes_per_value`` bytes per (item, class, pixel) of ``data`` fit :func:`map_cache_bytes`."""
    h, w = data.semantics.shape[-2:]
    return len(data) * NUM_CLASSES * h * w * bytes_per_value <= map_cache_bytes(torch.device(device))


class StnExamples:
    """Each train item's STN input and target view, made once per fit (memory permitting).

    Neither changes while the STN trains: the input is the item's map (true one-hot,
    or the frozen UNet's probabilities) ⊕ its template's one-hot map, the template
    chosen before the first epoch; the target is the scene warped by the item's true
    homography. Making them in every batch of every epoch cost ~¼ of a step (issue 22).
    They are kept on ``device`` while ``len(data) ×`` bytes per item ≤
    :func:`map_cache_bytes` (one-hot inputs as uint8, the rest float32), else made
    per batch; the values are the same either way (items are converted, segmented
    and warped independently of their batch).

    Args:
        data: the train split.
        templates: (K,) the template of each train item.
        unet: the frozen UNet (eval mode), or None for true maps.
        device: where the batches go.
        chunk: items made at a time when caching.
    """

    def __init__(self, data: TrainingData, templates: Tensor, unet: nn.Module | None, device: torch.device,
                 chunk: int = 256) -> None:
        self.data, self.templates, self.unet, self.device = data, templates, unet, device
        self.scene, self.frame = data.scene.to(device), data.scene_frame.to(device)
        self.cached: tuple[Tensor, Tensor] | None = None
        # The target view in float32, the input map and template map as uint8 (one-hot) or float32.
        if _fits(data, 4 + (2 if unet is None else 8), device):
            inputs, targets = zip(*(self._make(index) for index in torch.arange(len(data)).split(chunk)), strict=True)
            self.cached = torch.cat(inputs), torch.cat(targets)

    def _make(self, index: Tensor) -> tuple[Tensor, Tensor]:
        """Items ``index``: (B, 8, h, w) inputs (uint8 when one-hot) and (B, 4, h, w) target views."""
        if self.unet is None:  # exact in uint8, a quarter of the bytes to keep
            maps = one_hot_maps(self.data.semantics[index].to(self.device), NUM_CLASSES, torch.uint8)
        else:
            maps = input_maps(self.data, index, self.unet, self.device)
        template = one_hot_maps(self.data.templates[self.templates[index]].to(self.device), NUM_CLASSES, maps.dtype)
        with torch.no_grad():
            target = self.warp(self.data.homographies[index].to(self.device))
        return torch.cat([maps, template], dim=1), target

    def warp(self, H: Tensor) -> Tensor:
        """(B, 4, h, w) views of the loss's scene through (B, 3, 3) working-resolution homographies ``H``."""
        return warp_semantic(self.scene, H @ self.frame, self.data.work_size)

    def batch(self, index: Tensor) -> tuple[Tensor, Tensor]:
        """Items ``index``: (B, 8, h, w) float32 inputs (map ⊕ template map) and (B, 4, h, w) target views."""
        if self.cached is None:
            inputs, targets = self._make(index)
        else:
            index = index.to(self.device)
            inputs, targets = self.cached[0][index], self.cached[1][index]
        return inputs.float(), targets
