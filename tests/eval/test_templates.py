"""Template diagnostics: the template a run picked, found from its stored estimates, and its pan error."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import zarr

from synthcal.data import load_split
from synthcal.eval.harness import collect_results
from synthcal.eval.templates import format_diagnostics, identify_templates, template_diagnostics
from synthcal.generate.splits import draw_splits

H_COLUMNS = [f"h{i}{j}" for i in range(3) for j in range(3)]


def test_identify_templates_up_to_scale_and_sign():
    rng = np.random.default_rng(0)
    dictionary = rng.normal(size=(20, 3, 3))
    picks = np.array([3, 0, 19, 7, 7])
    scales = np.array([2.5, -0.1, 1e3, -7.0, 1.0])
    estimates = dictionary[picks] * scales[:, None, None]
    estimates = np.concatenate([estimates, np.full((1, 3, 3), np.nan), rng.normal(size=(1, 3, 3))])
    assert identify_templates(estimates, dictionary).tolist() == [3, 0, 19, 7, 7, -1, -1]


def _fake_run(results: Path, store: Path, model: str, test, estimates: np.ndarray,
              dataset: str = "intersection-1") -> None:
    run_id = f"{dataset}_{model}_s0"
    folder = results / "runs" / run_id
    folder.mkdir(parents=True)
    run = {"dataset": dataset, "store": str(store), "mixed": None, "model": model, "estimator": model,
           "seed": 0, "training": None, "loss": None, "matching": "top-mse", "segmentation": "ground-truth",
           "profile": "smoke"}
    (folder / "run.json").write_text(json.dumps({"run": run, "id": run_id, "status": "ok",
                                                 "summary": {"iou": 0.5, "completeness": 1.0, "n_images": 8}}))
    per_image = pd.DataFrame(estimates.reshape(-1, 9), columns=H_COLUMNS)
    per_image.insert(0, "pool_index", np.asarray(test.indices))
    per_image.to_csv(folder / "metrics.csv", index=False)


def _best_pose_by_opencv(truths: np.ndarray, dictionary: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The best-pose template computed independently, one image and template at a time: an 8 × 5 pixel grid
    sent to the ground by the inverse truth and back by each template with cv2.perspectiveTransform, mean
    pixel distance; depths (in front of the camera or not) from plain matrix products."""
    import cv2

    w, h = size
    u, v = np.meshgrid((np.arange(8) + 0.5) * w / 8 - 0.5, (np.arange(5) + 0.5) * h / 5 - 0.5)
    pixels = np.stack([u.ravel(), v.ravel()], axis=1)
    best = []
    for H in truths:
        inverse = np.linalg.inv(H)
        seen = (inverse @ np.vstack([pixels.T, np.ones(len(pixels))]))[2] > 0
        if not seen.any():
            best.append(-1)
            continue
        ground = cv2.perspectiveTransform(pixels[seen][None], inverse)[0]
        distances = []
        for T in dictionary:
            if not ((T @ np.vstack([ground.T, np.ones(len(ground))]))[2] > 0).all():
                distances.append(np.inf)
                continue
            back = cv2.perspectiveTransform(ground[None], T)[0]
            distances.append(float(np.mean(np.hypot(*(back - pixels[seen]).T))))
        best.append(int(np.argmin(distances)) if np.isfinite(min(distances)) else -1)
    return np.array(best)


def test_best_pose_share_and_pan_errors_against_the_store(smoke_stores, tmp_path, monkeypatch, capsys):
    store = smoke_stores.copy(["intersection-1"], tmp_path / "data")["intersection-1"]
    draw_splits(store, seeds=[0])
    dictionary, test = load_split(store, "dictionary", 0), load_split(store, "test", 0)
    group = zarr.open_group(str(store), mode="r")
    truths = group["homography"][:][np.asarray(test.indices)]
    best = _best_pose_by_opencv(truths, dictionary.homographies, tuple(group.attrs["image_size"]))
    assert (best >= 0).sum() >= 4 and len(set(best[best >= 0].tolist())) > 1  # a test that can tell picks apart
    rng = np.random.default_rng(1)
    n, k = len(test.indices), len(dictionary.indices)
    retrieved = np.where(rng.random(n) < 0.5, np.maximum(best, 0), rng.integers(0, k, n))
    scale = rng.uniform(0.5, 2.0, n)[:, None, None]
    estimates = dictionary.homographies[retrieved] * scale
    estimates[0] = np.nan  # a failed image: no template
    results = tmp_path / "results"
    # bench records the store path as given: relative to where it ran, beside the results folder
    _fake_run(results, store.relative_to(tmp_path), "retrieved", test, estimates)
    _fake_run(results, store, "proposed", test, estimates + 1.0)  # not a picker: ignored
    monkeypatch.chdir(results)  # the table printed from elsewhere
    diagnostics = template_diagnostics(collect_results(results), results, mixed_only=False)
    assert diagnostics["model"].tolist() == ["retrieved"]
    row = diagnostics.iloc[0]
    scored = (np.arange(n) > 0) & (best >= 0)  # image 0 has no template; some truths see no ground
    assert row["best_pose"] == pytest.approx(100.0 * np.mean(retrieved[scored] == best[scored]))
    # Pans read straight from the store, the wrap done with complex numbers.
    pans = group["camera/pan_deg"][:]
    template_pans, test_pans = pans[np.asarray(dictionary.indices)], pans[np.asarray(test.indices)]

    def error(picks: np.ndarray) -> np.ndarray:
        return np.abs(np.rad2deg(np.angle(np.exp(1j * np.deg2rad(template_pans[picks] - test_pans)))))
    assert np.ptp(error(retrieved)) > 1.0  # pans that differ: the median means something
    assert row["pan_error"] == pytest.approx(np.median(error(retrieved)[1:]))
    assert row["best_pan_error"] == pytest.approx(np.median(error(best[best >= 0])[best >= 0]))
    text = format_diagnostics(diagnostics, {"intersection-1": "61.00 ± 1.00"})
    assert f"for {row['best_pose']:.1f} %" in text and "template `retrieved` picked" in text
    # the same frame as a CSV, from the command line (own dictionaries included)
    from synthcal.cli import main

    assert main(["table", str(results), "--layout", "diagnostics", "--format", "csv"]) == 0
    printed = pd.read_csv(io.StringIO(capsys.readouterr().out))
    assert printed["best_pose"].iloc[0] == pytest.approx(row["best_pose"])


def test_mixed_dictionary_templates_take_their_pose_from_their_source_store(smoke_stores, tmp_path):
    names = ["intersection-1", "intersection-2", "intersection-3", "intersection-4", "intersection-5"]
    stores = smoke_stores.copy(names, tmp_path / "data")
    draw_splits(stores["intersection-1"], seeds=[0], mixed=True)
    dictionary = load_split(stores["intersection-1"], "dictionary", 0, mixed=True)
    test = load_split(stores["intersection-1"], "test", 0)
    assert len(set(dictionary.source.tolist())) > 1  # templates from several stores
    picks = np.arange(len(test.indices)) % len(dictionary.indices)
    results = tmp_path / "results"
    _fake_run(results, stores["intersection-1"], "retrieved", test, dictionary.homographies[picks] * 3.0)
    record = results / "runs" / "intersection-1_retrieved_s0" / "run.json"
    edited = json.loads(record.read_text())
    edited["run"].update(dataset="mixed-1", mixed=True)
    edited["run"]["matching"] = None  # a run without a matching score (NaN in the frame) groups, not crashes
    record.write_text(json.dumps(edited))
    diagnostics = template_diagnostics(collect_results(results), results)
    assert diagnostics["dataset"].tolist() == ["mixed-1"]
    pans = {k: zarr.open_group(str(path), mode="r")["camera/pan_deg"][:]
            for k, path in enumerate(dictionary.source_stores)}
    template_pans = np.array([pans[s][i] for s, i in zip(dictionary.source, dictionary.indices, strict=True)])
    test_pans = zarr.open_group(str(stores["intersection-1"]), mode="r")["camera/pan_deg"][:][np.asarray(test.indices)]
    errors = np.abs(np.rad2deg(np.angle(np.exp(1j * np.deg2rad(template_pans[picks] - test_pans)))))
    assert diagnostics["pan_error"].iloc[0] == pytest.approx(np.median(errors))


def test_world_cup_templates_come_from_the_soccer_store(smoke_stores, tmp_path):
    stores = smoke_stores.copy(["soccer", "worldcup2014"], tmp_path / "data")
    store = stores["worldcup2014"]
    draw_splits(store, seeds=[0])
    dictionary, test = load_split(store, "dictionary", 0), load_split(store, "test", 0)  # as a run loads them
    assert dictionary.sources == ("soccer",)
    truths = zarr.open_group(str(store), mode="r")["homography"][:][np.asarray(test.indices)]
    best = _best_pose_by_opencv(truths, dictionary.homographies, (64, 36))
    picks = np.where(np.arange(len(best)) % 3 == 0, np.maximum(best, 0), np.arange(len(best)) % len(dictionary))
    results = tmp_path / "results"
    # the run records mixed None (the store's default), as bench does for worldcup2014
    _fake_run(results, store, "retrieved", test, dictionary.homographies[picks] * 2.0, dataset="worldcup2014")
    (row,) = template_diagnostics(collect_results(results), results, mixed_only=False).to_dict("records")
    assert row["dataset"] == "worldcup2014" and row["seeds"] == 1
    scored = best >= 0
    assert 0 < row["best_pose"] < 100
    assert row["best_pose"] == pytest.approx(100.0 * np.mean(picks[scored] == best[scored]))
    # template pans from the soccer store, test pans from World Cup's own
    template_pans = zarr.open_group(str(stores["soccer"]), mode="r")["camera/pan_deg"][:][np.asarray(dictionary.indices)]
    test_pans = zarr.open_group(str(store), mode="r")["camera/pan_deg"][:][np.asarray(test.indices)]
    errors = np.abs(np.rad2deg(np.angle(np.exp(1j * np.deg2rad(template_pans[picks] - test_pans)))))
    assert row["pan_error"] == pytest.approx(np.median(errors))


def test_each_store_row_is_read_once_per_call_and_only_where_needed(smoke_stores, tmp_path, monkeypatch):
    from synthcal.store import shards

    store = smoke_stores.copy(["intersection-1"], tmp_path / "data")["intersection-1"]
    draw_splits(store, seeds=[0])
    dictionary, test = load_split(store, "dictionary", 0), load_split(store, "test", 0)
    picks = np.arange(len(test.indices)) % len(dictionary.indices)
    results = tmp_path / "results"
    for model in ("retrieved", "template"):  # two runs of one store and seed: their rows are read once
        _fake_run(results, store, model, test, dictionary.homographies[picks])
    reads: list[tuple[str, np.ndarray]] = []
    read_rows = shards.read_rows

    def spy(array, index, threads=None):
        reads.append((array.path, np.asarray(index)))
        return read_rows(array, index, threads)

    monkeypatch.setattr(shards, "read_rows", spy)
    needed = np.union1d(dictionary.indices, test.indices)
    pool = zarr.open_group(str(store), mode="r")["homography"].shape[0]
    assert len(needed) < pool  # rows outside the splits exist, so "only where needed" can fail
    for _ in range(2):  # a second call reads again: nothing is kept from one call to the next
        reads.clear()
        diagnostics = template_diagnostics(collect_results(results), results, mixed_only=False)
        assert diagnostics["seeds"].tolist() == [1, 1]
        for name in ("homography", "camera/pan_deg"):
            rows = np.concatenate([index for path, index in reads if path == name])
            assert np.sort(rows).tolist() == needed.tolist()
