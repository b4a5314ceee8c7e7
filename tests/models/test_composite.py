"""The composite model: shapes, the epoch schedule, and where gradients go."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from synthcal.generate.camera import homography
from synthcal.generate.render import render_semantic
from synthcal.models import (
    BaselineSTN,
    CompositeModel,
    ProposedSTN,
    SiameseNet,
    UNet,
    end_to_end_weights,
)

IMAGE = (64, 36)


@pytest.fixture(scope="module")
def data() -> dict[str, torch.Tensor]:
    rng = np.random.default_rng(0)
    scene = np.kron(rng.integers(0, 4, (10, 15)), np.ones((20, 20), np.int64)).astype(np.uint8)  # 200 × 300
    n = 6
    Hs = homography(rng.uniform(-180, 180, n), rng.uniform(-50, -20, n), rng.uniform(30, 60, n),
                    np.stack([rng.uniform(80, 220, n), rng.uniform(60, 140, n), rng.uniform(30, 60, n)], 1), IMAGE)
    semantic = np.stack([render_semantic(scene, H, IMAGE) for H in Hs])
    return {
        "scene": torch.from_numpy(scene),
        "dictionary": torch.from_numpy(semantic),
        "homography": torch.from_numpy(Hs),
        "images": torch.rand(3, 3, IMAGE[1], IMAGE[0], generator=torch.Generator().manual_seed(0)),
        "semantic": torch.from_numpy(semantic[[1, 4, 2]]).long(),
        "match": torch.tensor([1, 4, 2]),
    }


def _model(data, stn_class=ProposedSTN, **options) -> CompositeModel:
    torch.manual_seed(0)
    return CompositeModel(UNet(width=4, depth=2), SiameseNet(width=4, embedding_dim=8, depth=3),
                          stn_class(width=4, image_size=IMAGE), data["scene"], data["dictionary"], data["homography"],
                          **options)


def test_end_to_end_weights_schedule():
    assert [end_to_end_weights(e) for e in (0, 19)] == [(1.0, 0.0, 0.0)] * 2
    assert [end_to_end_weights(e) for e in (20, 39)] == [(0.0, 1.0, 0.0)] * 2
    assert [end_to_end_weights(e) for e in (40, 100)] == [(0.05, 0.05, 0.9)] * 2


@pytest.mark.parametrize("stn_class", [BaselineSTN, ProposedSTN])
@pytest.mark.parametrize("batch", [1, 3])
def test_forward_shapes_and_fresh_stn(data, stn_class, batch):
    model = _model(data, stn_class)
    out = model(data["images"][:batch])
    assert out.logits.shape == out.probabilities.shape == out.warped.shape == (batch, 4, IMAGE[1], IMAGE[0])
    assert out.embedding.shape == (batch, 8) and out.h_bar.shape == (batch, 8)
    assert out.match_index.shape == (batch,) and out.homography.dtype == torch.float64
    # A fresh STN returns the retrieved template's homography exactly.
    assert torch.equal(out.homography, data["homography"][out.match_index])
    assert model.dictionary_embedding.shape == (6, 8)
    forced = model(data["images"][:batch], match_index=data["match"][:batch])
    assert torch.equal(forced.match_index, data["match"][:batch])


def _grad_norm(module: torch.nn.Module) -> float:
    return sum(float(p.grad.abs().sum()) for p in module.parameters() if p.grad is not None)


@pytest.mark.parametrize("epoch, terms", [(0, {"ce"}), (25, {"con"}), (45, {"ce", "con", "warp"})])
def test_training_loss_terms(data, epoch, terms):
    model = _model(data)
    loss, parts = model.training_loss(data["images"], data["semantic"], data["match"], epoch,
                                      target_homography=data["homography"][data["match"]])
    assert set(parts) == terms and torch.isfinite(loss)
    loss.backward()
    assert _grad_norm(model.unet) > 0
    assert (_grad_norm(model.siamese) > 0) == ("con" in terms)
    assert (_grad_norm(model.stn) > 0) == ("warp" in terms)


def test_warp_loss_reaches_unet_through_stn(data):
    model = _model(data)
    with torch.no_grad():  # a trained STN's last layer is no longer zero
        model.stn.head[-1].weight.normal_(0, 1e-3)
    out = model(data["images"], match_index=data["match"])
    target = torch.nn.functional.one_hot(data["semantic"], 4).permute(0, 3, 1, 2).float()
    model.warp_loss(out.warped, target).backward()
    assert _grad_norm(model.unet) > 0
    assert all(p.grad is None or p.grad.abs().sum() == 0 for p in model.siamese.parameters())


def test_scene_as_class_ids_or_as_float_maps(data):
    ids = _model(data)
    soft = torch.nn.functional.one_hot(data["scene"].long(), 4).movedim(-1, 0).float() * 0.5
    maps = CompositeModel(ids.unet, ids.siamese, ids.stn, soft, data["dictionary"], data["homography"])
    torch.testing.assert_close(maps.scene, ids.scene * 0.5)  # float maps are taken as they are
    with pytest.raises(ValueError, match=r"scene: expected .* got shape \(3, "):
        CompositeModel(ids.unet, ids.siamese, ids.stn, soft[:3], data["dictionary"], data["homography"])


class _MeanClasses(torch.nn.Module):
    """A stand-in Siamese whose retrieval is easy to compute by hand: the class shares of a map."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.mean(dim=(2, 3))


class _Recording(torch.nn.Module):
    """Wraps an STN and keeps the template half of every input it reads."""

    def __init__(self, stn: torch.nn.Module):
        super().__init__()
        self.stn, self.templates = stn, []

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        self.templates.append(x[:, 4:].detach().clone())
        return self.stn(x)


@pytest.mark.parametrize("stn_template", ["retrieved", "ground-truth"])
def test_stn_reads_the_retrieved_template_by_default(data, stn_template):
    options = {} if stn_template == "retrieved" else {"stn_template": stn_template}
    model = _model(data, **options)
    model.siamese = _MeanClasses()
    model.stn = _Recording(model.stn)
    # What the stand-in retrieves, by hand; the "true" matches are made to differ from it.
    with torch.no_grad():
        shares = model.unet(data["images"]).softmax(1).mean(dim=(2, 3))
    dictionary = torch.nn.functional.one_hot(data["dictionary"].long(), 4).float().mean(dim=(1, 2))
    retrieved = torch.cdist(shares, dictionary).argmin(dim=1)
    truth = (retrieved + 1) % len(dictionary)
    _, terms = model.training_loss(data["images"], data["semantic"], truth, 45,
                                   target_homography=data["homography"][truth])
    assert "warp" in terms and len(model.stn.templates) == 1
    expected = retrieved if stn_template == "retrieved" else truth
    onehot = torch.nn.functional.one_hot(data["dictionary"][expected].long(), 4).permute(0, 3, 1, 2).float()
    assert torch.equal(model.stn.templates[0], onehot)


def test_warp_loss_compares_like_with_like(data):
    """L_warp's target is the scene rendered by the same renderer: the true H costs exactly 0."""
    model = _model(data, stn_template="ground-truth", warp_loss_name="mse")
    # A fresh STN returns the template's H; make the true homographies exactly those.
    _, terms = model.training_loss(data["images"], data["semantic"], data["match"], 45,
                                   target_homography=data["homography"][data["match"]])
    assert terms["warp"] == 0.0
    _, terms = model.training_loss(data["images"], data["semantic"], data["match"], 45,
                                   target_homography=data["homography"][(data["match"] + 1) % 6])
    assert terms["warp"] > 0.01


def test_class_weights_weigh_the_segmentation_term(data):
    weights = torch.tensor([0.2, 1.0, 1.0, 5.0])
    plain, weighted = _model(data), _model(data, class_weights=weights)
    logits = plain.unet(data["images"])  # the same initial UNet in both
    for model, expected in ((plain, F.cross_entropy(logits, data["semantic"])),
                            (weighted, F.cross_entropy(logits, data["semantic"], weight=weights))):
        _, parts = model.training_loss(data["images"], data["semantic"], data["match"], 0,
                                       target_homography=data["homography"][data["match"]])
        assert parts["ce"] == pytest.approx(expected.item(), rel=1e-5)
