"""The STN stage's once-per-fit inputs and target views (issue 22) train exactly as a
straightforward loop that makes them afresh in every batch."""

import copy
import dataclasses

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from synthcal.generate.camera import homography
from synthcal.models import (
    BaselineSTN,
    ProposedSTN,
    SiameseNet,
    UNet,
    compose_homography,
    top_mse_loss,
    warp_semantic,
)
from synthcal.training import TrainingData, examples, reduce_scene, stages, train_siamese, train_stn

SIZE = (32, 18)
SEED, EPOCHS, BATCH, LR = 3, 3, 4, 1e-3  # 10 items: batches of 4, 4 and 2


def cameras(n: int, rng: np.random.Generator) -> torch.Tensor:
    """(n, 3, 3) float64 homographies of cameras looking down at a 160 × 240 scene."""
    centres = np.stack([rng.uniform(60, 100, n), rng.uniform(80, 160, n), rng.uniform(30, 50, n)], 1)
    return torch.from_numpy(homography(rng.uniform(-180, 180, n), rng.uniform(-60, -30, n),
                                       rng.uniform(20, 30, n), centres, SIZE))


@pytest.fixture(scope="module")
def data() -> TrainingData:
    rng = np.random.default_rng(0)
    scene_ids = np.kron(rng.integers(0, 4, (12, 8)), np.ones((20, 20), np.int64)).astype(np.uint8)  # 240 × 160
    scene, frame = reduce_scene(scene_ids, 4)
    n, t = 10, 5
    ids = torch.from_numpy(rng.integers(0, 4, (n + t, SIZE[1], SIZE[0]), dtype=np.uint8))
    return TrainingData(images=torch.from_numpy(rng.integers(0, 256, (n, 3, SIZE[1], SIZE[0]), dtype=np.uint8)),
                        semantics=ids[:n], homographies=cameras(n, rng), match=torch.from_numpy(rng.integers(0, t, n)),
                        templates=ids[n:], template_homographies=cameras(t, rng), scene=scene, scene_frame=frame,
                        work_size=SIZE)


def one_hot(ids: torch.Tensor) -> torch.Tensor:
    return F.one_hot(ids.long(), 4).permute(0, 3, 1, 2).float()


def reference(stn: torch.nn.Module, data: TrainingData, templates: torch.Tensor, unet: torch.nn.Module | None):
    """Per-epoch mean losses and the trained weights of a plain loop: every input and
    target view made again in every batch, from the data and SPEC §7's loss alone."""
    torch.manual_seed(SEED)
    generator = torch.Generator().manual_seed(SEED)
    optimiser = torch.optim.Adam(stn.parameters(), lr=LR)
    log = []
    for _ in range(EPOCHS):
        losses = []
        for index in torch.randperm(len(data), generator=generator).split(BATCH):
            if unet is None:
                maps = one_hot(data.semantics[index])
            else:
                with torch.no_grad():
                    maps = unet(data.images[index].float() / 255).softmax(1)
            template = templates[index]
            x = torch.cat([maps, one_hot(data.templates[template])], dim=1)
            H = compose_homography(stn(x), data.template_homographies[template], SIZE)
            target = warp_semantic(data.scene, data.homographies[index] @ data.scene_frame, SIZE)
            loss = top_mse_loss(warp_semantic(data.scene, H @ data.scene_frame, SIZE), target, class_reduction="sum")
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            losses.append(loss.item())
        log.append(float(np.mean(losses)))
    return log, stn.state_dict()


def trained(stn: torch.nn.Module, data: TrainingData, templates: torch.Tensor, unet: torch.nn.Module | None):
    log: list[float] = []
    stn = train_stn(stn, data, unet, "top-mse", EPOCHS, BATCH, LR, torch.device("cpu"), seed=SEED, log=log,
                    templates=templates, class_reduction="sum")
    return log, stn.state_dict()


@pytest.mark.parametrize("cache_bytes", [examples.MAP_CACHE_BYTES, 0], ids=["once-per-fit", "per-batch"])
@pytest.mark.parametrize("network", [BaselineSTN, ProposedSTN])
def test_stn_training_equals_the_plain_loop_on_true_maps(data, network, cache_bytes, monkeypatch):
    monkeypatch.setattr(examples, "MAP_CACHE_BYTES", cache_bytes)
    assert (examples.StnExamples(data, data.match, None, torch.device("cpu")).cached is None) == (cache_bytes == 0)
    torch.manual_seed(0)
    initial = network(8, image_size=SIZE, width=4)
    templates = torch.roll(data.match, 1)  # not the ground truth: the chosen ones must be the ones read
    ours, expected = trained(copy.deepcopy(initial), data, templates, None), reference(initial, data, templates, None)
    assert ours[0] == expected[0] and len(ours[0]) == EPOCHS
    assert expected[0][-1] != expected[0][0]  # it trained
    for name, weight in expected[1].items():
        assert torch.equal(ours[1][name], weight), name


def test_stn_training_on_frozen_unet_maps_matches_the_plain_loop(data):
    torch.manual_seed(1)
    unet = UNet(width=2, depth=1).eval()
    initial = BaselineSTN(8, image_size=SIZE, width=4)
    ours, expected = trained(copy.deepcopy(initial), data, data.match, unet), reference(initial, data, data.match, unet)
    # The UNet sees chunks of 256 items once instead of batches of 4: equal up to float associativity.
    np.testing.assert_allclose(ours[0], expected[0], rtol=1e-5)
    for name, weight in expected[1].items():
        torch.testing.assert_close(ours[1][name], weight, rtol=1e-4, atol=1e-6, msg=name)


def test_cached_examples_are_the_batches_made_afresh(data):
    made = examples.StnExamples(data, data.match, None, torch.device("cpu"))
    index = torch.tensor([7, 2, 2, 9])
    inputs, targets = made.batch(index)
    assert inputs.dtype == targets.dtype == torch.float32
    assert (targets.sum(1) > 0.5).float().mean() > 0.5  # the cameras see the scene
    torch.testing.assert_close(inputs, torch.cat([one_hot(data.semantics[index]),
                                                  one_hot(data.templates[data.match[index]])], 1), rtol=0, atol=0)
    torch.testing.assert_close(targets, warp_semantic(data.scene, data.homographies[index] @ data.scene_frame, SIZE),
                               rtol=0, atol=0)


def test_examples_are_kept_in_half_the_free_memory_of_a_gpu(monkeypatch):
    # No GPU needed: the rule reads only what the device reports free.
    monkeypatch.setattr(torch.cuda, "mem_get_info", lambda device=None: (10 * 2**30, 80 * 2**30))
    assert examples.map_cache_bytes(torch.device("cuda")) == 5 * 2**30
    assert examples.map_cache_bytes(torch.device("cpu")) == examples.MAP_CACHE_BYTES


def test_siamese_on_frozen_unet_maps_kept_matches_the_unet_rerun_per_batch(data, monkeypatch):
    torch.manual_seed(2)
    unet = UNet(width=2, depth=1).eval()
    initial = SiameseNet(4, embedding_dim=8, width=4)
    fits = {}
    for kept, cap in (("kept", examples.MAP_CACHE_BYTES), ("per-batch", 0)):
        monkeypatch.setattr(examples, "MAP_CACHE_BYTES", cap)
        assert (examples.with_unet_maps(data, unet, torch.device("cpu")).unet_maps is None) == (cap == 0)
        log: list[float] = []
        siamese = train_siamese(copy.deepcopy(initial), data, unet, EPOCHS, BATCH, LR, torch.device("cpu"),
                                seed=SEED, log=log)
        fits[kept] = log, siamese.state_dict()
    np.testing.assert_allclose(fits["kept"][0], fits["per-batch"][0], rtol=1e-5)
    assert fits["per-batch"][0][-1] != fits["per-batch"][0][0]  # it trained
    for name, weight in fits["per-batch"][1].items():
        torch.testing.assert_close(fits["kept"][1][name], weight, rtol=1e-4, atol=1e-6)


def test_unet_early_stopping_keeps_the_best_epochs_weights(data):
    # Scores 3, 1, 2, 2 with patience 2: the fourth epoch is the second without a better score, so
    # training stops there and returns the second epoch's weights — a plain 2-epoch run's, bit for bit.
    designed = iter([3.0, 1.0, 2.0, 2.0, 0.5, 0.5])
    scores: list[float] = []
    torch.manual_seed(4)
    initial = UNet(width=2, depth=1)
    log: list[float] = []
    stopped = stages.train_unet(copy.deepcopy(initial), data, 6, BATCH, LR, torch.device("cpu"), seed=SEED, log=log,
                                validate=lambda unet: next(designed), patience=2, scores=scores)
    assert scores == [3.0, 1.0, 2.0, 2.0] and len(log) == 4
    two = stages.train_unet(copy.deepcopy(initial), data, 2, BATCH, LR, torch.device("cpu"), seed=SEED)
    four = stages.train_unet(copy.deepcopy(initial), data, 4, BATCH, LR, torch.device("cpu"), seed=SEED)
    for name, weight in two.state_dict().items():
        assert torch.equal(stopped.state_dict()[name], weight), name
    assert any(not torch.equal(four.state_dict()[n], w) for n, w in two.state_dict().items())  # it moved on


def test_segmentation_validation_loss_is_the_item_weighted_cross_entropy(data):
    torch.manual_seed(5)
    unet = UNet(width=2, depth=1).train()
    expected = F.cross_entropy(unet.eval()(data.images.float() / 255.0), data.semantics.long()).item()
    unet.train()
    assert stages.segmentation_validation_loss(unet, data, batch_size=3) == pytest.approx(expected, rel=1e-5)
    assert unet.training  # back in the mode it came in


def test_segmentation_class_iou_is_sklearns_jaccard_over_pooled_pixels(data):
    from sklearn.metrics import jaccard_score

    torch.manual_seed(5)
    unet = UNet(width=2, depth=1).train()
    predicted = unet.eval()(data.images.float() / 255.0).argmax(1)
    unet.train()
    iou = stages.segmentation_class_iou(unet, data, batch_size=3)
    expected = jaccard_score(data.semantics.flatten().numpy(), predicted.flatten().numpy(), labels=[0, 1, 2, 3],
                             average=None)  # every class is in the random true maps
    np.testing.assert_allclose(iou.numpy(), expected, rtol=1e-12)
    assert unet.training  # back in the mode it came in


def test_a_class_in_neither_map_has_no_iou(data):
    class Always(torch.nn.Module):  # every pixel class 0; the true maps below hold no class 3
        def __init__(self) -> None:
            super().__init__()
            self.logits = torch.nn.Parameter(torch.tensor([1.0, 0.0, 0.0, 0.0]))

        def forward(self, images: torch.Tensor) -> torch.Tensor:
            return self.logits.view(1, 4, 1, 1).expand(len(images), 4, *images.shape[2:])

    no_three = dataclasses.replace(data, semantics=data.semantics.clamp(max=2))
    iou = stages.segmentation_class_iou(Always(), no_three)
    assert torch.isnan(iou[3]) and iou[1] == 0 and iou[2] == 0
    assert iou[0] == pytest.approx((no_three.semantics == 0).float().mean().item())
