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
    stn = stn_class(width=4)
    h = stn(torch.rand(batch, 8, *size))
    assert h.shape == (batch, 8)
    assert torch.equal(h, torch.tensor(IDENTITY_H8).expand(batch, 8))
    g = torch.Generator().manual_seed(0)
    template_H = torch.randn(batch, 3, 3, generator=g, dtype=torch.float64) * 100
    # Exactly the template's homography, bit for bit.
    assert torch.equal(compose_homography(h, template_H, (size[1], size[0])), template_H)


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
def test_stn_trains(stn_class):
    stn = stn_class(width=4)
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


def test_locblock_and_attention_shapes():
    x = torch.rand(2, 8, 9, 16)
    assert LocBlock(8, 12)(x).shape == (2, 12, 5, 8)
    attention = SelfAttention2d(8, reduction=4)
    assert torch.equal(attention(x), x)  # γ = 0: the identity at initialisation
    with torch.no_grad():
        attention.gamma.fill_(1.0)
    assert attention(x).shape == x.shape and not torch.equal(attention(x), x)


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
