"""The UNet's own segmentation quality: the scores against scikit-learn, and ``synthcal segmentation`` on a smoke bench."""

import io
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from sklearn.metrics import accuracy_score, f1_score, jaccard_score

from synthcal.cli import main
from synthcal.data import load_split, read_scene
from synthcal.eval.harness import collect_results, read_record, run_threads
from synthcal.eval.segmentation import (
    class_scores,
    confusion_matrix,
    quality_row,
    readings_side_by_side,
    seed_summary,
)
from synthcal.generate.splits import draw_splits
from synthcal.models import UNet

NAMES = ("background", "road", "terrain", "path")


def test_iou_and_dice_agree_with_sklearn_per_class():
    rng = np.random.default_rng(3)
    truth = rng.integers(0, 4, (5, 9, 11))
    predicted = np.where(rng.random(truth.shape) < 0.6, truth, rng.integers(0, 4, truth.shape))
    confusion = confusion_matrix(truth, predicted)
    assert confusion.sum() == truth.size
    iou, dice = class_scores(confusion)
    labels = [0, 1, 2, 3]
    np.testing.assert_allclose(iou, jaccard_score(truth.ravel(), predicted.ravel(), labels=labels, average=None))
    np.testing.assert_allclose(dice, f1_score(truth.ravel(), predicted.ravel(), labels=labels, average=None))
    row = quality_row(confusion, NAMES)
    assert row["iou terrain"] == pytest.approx(iou[2]) and row["dice path"] == pytest.approx(dice[3])
    assert row["mean iou"] == pytest.approx(iou[1:].mean()) and row["mean dice"] == pytest.approx(dice[1:].mean())
    assert row["pixel accuracy"] == pytest.approx(accuracy_score(truth.ravel(), predicted.ravel()))


def test_a_class_absent_from_truth_and_prediction_has_no_score():
    truth = np.array([[0, 0, 1, 1]])
    predicted = np.array([[0, 1, 1, 1]])
    iou, dice = class_scores(confusion_matrix(truth, predicted))
    # class 1: TP 2, FP 1, FN 0 → IoU 2/3, Dice 4/5; class 0: TP 1, FN 1 → 1/2, 2/3
    np.testing.assert_allclose(iou[:2], [1 / 2, 2 / 3])
    np.testing.assert_allclose(dice[:2], [2 / 3, 4 / 5])
    assert np.isnan(iou[2:]).all() and np.isnan(dice[2:]).all()
    row = quality_row(confusion_matrix(truth, predicted), NAMES)
    assert row["mean iou"] == pytest.approx(2 / 3)  # only class 1 of the foreground has a score


def test_confusion_matrix_names_bad_input():
    with pytest.raises(ValueError, match="shape"):
        confusion_matrix(np.zeros((2, 3)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"prediction: class ids must lie in 0..3; got 0..4"):
        confusion_matrix(np.zeros(3, int), np.array([0, 4, 1]))


def test_seed_summary_is_mean_and_sample_std_in_percent():
    frame = pd.DataFrame({"dataset": ["a", "a", "a", "b"], "seed": [0, 1, 2, 0],
                          "mean iou": [0.5, 0.6, 0.7, 0.25], "pixel accuracy": [0.9, 0.8, 0.7, 1.0]})
    summary = seed_summary(frame).set_index("dataset")
    assert summary.loc["a", "seeds"] == 3
    assert summary.loc["a", "mean iou"] == f"{60:.2f} ± {np.std([50, 60, 70], ddof=1):.2f}"
    assert summary.loc["b", "pixel accuracy"] == "100.00"  # one seed: its value alone


def test_models_that_read_different_unets_on_a_seed_are_summarised_apart():
    # Seed 0: both models read UNet k0; seed 1: validation chose a different rate for each.
    frame = pd.DataFrame({"dataset": ["a", "a", "a"], "seed": [0, 1, 1], "unet": ["k0", "k1", "k2"],
                          "models": ["p, s", "p", "s"], "mean iou": [0.5, 0.6, 0.8]})
    summary = seed_summary(frame).set_index("models")
    assert list(summary["seeds"]) == [2, 2]
    assert summary.loc["p", "mean iou"] == f"{55:.2f} ± {np.std([50, 60], ddof=1):.2f}"
    assert summary.loc["s", "mean iou"] == f"{65:.2f} ± {np.std([50, 80], ddof=1):.2f}"


# --- the command on a smoke bench -----------------------------------------------------------


@pytest.fixture(scope="module")
def unet_bench(smoke_stores, tmp_path_factory) -> tuple[Path, Path]:
    """``proposed`` on intersection-1, seed 0, with a UNet and with true maps: (data, results).

    Under ``--patience`` the UNet keeps its best validation epoch, so its cache key holds the
    validation split: ``segmentation`` finds it by the key the run recorded."""
    data = tmp_path_factory.mktemp("unet-data")
    smoke_stores.copy(["intersection-1"], data)
    draw_splits(data / "intersection-1.zarr", seeds=[0])
    results = tmp_path_factory.mktemp("unet-results")
    assert main(["bench", "--data", str(data), "--datasets", "intersection-1", "--estimator", "proposed",
                 "--seeds", "0", "--results", str(results), "--profile", "smoke", "--device", "cpu",
                 "--segmentation", "unet", "ground-truth", "--patience", "1", "--quiet", "--yes"]) == 0
    return data, results


def test_segmentation_prints_the_checkpoints_scores(unet_bench, smoke_config, capsys):
    data, results = unet_bench
    assert main(["segmentation", str(results), "--data", str(data), "--format", "csv"]) == 0
    printed = pd.read_csv(io.StringIO(capsys.readouterr().out))
    assert list(printed[["dataset", "seed", "models"]].itertuples(index=False, name=None)) == [
        ("intersection-1", 0, "proposed")]
    # Directly: the one UNet the bench cached, on the first test images the smoke profile uses.
    (checkpoint,) = (results / "cache" / "unet").glob("*.pt")
    (unet_run,) = [record for record in map(read_record, (results / "runs").glob("*/run.json"))
                   if record["run"]["segmentation"] == "unet"]
    assert unet_run["stage_keys"]["unet"] == checkpoint.stem and "unet-validation" in unet_run["history"]
    # What decides the trained stages' last bits: torch's instruction set and the threads bench gave the run.
    machine = unet_run["machine"]
    assert machine["torch"] == torch.__version__ and machine["torch_threads"] == run_threads(1)
    assert machine["cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    settings = smoke_config.training("smoke").settings()
    unet = UNet(num_classes=4, width=settings["unet_width"], depth=settings["unet_depth"])
    unet.load_state_dict(torch.load(checkpoint, weights_only=True))
    test = load_split(data / "intersection-1.zarr", "test", 0)
    n = int(printed["n_images"][0])
    assert n == min(len(test), smoke_config.split_caps("smoke")["test"])
    with torch.no_grad():  # smoke sets no work_size: the UNet reads the images at full size
        rgb = torch.from_numpy(np.asarray(test.images[:n])).permute(0, 3, 1, 2).float() / 255
        predicted = unet.eval()(rgb).argmax(1).numpy().ravel()
    truth = np.asarray(test.semantics[:n]).ravel()
    classes = read_scene(data / "intersection-1.zarr").classes
    iou = jaccard_score(truth, predicted, labels=[0, 1, 2, 3], average=None, zero_division=0)
    dice = f1_score(truth, predicted, labels=[0, 1, 2, 3], average=None, zero_division=0)
    for k, name in enumerate(classes):
        if k in truth or k in predicted:
            assert printed[f"iou {name}"][0] == pytest.approx(iou[k])
            assert printed[f"dice {name}"][0] == pytest.approx(dice[k])
        else:  # sklearn says 0 where we say "no score"
            assert np.isnan(printed[f"iou {name}"][0]) and np.isnan(printed[f"dice {name}"][0])
    assert printed["pixel accuracy"][0] == pytest.approx(accuracy_score(truth, predicted))


def test_segmentation_shows_the_readings_on_unet_and_true_maps_side_by_side(unet_bench, capsys):
    data, results = unet_bench
    assert main(["segmentation", str(results), "--data", str(data), "--metric", "iou"]) == 0
    text = capsys.readouterr().out
    frame = collect_results(results)
    side = readings_side_by_side(frame, "iou")
    assert len(side) == 1 and side["seeds"][0] == 1
    for segmentation in ("unet", "ground-truth"):
        expected = 100 * frame.loc[frame["segmentation"] == segmentation, "iou"].item()
        assert side[segmentation][0] == f"{expected:.2f}"
    side_table = text.split("on the UNet's maps beside the true maps")[1]
    row = next(line for line in side_table.splitlines() if line.startswith("| intersection-1 | proposed |"))
    assert f"| {side['unet'][0]} | {side['ground-truth'][0]} |" in row


def test_segmentation_names_a_missing_checkpoint(unet_bench, tmp_path, capsys):
    import shutil

    data, results = unet_bench
    copy = Path(shutil.copytree(results, tmp_path / "results"))
    (checkpoint,) = (copy / "cache" / "unet").glob("*.pt")
    checkpoint.unlink()
    assert main(["segmentation", str(copy), "--data", str(data)]) == 2
    assert str(checkpoint) in capsys.readouterr().err
