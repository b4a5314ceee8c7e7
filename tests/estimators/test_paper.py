"""The paper's models as estimators: fit/predict on a smoke store, shared-stage cache,
working resolution, the scaled end-to-end schedule."""

from pathlib import Path

import numpy as np
import pytest
import torch

from synthcal.config import load_config
from synthcal.data import load_splits
from synthcal.estimators import SemanticEstimator, load_estimator
from synthcal.estimators.paper import BaselineEstimator, PaperEstimator, ProposedEstimator
from synthcal.generate.render import render_semantic
from synthcal.generate.splits import draw_splits
from synthcal.models import end_to_end_weights, match_ground_truth, nearest_embeddings, one_hot_maps, warp_semantic
from synthcal.training import (
    StageCache,
    end_to_end_stage,
    reduce_class_maps,
    reduce_scene,
    resolution_matrix,
)

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def splits(smoke_stores, tmp_path_factory):
    store = smoke_stores.copy(["intersection-1"], tmp_path_factory.mktemp("paper"))["intersection-1"]
    draw_splits(store, seeds=[0])
    return load_splits(store, 0)


@pytest.fixture(scope="module")
def settings():
    return load_config(ROOT / "datasets.yaml").training("smoke").settings()


def fit(splits, settings, **options):
    estimator = load_estimator(options.pop("name", "proposed"), settings=settings, device="cpu", **options)
    estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene)
    return estimator


@pytest.mark.parametrize("name", ["proposed", "baseline"])
@pytest.mark.parametrize("training", ["step-by-step", "end-to-end"])
@pytest.mark.parametrize("segmentation", ["unet", "ground-truth"])
def test_fits_and_predicts_finite_homographies(splits, settings, name, training, segmentation):
    estimator = fit(splits, settings, name=name, training=training, segmentation=segmentation, loss="top-dice",
                    matching="mse")
    test = splits["test"]
    H = estimator.predict_semantic(test.semantics)
    assert H.shape == (len(test), 3, 3) and H.dtype == np.float64 and np.isfinite(H).all()
    if segmentation == "unet":
        H = estimator.predict(test.images)
        assert H.shape == (len(test), 3, 3) and np.isfinite(H).all()
    else:
        with pytest.raises(RuntimeError, match="predict_semantic"):
            estimator.predict(test.images)
    assert all(np.isfinite(v).all() and v for v in estimator.history.values())


def test_bundled_names_and_labels():
    assert isinstance(load_estimator("proposed"), ProposedEstimator)
    baseline = load_estimator("sha2020", loss="mse")
    assert isinstance(baseline, BaselineEstimator) and baseline.model == "baseline" and baseline.loss == "mse"
    assert ProposedEstimator.label == "proposed" and BaselineEstimator.label == "sha2020"
    assert isinstance(load_estimator("baseline"), SemanticEstimator)
    with pytest.raises(ValueError, match="loss"):
        PaperEstimator(loss="l1")


def test_shared_stages_are_trained_once_and_reused(splits, settings, tmp_path):
    first = fit(splits, settings, segmentation="unet", cache_dir=tmp_path)
    assert first.trained_stages == ["unet", "siamese", "stn"]
    files = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*.pt")}
    # The dictionary's embedding by the trained Siamese is cached beside the stages (once per pair).
    assert {p.parent.name for p in files} == {"match", "unet", "siamese", "embedding"}

    second = fit(splits, settings, name="baseline", segmentation="unet", loss="mse", cache_dir=tmp_path)
    assert second.trained_stages == ["stn"]  # same UNet and Siamese, another STN
    assert {p: p.stat().st_mtime_ns for p in files} == files

    third = fit(splits, settings, segmentation="unet", matching="mse", cache_dir=tmp_path)
    assert third.trained_stages == ["siamese", "stn"]  # another matching score: a new Siamese only
    np.testing.assert_array_equal(first.predict_semantic(splits["test"].semantics),
                                  fit(splits, settings, segmentation="unet", cache_dir=tmp_path)
                                  .predict_semantic(splits["test"].semantics))


def test_same_seed_same_estimates(splits, settings):
    a = fit(splits, settings, segmentation="ground-truth").predict_semantic(splits["test"].semantics)
    b = fit(splits, settings, segmentation="ground-truth").predict_semantic(splits["test"].semantics)
    np.testing.assert_array_equal(a, b)


def test_working_resolution_is_the_full_view_reduced(splits):
    """``A H`` renders, at half size, the area-reduced full-size view."""
    scene, H = splits["train"].scene.semantic, splits["train"].homographies[:6]
    full = np.stack([render_semantic(scene, h, (64, 36)) for h in H])
    half = np.stack([render_semantic(scene, resolution_matrix((64, 36), (32, 18)) @ h, (32, 18)) for h in H])
    agree = (reduce_class_maps(full, (32, 18)).numpy() == half).mean()
    assert agree > 0.9


def test_reduced_scene_renders_the_same_views_softly(splits):
    semantic = splits["train"].scene.semantic
    scene, frame = reduce_scene(semantic, 4)
    assert scene.shape[0] == 4 and torch.allclose(scene.sum(0), torch.ones(scene.shape[1:]))
    H = torch.from_numpy(splits["train"].homographies[:4])
    sharp = warp_semantic(one_hot_maps(torch.from_numpy(semantic)), H, (64, 36))
    soft = warp_semantic(scene, H @ frame, (64, 36))
    assert (sharp.argmax(1) == soft.argmax(1)).float().mean() > 0.8


def test_end_to_end_schedule_scales_the_warm_up():
    def phases(epochs, with_unet=True):
        n = epochs - (0 if with_unet else max(1, round(0.2 * epochs)))
        return [end_to_end_weights(end_to_end_stage(e, epochs, with_unet)) for e in range(n)]
    assert phases(100) == [end_to_end_weights(e) for e in range(100)]  # the paper's own schedule
    assert phases(5) == [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)] + [(0.05, 0.05, 0.9)] * 3
    assert phases(3) == [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.05, 0.05, 0.9)]
    assert phases(10, with_unet=False) == [(0.0, 1.0, 0.0)] * 2 + [(0.05, 0.05, 0.9)] * 6


def test_profiles_training_blocks_validate(tmp_path):
    from synthcal.config import ConfigError

    config = load_config(ROOT / "datasets.yaml")
    for profile in ("smoke", "demo", "quick", "paper"):
        assert config.training(profile).end_to_end_epochs >= 3
    assert config.training("quick").segmentation == "ground-truth" and config.training("paper").segmentation == "unet"
    text = (ROOT / "datasets.yaml").read_text().replace("      stn_epochs: 1\n", "      stn_epochs: 0\n", 1)
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(ConfigError, match=r"profiles\.smoke\.training\.stn_epochs"):
        load_config(tmp_path / "bad.yaml")


def test_stage_cache_trains_a_stage_once_when_two_callers_need_it_at_once(tmp_path):
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    cache = StageCache(tmp_path)
    builds: list[int] = []
    both_asked = threading.Barrier(2)

    def build() -> dict[str, torch.Tensor]:
        builds.append(threading.get_ident())
        time.sleep(0.3)  # long enough for the other caller to arrive while this one trains
        return {"weight": torch.arange(3.0)}

    def ask(_: int) -> tuple[dict, bool]:
        both_asked.wait()
        return cache.cached("unet", "key", build)

    with ThreadPoolExecutor(2) as pool:
        results = list(pool.map(ask, range(2)))
    assert len(builds) == 1
    assert sorted(trained for _, trained in results) == [False, True]
    for state, _ in results:
        torch.testing.assert_close(state["weight"], torch.arange(3.0))


class _Recording(torch.nn.Module):
    """Wraps an STN and keeps every (input map, template) pair it reads, as class ids."""

    def __init__(self, stn: torch.nn.Module, pairs: set[tuple[bytes, bytes]]):
        super().__init__()
        self.stn, self.pairs = stn, pairs

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.training:
            for item in x.detach():
                self.pairs.add((item[:4].argmax(0).to(torch.uint8).numpy().tobytes(),
                                item[4:].argmax(0).to(torch.uint8).numpy().tobytes()))
        return self.stn(x)


@pytest.mark.parametrize("stn_template", ["retrieved", "ground-truth"])
def test_step_by_step_stn_reads_the_retrieved_template_by_default(splits, settings, stn_template, monkeypatch):
    pairs: set[tuple[bytes, bytes]] = set()
    build = PaperEstimator._stn
    monkeypatch.setattr(PaperEstimator, "_stn", lambda self, size: _Recording(build(self, size), pairs))
    options = {} if stn_template == "retrieved" else {"stn_template": stn_template}
    estimator = fit(splits, {**settings, **options}, segmentation="ground-truth")
    # What the trained Siamese retrieves for each train map, and the ground truth (L_Top-MSE, sum).
    maps, templates = splits["train"].semantics, splits["dictionary"].semantics
    f = estimator._fitted
    with torch.no_grad():
        embedded = f["siamese"](one_hot_maps(torch.from_numpy(np.asarray(maps))))
    retrieved = nearest_embeddings(embedded, f["embedding"]).index.numpy()
    truth = match_ground_truth(torch.from_numpy(np.asarray(maps)), torch.from_numpy(np.asarray(templates)),
                               "top_mse").index.numpy()
    assert (retrieved != truth).mean() > 0.2  # the premise: retrieval is not the ground truth
    chosen = retrieved if stn_template == "retrieved" else truth
    expected = {(m.tobytes(), templates[k].tobytes()) for m, k in zip(np.asarray(maps), chosen, strict=True)}
    assert pairs == expected


def test_protocol_settings_and_the_stage_cache(splits, settings, tmp_path):
    first = fit(splits, settings, segmentation="ground-truth", cache_dir=tmp_path)
    assert first.trained_stages == ["siamese", "stn"]
    # The STN's template changes no shared stage: only the STN trains again.
    other = fit(splits, {**settings, "stn_template": "ground-truth"}, segmentation="ground-truth", cache_dir=tmp_path)
    assert other.trained_stages == ["stn"]
    # The class reduction changes the ground-truth matches (their own cache entry), and the
    # Siamese trained on them exactly when they differ.
    mean = fit(splits, {**settings, "class_reduction": "mean"}, segmentation="ground-truth", cache_dir=tmp_path)
    assert len(list((tmp_path / "match").glob("*.pt"))) == 2
    maps = torch.from_numpy(np.asarray(splits["train"].semantics))
    templates = torch.from_numpy(np.asarray(splits["dictionary"].semantics))
    differ = not torch.equal(*(match_ground_truth(maps, templates, "top_mse", class_reduction=r).index
                               for r in ("sum", "mean")))
    assert mean.trained_stages == (["siamese", "stn"] if differ else ["stn"])
    with pytest.raises(ValueError, match="stn_template"):
        PaperEstimator(settings={**settings, "stn_template": "best"})


def test_vocabularies_agree_with_the_models():
    from synthcal import config, models

    assert config.STN_TEMPLATES == models.STN_TEMPLATES
    assert config.CLASS_REDUCTIONS == models.CLASS_REDUCTIONS
    assert config.TrainingSettings().class_reduction == models.CLASS_REDUCTION


def test_ccbv_and_batch_norm_variants_fit_predict_and_label_their_rows(splits, settings):
    from synthcal.estimators.paper import CcbvEstimator
    from synthcal.eval.runs import estimator_label

    ccbv = fit(splits, settings, name="synthcal.estimators.paper:CcbvEstimator", segmentation="ground-truth")
    assert isinstance(ccbv, CcbvEstimator) and ccbv.label == "sha2020-ccbv"
    assert np.isfinite(ccbv.predict_semantic(splits["test"].semantics)).all()
    bn = fit(splits, {**settings, "batch_norm": True}, name="baseline", segmentation="ground-truth")
    assert any(isinstance(m, torch.nn.BatchNorm2d) for m in bn._fitted["stn"].modules())
    # The run's table label (fixed before any instance exists) is the instance's.
    assert estimator_label("baseline", BaselineEstimator, {**settings, "batch_norm": True}) == bn.label == "sha2020+bn"
    assert estimator_label("proposed", ProposedEstimator, {**settings, "batch_norm": False}) == "proposed+no-bn"
    assert estimator_label("proposed", ProposedEstimator, {**settings, "batch_norm": True}) == "proposed"
    assert estimator_label("x:Y", CcbvEstimator, settings) == "sha2020-ccbv"


def test_retrieved_returns_dictionary_homographies_and_reuses_the_cached_siamese(splits, settings, tmp_path):
    from synthcal.estimators.diagnostic import RetrievedEstimator

    proposed = fit(splits, settings, segmentation="ground-truth", cache_dir=tmp_path)
    assert proposed.trained_stages == ["siamese", "stn"]
    files = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*.pt")}
    retrieved = fit(splits, settings, name="synthcal.estimators.diagnostic:RetrievedEstimator",
                    segmentation="ground-truth", cache_dir=tmp_path)
    assert isinstance(retrieved, RetrievedEstimator) and retrieved.label == "retrieved"
    assert retrieved.trained_stages == [] and retrieved.history == {}  # no Siamese trained, no STN
    assert {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*.pt")} == files
    for name, value in proposed._fitted["siamese"].state_dict().items():
        torch.testing.assert_close(retrieved._fitted["siamese"].state_dict()[name], value, rtol=0, atol=0)

    test = splits["test"]
    H = retrieved.predict_semantic(test.semantics)
    dictionary = np.asarray(splits["dictionary"].homographies)
    # Each estimate is exactly the homography of the template the proposed model's Siamese retrieves.
    f = proposed._fitted
    with torch.no_grad():
        embedded = f["siamese"](one_hot_maps(torch.from_numpy(reduce_class_maps(
            np.asarray(test.semantics), f["work_size"]).numpy())))
    index = nearest_embeddings(embedded, f["embedding"]).index.numpy()
    np.testing.assert_array_equal(H, dictionary[index])
