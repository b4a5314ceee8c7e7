"""Siamese embedding of semantic maps, contrastive loss and dictionary search.

Architecture
------------
``depth`` stages of (conv 3×3 stride 2 → BN → ReLU), channels
``width · 2^stage`` (capped at ``8 · width``); adaptive average pooling to a 4 × 4
grid, which keeps *where* the classes are, flattened; FC → ReLU → FC to
``embedding_dim``; L2 normalisation (on by default), so distances lie in [0, 2].
The same network embeds both members of a pair.

Search
------
:func:`nearest_embeddings` finds each query's nearest dictionary entry with
``‖q − t‖² = ‖q‖² − 2 q·t + ‖t‖²``: one matrix product per chunk of the dictionary
and a running minimum, so a 200,000-entry dictionary is searched without a
Python loop over entries and with ``Q · chunk_size`` floats of scratch memory.

Example
-------
>>> import torch
>>> net = SiameseNet(width=8, embedding_dim=16)
>>> e = net(torch.rand(3, 4, 36, 64))
>>> e.shape, nearest_embeddings(e, e).index.tolist()
(torch.Size([3, 16]), [0, 1, 2])
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from .layers import conv_bn_relu

__all__ = ["SiameseNet", "contrastive_loss", "Nearest", "nearest_embeddings"]


class SiameseNet(nn.Module):
    """Semantic map → embedding vector.

    Args:
        in_channels: channels of the (one-hot or soft) map.
        embedding_dim: length of the embedding.
        width: channels of the first stage.
        depth: number of stride-2 stages.
        normalize: L2-normalise the embeddings.

    Shapes: (B, in_channels, H, W) → (B, embedding_dim).
    """

    def __init__(self, in_channels: int = 4, embedding_dim: int = 128, width: int = 32, depth: int = 4,
                 normalize: bool = True):
        super().__init__()
        stages, channels = [], in_channels
        for stage in range(depth):
            out = width * 2 ** min(stage, 3)
            stages.append(conv_bn_relu(channels, out, 3, stride=2))
            channels = out
        self.features = nn.Sequential(*stages, nn.AdaptiveAvgPool2d((4, 4)), nn.Flatten())
        self.head = nn.Sequential(nn.Linear(channels * 16, 256), nn.ReLU(inplace=True), nn.Linear(256, embedding_dim))
        self.normalize = normalize
        self.embedding_dim = embedding_dim

    def forward(self, x: Tensor) -> Tensor:
        embedding = self.head(self.features(x))
        return F.normalize(embedding, dim=1) if self.normalize else embedding


def contrastive_loss(a: Tensor, b: Tensor, same: Tensor, margin: float = 1.0, reduction: str = "mean") -> Tensor:
    """Contrastive loss (Hadsell, Chopra, LeCun 2006).

    ``same · d² + (1 − same) · max(0, margin − d)²`` with ``d = ‖a − b‖``.

    Args:
        a: (B, D) embeddings.
        b: (B, D) embeddings of the partners.
        same: (B,) bool or 0/1: whether each pair should match.
        margin: distance beyond which dissimilar pairs cost nothing.
        reduction: ``"mean"`` → scalar; ``"none"`` → (B,).
    """
    squared = (a - b).square().sum(dim=1)
    # sqrt has an infinite derivative at 0: keep it away from there for the hinge.
    distance = torch.sqrt(squared + 1e-12)
    same = same.to(squared.dtype)
    loss = same * squared + (1 - same) * torch.relu(margin - distance).square()
    if reduction == "mean":
        return loss.mean()
    if reduction == "none":
        return loss
    raise ValueError(f"reduction must be 'mean' or 'none', got {reduction!r}")


@dataclass(frozen=True)
class Nearest:
    """Result of :func:`nearest_embeddings`: (Q,) int64 ``index`` and (Q,) ``squared_distance``.

    A dataclass, not a NamedTuple: a tuple's field ``index`` would shadow ``tuple.index``.
    """

    index: Tensor
    squared_distance: Tensor


@torch.no_grad()
def nearest_embeddings(queries: Tensor, dictionary: Tensor, chunk_size: int = 16384) -> Nearest:
    """Nearest dictionary entry of each query (Euclidean), by chunked GEMM.

    Args:
        queries: (Q, D) embeddings.
        dictionary: (T, D) embeddings, same dtype and device.
        chunk_size: dictionary rows per matrix product.

    Returns:
        :class:`Nearest`; ties go to the lowest index.
    """
    best = torch.full((queries.shape[0],), float("inf"), dtype=queries.dtype, device=queries.device)
    index = torch.zeros(queries.shape[0], dtype=torch.long, device=queries.device)
    for start in range(0, dictionary.shape[0], chunk_size):
        chunk = dictionary[start:start + chunk_size]
        # ‖t‖² − 2 q·t in one fused GEMM; ‖q‖² does not change the argmin.
        partial = torch.addmm(chunk.square().sum(1), queries, chunk.T, alpha=-2)
        value, position = partial.min(dim=1)
        better = value < best  # strict: an earlier chunk keeps its ties
        best = torch.where(better, value, best)
        index = torch.where(better, position + start, index)
    return Nearest(index, (best + queries.square().sum(1)).clamp_min(0))
