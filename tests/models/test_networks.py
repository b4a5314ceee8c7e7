"""Shapes and initial behaviour of the networks; homography composition; search."""

from __future__ import annotations

import pytest
import torch

from synthcal.models import (
    BaselineSTN,
    LocBlock,
    ProposedSTN,
    SelfAttention2d,
    SiameseNet,
    UNet,
    compose_homography,
    contrastive_loss,
    device_from_name,
    h_bar_matrix,
    nearest_embeddings,
    segmentation_loss,
)
from synthcal.models.stn import IDENTITY_H8, normalization_matrix

SIZES = [(36, 64), (37, 50)]


@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize("size", SIZES)
def test_unet_shapes_and_loss(batch, size):
    net = UNet(width=4, depth=3)
    logits = net(torch.rand(batch, 3, *size))
    assert logits.shape == (batch, 4, *size)
    loss = segmentation_loss(logits, torch.randint(0, 4, (batch, *size)))
    loss.backward()
    assert torch.isfinite(loss) and net.classifier.weight.grad.abs().sum() > 0


@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize("size", SIZES)
def test_siamese_shapes(batch, size):
    net = SiameseNet(width=4, embedding_dim=16).eval()
    emb = net(torch.rand(batch, 4, *size))
    assert emb.shape == (batch, 16)
    torch.testing.assert_close(emb.norm(dim=1), torch.ones(batch))


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize("size", SIZES)
def test_fresh_stn_is_identity(stn_class, batch, size):
    stn = stn_class(width=4, image_size=(size[1], size[0]))
    h = stn(torch.rand(batch, 8, *size))
    assert h.shape == (batch, 8)
    assert torch.equal(h, torch.tensor(IDENTITY_H8).expand(batch, 8))
    g = torch.Generator().manual_seed(0)
    template_H = torch.randn(batch, 3, 3, generator=g, dtype=torch.float64) * 100
    # Exactly the template's homography, bit for bit.
    assert torch.equal(compose_homography(h, template_H, (size[1], size[0])), template_H)


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
def test_stn_trains(stn_class):
    stn = stn_class(width=4, image_size=(64, 36))
    x = torch.rand(2, 8, 36, 64)
    stn(x).square().sum().backward()
    grads = [p.grad for p in stn.parameters() if p.grad is not None]
    assert grads and all(torch.isfinite(g).all() for g in grads)


def test_compose_homography_formula():
    g = torch.Generator().manual_seed(1)
    size = (64, 36)
    h8 = torch.tensor(IDENTITY_H8) + 0.05 * torch.randn(4, 8, generator=g)
    template_H = torch.randn(4, 3, 3, generator=g, dtype=torch.float64)
    N = normalization_matrix(size)
    expected = torch.linalg.inv(N) @ h_bar_matrix(h8.double()) @ N @ template_H
    torch.testing.assert_close(compose_homography(h8, template_H, size), expected)
    # N sends the pixel centres of the corners to ±1.
    corners = torch.tensor([[0.0, 0, 1], [63, 35, 1]], dtype=torch.float64)
    torch.testing.assert_close((N @ corners.T).T[:, :2], torch.tensor([[-1.0, -1], [1, 1]], dtype=torch.float64))


def test_locblock_shapes():
    assert LocBlock(8, 12)(torch.rand(2, 8, 9, 16)).shape == (2, 12, 5, 8)


def _convs(module: torch.nn.Module) -> list[torch.nn.Conv2d]:
    return [m for m in module.modules() if isinstance(m, torch.nn.Conv2d)]


def test_baseline_localisation_has_two_conv_layers():
    stn = BaselineSTN(width=4, image_size=(64, 36))
    convs = _convs(stn)
    assert [(c.in_channels, c.out_channels, c.kernel_size) for c in convs] == [(8, 4, (7, 7)), (4, 8, (5, 5))]
    # Then the FC regressor on the flattened features: 8 channels × ⌈36/8⌉ × ⌈64/8⌉.
    linears = [m for m in stn.head if isinstance(m, torch.nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(8 * 5 * 8, 128), (128, 8)]
    assert not any(isinstance(m, (torch.nn.AdaptiveAvgPool2d, torch.nn.BatchNorm2d)) for m in stn.modules())


def test_proposed_is_three_locblocks_attention_three_fc():
    stn = ProposedSTN(width=4, image_size=(64, 36))
    kinds = [type(m) for m in stn.features]
    assert kinds == [LocBlock, LocBlock, LocBlock, SelfAttention2d]
    # Every convolution belongs to a LocBlock (no stem).
    assert len(_convs(stn)) == sum(len(_convs(block)) for block in stn.features[:3]) == 3 * 3
    linears = [m for m in stn.head if isinstance(m, torch.nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(16 * 5 * 8, 256), (256, 64), (64, 8)]
    assert not any(isinstance(m, torch.nn.AdaptiveAvgPool2d) for m in stn.modules())


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
def test_stn_names_its_image_size(stn_class):
    stn = stn_class(width=4, image_size=(64, 36))
    with pytest.raises(ValueError, match="64 × 36 inputs .* got 50 × 37"):
        stn(torch.rand(1, 8, 37, 50))


def _hand_attention(x: torch.Tensor, attention: SelfAttention2d) -> torch.Tensor:
    """softmax(Q Kᵀ / √d) V per head over the H·W positions, written out."""
    b, c, h, w = x.shape
    heads, d = attention.heads, c // attention.heads
    tokens = x.flatten(2).transpose(1, 2)  # (B, HW, C)
    weight, bias = attention.qkv.weight, attention.qkv.bias
    q, k, v = (tokens @ weight[i * c:(i + 1) * c].T + bias[i * c:(i + 1) * c] for i in range(3))
    outputs = []
    for head in range(heads):
        part = slice(head * d, (head + 1) * d)
        scores = q[..., part] @ k[..., part].transpose(1, 2) / d ** 0.5  # (B, HW, HW)
        outputs.append(scores.softmax(dim=-1) @ v[..., part])
    mixed = attention.out(torch.cat(outputs, dim=-1))
    return attention.norm(tokens + mixed).transpose(1, 2).reshape(b, c, h, w)


@pytest.mark.parametrize("heads", [1, 2])
def test_attention_is_scaled_dot_product_over_positions(heads):
    torch.manual_seed(0)
    attention = SelfAttention2d(8, heads=heads)
    x = torch.randn(2, 8, 5, 7)
    with torch.no_grad():
        torch.testing.assert_close(attention(x), _hand_attention(x, attention))
        # ... and PyTorch's own multi-head attention with the same weights.
        reference = torch.nn.MultiheadAttention(8, heads, batch_first=True)
        reference.in_proj_weight.copy_(attention.qkv.weight)
        reference.in_proj_bias.copy_(attention.qkv.bias)
        reference.out_proj.weight.copy_(attention.out.weight)
        reference.out_proj.bias.copy_(attention.out.bias)
        tokens = x.flatten(2).transpose(1, 2)
        expected = attention.norm(tokens + reference(tokens, tokens, tokens, need_weights=False)[0])
        torch.testing.assert_close(attention(x), expected.transpose(1, 2).reshape(x.shape))
    # Global: a change at one position moves the output at every position.
    y = x.clone()
    y[:, :, 0, 0] += 1.0
    changed = (attention(y) - attention(x)).abs().amax(dim=1) > 1e-6
    assert changed.all()


def test_nearest_embeddings_equal_brute_force():
    g = torch.Generator().manual_seed(2)
    dictionary = torch.randn(1000, 32, generator=g, dtype=torch.float64)
    queries = torch.randn(40, 32, generator=g, dtype=torch.float64)
    queries[:5] = dictionary[[3, 999, 500, 10, 700]]
    dictionary[900] = dictionary[500]  # a tie across chunks: the lower index wins
    result = nearest_embeddings(queries, dictionary, chunk_size=128)
    brute = torch.stack([((dictionary - q) ** 2).sum(1).argmin() for q in queries])
    assert result.index.tolist() == brute.tolist()
    assert result.index[:5].tolist() == [3, 999, 500, 10, 700]
    torch.testing.assert_close(result.squared_distance, torch.cdist(queries, dictionary).square().min(1).values)


def test_contrastive_loss_by_hand():
    a = torch.tensor([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    b = torch.tensor([[0.3, 0.4], [0.3, 0.4], [3.0, 4.0]])
    same = torch.tensor([True, False, False])
    # d = 0.5, 0.5, 5: similar 0.25; dissimilar (1 - 0.5)² = 0.25; beyond margin 0.
    torch.testing.assert_close(contrastive_loss(a, b, same, reduction="none"), torch.tensor([0.25, 0.25, 0.0]))
    x = torch.zeros(1, 2, requires_grad=True)
    contrastive_loss(x, torch.zeros(1, 2), torch.tensor([False])).backward()
    assert torch.isfinite(x.grad).all()


def test_device_from_name():
    assert device_from_name("cpu") == torch.device("cpu")
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert device_from_name("auto").type == expected
    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError):
            device_from_name("cuda")


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
def test_stn_convolutions_read_contiguous_memory(stn_class):
    """One-hot maps come in channels-last memory, which crashed LocBlock backward passes
    in torch's CPU convolutions (stn.py, ``_checked_input``): the STN hands on a contiguous copy."""
    stn = stn_class(width=4, image_size=(64, 36))
    seen = []
    stn.features[0].register_forward_pre_hook(lambda _, args: seen.append(args[0].is_contiguous()))
    x = torch.rand(2, 36, 64, 8).permute(0, 3, 1, 2)  # channels-last, as cat(one_hot_maps(...)) gives
    assert not x.is_contiguous()
    stn(x).sum().backward()
    assert seen == [True]


def test_weighted_segmentation_loss_is_the_weighted_mean_of_pixel_losses():
    torch.manual_seed(0)
    logits, target = torch.randn(2, 4, 3, 5), torch.randint(0, 4, (2, 3, 5))
    weights = torch.tensor([0.1, 1.0, 2.0, 4.0])
    # By hand: each pixel's -log p(true class), weighted by its class, over the sum of the weights.
    nll = -logits.log_softmax(1).gather(1, target[:, None])[:, 0]
    expected = (weights[target] * nll).sum() / weights[target].sum()
    torch.testing.assert_close(segmentation_loss(logits, target, weights), expected)
    torch.testing.assert_close(segmentation_loss(logits, target), nll.mean())
