"""Training choices read the validation split only: early stopping, learning-rate selection, the
shared Siamese per rate, and a harness run whose test split is noise trains exactly the same."""

import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
import zarr

from synthcal.config import load_config
from synthcal.data import load_split, load_splits
from synthcal.estimators import load_estimator
from synthcal.estimators.paper import MissedClassWarning
from synthcal.eval.harness import collect_results, execute_run, expand_runs, read_record, run_folder, table_runs
from synthcal.eval.runs import training_budget
from synthcal.eval.tables import format_table
from synthcal.generate.splits import draw_splits
from synthcal.models import UNet
from synthcal.store import read_split_indices, write_manifest
from synthcal.training import best_epoch, segmentation_class_iou, segmentation_validation_loss

ROOT = Path(__file__).resolve().parents[2]
RATES = [1e-4, 3e-3]


@pytest.fixture(scope="module")
def store(smoke_stores, tmp_path_factory) -> Path:
    path = smoke_stores.copy(["intersection-1"], tmp_path_factory.mktemp("select"))["intersection-1"]
    draw_splits(path, seeds=[0])
    return path


@pytest.fixture(scope="module")
def splits(store):
    return {**load_splits(store, 0), "validation": load_split(store, "validation", 0)}


@pytest.fixture(scope="module")
def settings():
    return {**load_config(ROOT / "datasets.yaml").training("smoke").settings(), "stn_epochs": 4}


def fit(splits, settings, name="proposed", **options):
    estimator = load_estimator(name, settings=settings, device="cpu", segmentation="ground-truth", **options)
    estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    return estimator


def test_the_best_rate_on_validation_is_kept_and_each_siamese_is_trained_once(splits, settings, tmp_path):
    grid = {**settings, "select": {"learning_rate": RATES}}
    proposed = fit(splits, grid, cache_dir=tmp_path)
    selection = proposed.selection
    assert selection["split"] == "validation" and selection["grid"] == {"learning_rate": RATES}
    scores = selection["scores"]["learning_rate"]
    assert len(scores) == 2 and np.isfinite(scores).all() and scores[0] != scores[1]
    chosen = RATES[int(np.argmin(scores))]
    assert selection["chosen"] == {"learning_rate": chosen}
    # One Siamese per rate, trained by the first model, loaded by the second.
    assert proposed.trained_stages == ["siamese", "stn", "siamese", "stn"]
    baseline = fit(splits, grid, name="baseline", cache_dir=tmp_path)
    assert baseline.trained_stages == ["stn", "stn"]
    assert len(list((tmp_path / "siamese").glob("*.pt"))) == 2
    # The kept model is the one fitted at the chosen rate alone: same score, same estimates.
    alone = fit(splits, {**settings, "learning_rate": chosen}, cache_dir=tmp_path)
    assert alone.selection is None
    assert alone._validation_score() == pytest.approx(min(scores), rel=1e-6)
    test = splits["test"].semantics
    np.testing.assert_allclose(alone.predict_semantic(test), proposed.predict_semantic(test), rtol=1e-6)


def test_the_frozen_unet_segments_each_item_once_per_rate(splits, settings, monkeypatch):
    # The Siamese's epochs, the retrieval of the STN's templates, the STN's inputs and the
    # validation scores all read the frozen UNet's maps: made once per rate, not per reader.
    # (Under patience the UNet also scores the validation split after each of its epochs: the
    # smoke profile trains it for one.)
    frozen: list[int] = []
    forward = UNet.forward

    def counted(self, x):
        if not self.training:
            frozen.append(len(x))
        return forward(self, x)

    monkeypatch.setattr(UNet, "forward", counted)
    grid = {**settings, "select": {"learning_rate": RATES}, "patience": 2}
    estimator = load_estimator("proposed", settings=grid, device="cpu", segmentation="unet")
    estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert estimator.trained_stages == ["unet", "siamese", "stn"] * len(RATES)
    train = min(len(splits["train"]), grid.get("max_train") or len(splits["train"]))
    assert grid["unet_epochs"] == 1 and len(estimator.history["unet-validation"]) == 1
    assert sum(frozen) == len(RATES) * (train + len(splits["validation"]) + len(splits["validation"]))


def test_under_patience_the_unet_keeps_its_best_validation_epoch(splits, settings, tmp_path):
    early = {**settings, "unet_epochs": 3, "patience": 1}
    estimator = load_estimator("baseline", settings=early, device="cpu", segmentation="unet", cache_dir=tmp_path)
    estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    scores = estimator.history["unet-validation"]
    assert 1 <= len(scores) <= 3 and len(estimator.history["unet"]) == len(scores)
    held_out = estimator._held_out
    kept = estimator._check_fitted()["unet"]
    assert segmentation_validation_loss(kept, held_out) == pytest.approx(min(scores), rel=1e-6)
    assert estimator.history["unet-class-iou"] == pytest.approx(segmentation_class_iou(kept, held_out).tolist(),
                                                               nan_ok=True)
    # Its key holds the validation split and patience: a UNet that trained every epoch is another one.
    key = estimator.stage_keys["unet"]
    assert (tmp_path / "unet" / f"{key}.pt").is_file()
    plain = load_estimator("baseline", settings={**early, "patience": None}, device="cpu", segmentation="unet",
                           cache_dir=tmp_path)
    plain.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert plain.trained_stages[0] == "unet" and plain.stage_keys["unet"] != key
    assert "unet-validation" not in plain.history
    # A run that loads this UNet from the cache still knows its scores, so its selection records the epoch kept.
    again = load_estimator("baseline", settings={**early, "select": {"learning_rate": [early["learning_rate"]]}},
                           device="cpu", segmentation="unet", cache_dir=tmp_path)
    again.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert "unet" not in again.trained_stages and again.stage_keys["unet"] == key
    assert again.history["unet-validation"] == pytest.approx(scores)
    assert again.selection["chosen"]["unet_epochs"] == best_epoch(scores) + 1


@pytest.mark.filterwarnings("ignore::synthcal.estimators.paper.MissedClassWarning")  # a one-epoch smoke UNet
def test_a_fixed_unet_rate_gives_every_rate_tried_and_every_model_one_unet(splits, settings, tmp_path):
    """``unet_learning_rate`` fixes the step-by-step UNet's own rate while ``select`` varies the later stages':
    one UNet trained once at that rate (its key the one a plain run at that rate gives it), read by every rate and
    model; the Siamese still one per rate tried."""
    fixed = {**settings, "select": {"learning_rate": RATES}, "unet_learning_rate": RATES[1]}
    proposed = load_estimator("proposed", settings=fixed, device="cpu", segmentation="unet", cache_dir=tmp_path)
    proposed.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert proposed.trained_stages == ["unet", "siamese", "stn", "siamese", "stn"]
    assert len(list((tmp_path / "unet").glob("*.pt"))) == 1 and len(list((tmp_path / "siamese").glob("*.pt"))) == 2
    baseline = load_estimator("baseline", settings=fixed, device="cpu", segmentation="unet", cache_dir=tmp_path)
    baseline.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert baseline.trained_stages == ["stn", "stn"] and baseline.stage_keys["unet"] == proposed.stage_keys["unet"]
    # A run at that rate alone, without the setting, trains the same UNet: the setting changes which rate, not how.
    alone = load_estimator("baseline", settings={**settings, "learning_rate": RATES[1]}, device="cpu",
                           segmentation="unet", cache_dir=tmp_path)
    alone.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert "unet" not in alone.trained_stages and alone.stage_keys["unet"] == proposed.stage_keys["unet"]
    # Without the setting the grid trains a UNet per rate, as before.
    per_rate = load_estimator("baseline", settings={**fixed, "unet_learning_rate": None}, device="cpu",
                              segmentation="unet", cache_dir=tmp_path)
    per_rate.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert per_rate.trained_stages.count("unet") == 1 and len(list((tmp_path / "unet").glob("*.pt"))) == 2
    # Unset, it is not in the settings a run records (older runs keep their ids); set, its budget says it.
    assert "unet_learning_rate" not in settings
    budget = training_budget({"run": {"training": "step-by-step", "segmentation": "unet", "settings": fixed}})
    assert budget.endswith("; UNet at learning rate 0.003")


@pytest.mark.parametrize(("training", "segmentation", "why"), [("end-to-end", "unet", "jointly at one rate"),
                                                             ("step-by-step", "ground-truth", "has no UNet")])
def test_a_fixed_unet_rate_is_refused_where_no_step_by_step_unet_trains(splits, settings, training, segmentation,
                                                                        why):
    estimator = load_estimator("proposed", settings={**settings, "unet_learning_rate": 1e-3}, device="cpu",
                               segmentation=segmentation, training=training)
    with pytest.raises(ValueError, match=f"settings.unet_learning_rate 0.001: .*{why}"):
        estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])


def test_patience_keeps_the_best_validation_epoch(splits, settings):
    estimator = fit(splits, {**settings, "stn_epochs": 8, "learning_rate": 3e-3, "patience": 2})
    scores = estimator.history["stn-validation"]
    assert 1 <= len(scores) <= 8 and len(estimator.history["stn"]) == len(scores)
    stopped_early = len(scores) < 8
    assert not stopped_early or len(scores) - 1 - best_epoch(scores) == 2
    # The weights kept score the best epoch's validation loss, not the last one's.
    assert estimator._validation_score() == pytest.approx(min(scores), rel=1e-6)


def test_selection_needs_a_validation_split(splits, settings):
    estimator = load_estimator("proposed", settings={**settings, "patience": 3}, device="cpu",
                               segmentation="ground-truth")
    with pytest.raises(ValueError, match=r"settings.patience: needs a validation split.*--validation"):
        estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene)


def _noise_test_split(store: Path) -> None:
    """Overwrite the test split's images and class maps with noise, and reseal the manifest."""
    rng = np.random.default_rng(0)
    group = zarr.open_group(zarr.storage.LocalStore(store), mode="r+")
    for index in read_split_indices(store, "test", 0).tolist():
        image, semantic = group["image"], group["semantic"]
        image[index] = rng.integers(0, 256, image.shape[1:], dtype=np.uint8)
        semantic[index] = rng.integers(0, 4, semantic.shape[1:], dtype=np.uint8)
    write_manifest(store)


def test_test_data_is_never_read_while_training_or_selecting(smoke_stores, tmp_path):
    clean = smoke_stores.copy(["intersection-1"], tmp_path / "clean")["intersection-1"]
    noisy = smoke_stores.copy(["intersection-1"], tmp_path / "noisy")["intersection-1"]
    for path in (clean, noisy):
        draw_splits(path, seeds=[0])
    _noise_test_split(noisy)
    assert not np.array_equal(load_split(clean, "test", 0).semantics, load_split(noisy, "test", 0).semantics)
    settings = {**load_config(ROOT / "datasets.yaml").training("smoke").settings(), "stn_epochs": 3,
                "patience": 2, "select": {"learning_rate": RATES}}
    records = []
    for path in (clean, noisy):
        (run,) = expand_runs(path.parent, ["intersection-1"], ["proposed"], [0], "smoke", settings,
                             segmentations=["ground-truth"], device="cpu")
        results = path.parent / "results"
        results.mkdir()
        execute_run(run, results)
        records.append(read_record(run_folder(results, run) / "run.json"))
    first, second = records
    assert first["status"] == second["status"] == "ok"
    # Bit-identical training losses, validation scores and choice: the same weights were trained and kept.
    assert first["history"] == second["history"] and first["selection"] == second["selection"]
    assert first["selection"]["split"] == "validation" and "stn-validation" in first["history"]
    assert first["summary"] != second["summary"]  # while the test scores did read the noise
    # The table's caption says what validation chose, and the budget how.
    frame = collect_results(clean.parent / "results")
    rate = first["selection"]["chosen"]["learning_rate"]
    epochs = first["selection"]["chosen"]["stn_epochs"]
    assert frame.loc[0, "chosen"] == f"lr {rate:g}, STN {epochs} epochs"
    caption = " ".join(format_table(table_runs(frame), "models").split())  # unwrapped
    assert f"chosen on validation: proposed lr {rate:g}, STN {epochs} epochs (×1)" in caption
    assert "learning rate chosen on validation from 0.0001, 0.003" in caption


def test_the_validation_split_goes_only_to_a_fit_that_takes_it():
    from synthcal.eval.isolation import takes_validation

    assert takes_validation(load_estimator("proposed")) and takes_validation(load_estimator("retrieved"))
    assert not takes_validation(load_estimator("oracle-template"))  # takes settings, chooses nothing


def test_a_class_weighted_unet_loss_trains_another_unet(splits, settings, tmp_path):
    options = {**settings, "patience": 1}
    plain = load_estimator("baseline", settings=options, device="cpu", segmentation="unet", cache_dir=tmp_path)
    plain.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    weighted = load_estimator("baseline", settings={**options, "unet_class_weights": "inverse-frequency"},
                              device="cpu", segmentation="unet", cache_dir=tmp_path)
    weighted.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
    assert weighted.trained_stages[0] == "unet" and weighted.stage_keys["unet"] != plain.stage_keys["unet"]
    # Its early stopping reads the loss it trains on: the weighted validation cross-entropy.
    assert weighted.history["unet-validation"] != plain.history["unet-validation"]
    with pytest.raises(ValueError, match="unet_class_weights"):
        load_estimator("baseline", settings={**options, "unet_class_weights": "inverse"}, device="cpu")


def test_a_kept_unet_that_misses_a_class_is_warned_of_by_name_and_share(splits, settings, tmp_path, monkeypatch):
    """The warning's rule on given IoUs (segmentation_class_iou is tested against sklearn on its own)."""
    import synthcal.estimators.paper as paper

    def fit_with(iou):
        monkeypatch.setattr(paper, "segmentation_class_iou", lambda unet, held_out: torch.tensor(iou))
        estimator = load_estimator("baseline", settings={**settings, "patience": 1}, device="cpu",
                                   segmentation="unet", cache_dir=tmp_path)
        estimator.fit(splits["train"], splits["dictionary"], splits["train"].scene, validation=splits["validation"])
        return estimator

    with pytest.warns(MissedClassWarning) as caught:
        estimator = fit_with([0.95, 0.9, 0.9, 0.02])
    counts = np.bincount(estimator._held_out.semantics.numpy().ravel(), minlength=4)
    assert counts[3] / counts.sum() >= paper.MISSED_CLASS_SHARE  # the smoke scene's bicycle path is there
    message = str(caught[0].message)
    assert f"class 3 (IoU 2.0 %, {100 * counts[3] / counts.sum():.1f} % of the pixels)" in message
    assert "class 1" not in message and "unet_class_weights: inverse-frequency" in message
    assert estimator.history["unet-class-iou"] == pytest.approx([0.95, 0.9, 0.9, 0.02])
    assert estimator.history["unet-missed-classes"] == [3]  # what the report flags the run by
    with warnings.catch_warnings():
        warnings.simplefilter("error", MissedClassWarning)
        learnt = fit_with([0.95, 0.9, 0.9, 0.5])  # every class learnt: silent
    assert learnt.history["unet-missed-classes"] == []
