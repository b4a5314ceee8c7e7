"""``images: splits`` stores: images only for drawn splits, rendered to a full render's bytes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
import zarr

from synthcal import cli
from synthcal.config import SplitSizes, load_config
from synthcal.data.pool import LazyRows
from synthcal.eval.harness import collect_results
from synthcal.generate import images as images_module
from synthcal.generate.images import used_indices
from synthcal.generate.pipeline import anchored_spec, generate_dataset, load_scene
from synthcal.generate.splits import draw_splits
from synthcal.store import (
    CorruptStore,
    ImagesNotRendered,
    array_at,
    open_store,
    read_manifest,
    read_samples,
    rendered_mask,
    verify_store,
    write_manifest,
)
from synthcal.store.shards import read_rows
from synthcal.store.splits import pool_dictionary_indices, read_mixed_dictionary, resolve_mixed_dictionary

NAME = "intersection-1"
SMALL = SplitSizes(train=4, test=2, dictionary=3)


@pytest.fixture(scope="module")
def splits_store(smoke_config, tmp_path_factory) -> Path:
    """A pristine ``images: splits`` smoke store, no splits drawn."""
    spec = smoke_config.resolve(NAME, "smoke").model_copy(update={"images": "splits"})
    return generate_dataset(spec, tmp_path_factory.mktemp("splits-store"), workers=1, progress=False)


@pytest.fixture()
def store(splits_store, tmp_path) -> Path:
    import shutil

    return Path(shutil.copytree(splits_store, tmp_path / splits_store.name))


def _group(path: Path) -> zarr.Group:
    return zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r", zarr_format=3)


def test_a_generated_splits_store_holds_every_map_and_no_image(store, smoke_stores):
    full = open_store(smoke_stores.path(NAME))
    group = open_store(store)
    assert group.attrs["images"] == {"mode": "splits", "rendered": 0, "state": "complete"}
    assert not rendered_mask(group).any()
    assert not (store / "image" / "c").exists()
    every = np.arange(group.attrs["N"])
    for name in ("semantic", "homography", "camera/pan_deg"):
        np.testing.assert_array_equal(read_rows(array_at(group, name), every), read_rows(array_at(full, name), every))
    assert group.attrs["foreground"] == full.attrs["foreground"]


def test_rendered_images_equal_a_full_render_byte_for_byte(store, smoke_stores):
    result = draw_splits(store, seeds=(0, 1), sizes=SMALL)
    group = open_store(store)  # the manifest holds the new image files
    mask = rendered_mask(group)
    used = used_indices(group)
    assert result.rendered == len(used) == mask.sum() and np.array_equal(np.flatnonzero(mask), used)
    assert group.attrs["images"] == {"mode": "splits", "rendered": len(used), "state": "complete"}
    full = open_store(smoke_stores.path(NAME))
    got = read_samples(group, used)["image"]
    assert got.any(axis=(1, 2, 3)).all()
    np.testing.assert_array_equal(got, read_rows(array_at(full, "image"), used))
    assert verify_store(store).ok, verify_store(store).problems


def test_an_unrendered_image_is_an_error_naming_the_fix(store):
    draw_splits(store, seeds=(0,), sizes=SMALL)
    group = open_store(store)
    absent = int(np.flatnonzero(~rendered_mask(group))[0])
    with pytest.raises(ImagesNotRendered, match=r"never rendered.*`synthcal split .*--seeds") as caught:
        read_samples(group, np.array([absent]))
    assert str(store) in str(caught.value) and f"({absent})" in str(caught.value)
    rows = LazyRows(store, "image", np.array([int(used_indices(group)[0]), absent]))
    assert rows[0].any()
    with pytest.raises(ImagesNotRendered, match=str(store)):
        rows[1]


def test_new_seeds_render_only_what_is_missing(store, monkeypatch):
    draw_splits(store, seeds=(0,), sizes=SMALL)
    before = rendered_mask(open_store(store))
    rendered: list[int] = []
    real = images_module.render_samples

    def counting(scene, homographies, first, spec, indices=None, images=True):
        rendered.extend(np.asarray(indices).tolist())
        return real(scene, homographies, first, spec, indices=indices, images=images)

    monkeypatch.setattr(images_module, "render_samples", counting)
    result = draw_splits(store, seeds=(0, 1), sizes=SMALL)
    after = rendered_mask(open_store(store))
    assert before.sum() > 0 and (after & before).sum() == before.sum()
    assert sorted(rendered) == np.flatnonzero(after & ~before).tolist() and result.rendered == len(rendered) > 0
    rendered.clear()
    assert draw_splits(store, seeds=(0, 1), sizes=SMALL).rendered == 0 and not rendered


def test_a_killed_render_resumes(store, smoke_stores):
    draw_splits(store, seeds=(0,), sizes=SMALL)
    group = zarr.open_group(zarr.storage.LocalStore(store), mode="r+", zarr_format=3)
    mask = rendered_mask(group)
    lost = np.flatnonzero(mask)[-2:]  # a kill after a shard file was written, before image_rendered marked it
    mask[lost] = False
    array_at(group, "image_rendered")[:] = mask.astype(np.uint8)
    group.attrs.update({"images": {**group.attrs["images"], "state": "rendering"}})
    write_manifest(store, "writing", read_manifest(store).files)  # as the killed renderer's begin() left it
    with pytest.raises(CorruptStore, match=rf"{store}: a writer .* `synthcal split {store}` finishes the job"):
        open_store(store)  # readers refuse a store whose files are not sealed
    assert not verify_store(store).ok
    assert draw_splits(store, seeds=(0,), sizes=SMALL).rendered == len(lost)
    assert verify_store(store).ok
    used = used_indices(open_store(store))
    np.testing.assert_array_equal(read_samples(open_store(store), used)["image"],
                                  read_rows(array_at(open_store(smoke_stores.path(NAME)), "image"), used))


def test_images_all_stores_are_unchanged(smoke_config, smoke_stores):
    spec = smoke_config.resolve(NAME, "smoke")
    assert spec.images == "all"
    assert "images" not in spec.stored_config()
    assert spec.config_hash() != spec.model_copy(update={"images": "splits"}).config_hash()
    group = open_store(smoke_stores.path(NAME))
    assert "images" not in group.attrs and "image_rendered" not in group
    assert group.attrs["config"] == anchored_spec(spec, load_scene(spec)).stored_config()
    assert "images" not in group.attrs["config"]
    assert rendered_mask(group) is None
    read_samples(group, np.arange(group.attrs["N"]))  # every image readable


def test_the_images_key_is_validated_and_resolved(tmp_path):
    config = yaml.safe_load((Path(__file__).resolve().parents[2] / "datasets.yaml").read_text())
    config["datasets"][NAME]["images"] = "some"
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(config))
    with pytest.raises(ValueError, match=rf"(?s){path}.*datasets\.{NAME}\.images: Input should be .all. or .splits. \(value .some.\)"):
        load_config(path)
    config["datasets"][NAME]["images"] = "splits"
    path.write_text(yaml.safe_dump(config))
    assert load_config(path).resolve(NAME, "smoke").images == "splits"
    config["profiles"]["smoke"]["images"] = "all"
    path.write_text(yaml.safe_dump(config))
    assert load_config(path).resolve(NAME, "smoke").images == "all"


def test_info_reports_the_image_mode(store, smoke_stores, capsys):
    draw_splits(store, seeds=(0,), sizes=SMALL)
    assert cli.main(["info", str(store)]) == 0
    count = int(rendered_mask(open_store(store)).sum())
    assert f"images       splits: {count} of 48 rendered" in capsys.readouterr().out
    assert cli.main(["info", str(smoke_stores.path(NAME))]) == 0
    assert "images       all" in capsys.readouterr().out


def test_a_mixed_dictionary_renders_its_templates_in_splits_sources(smoke_config, smoke_stores, tmp_path):
    target = smoke_stores.copy([NAME], tmp_path)[NAME]
    sources = smoke_config.resolve(NAME, "smoke").mixed_sources
    for name in sources:
        spec = smoke_config.resolve(name, "smoke").model_copy(update={"images": "splits"})
        generate_dataset(spec, tmp_path, workers=1, progress=False)
    result = draw_splits(target, seeds=(0,), sizes=SMALL, mixed=True)
    mixed = read_mixed_dictionary(target, 0)
    assert result.rendered == len(mixed.index) == SMALL.dictionary
    for k, name in enumerate(sources):  # each source holds exactly the images of the templates it gives
        assert np.flatnonzero(rendered_mask(open_store(tmp_path / f"{name}.zarr"))).tolist() == \
            mixed.index[mixed.source == k].tolist()
    resolved = resolve_mixed_dictionary(target, 0)
    for k, name in enumerate(sources):
        full = read_rows(array_at(open_store(smoke_stores.path(name)), "image"), mixed.index[mixed.source == k])
        np.testing.assert_array_equal(resolved["image"][mixed.source == k], full)


def test_the_pool_dictionary_of_a_splits_store_scores_like_a_full_store(store, smoke_stores, tmp_path):
    # The pool dictionary reads maps only, so most of its templates have no image in a
    # splits store; its scores must equal the same run on the full (images: all) store.
    full = smoke_stores.copy([NAME], tmp_path / "full")[NAME]
    for path in (store, full):
        draw_splits(path, seeds=(0,), sizes=SplitSizes(train=24, test=8, dictionary=12))
    group = open_store(store)
    assert not rendered_mask(group)[pool_dictionary_indices(store, 0)].all()  # some templates never rendered
    scores = []
    for path in (store, full):
        results = tmp_path / f"results-{path.parent.name}"
        assert cli.main(["bench", "--data", str(path.parent), "--datasets", NAME, "--estimator", "template",
                         "--seeds", "0", "--results", str(results), "--profile", "smoke", "--device", "cpu",
                         "--dictionary", "pool", "--quiet"]) == 0
        run = collect_results(results)["run_id"].iloc[0]
        scores.append(pd.read_csv(results / "runs" / run / "metrics.csv"))
    assert len(scores[0]) == 8
    pd.testing.assert_frame_equal(scores[0], scores[1])

