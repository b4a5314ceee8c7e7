"""`synthcal generate`: store layout, reproducibility across workers, resume, Dask."""

from pathlib import Path

import numpy as np
import pytest
import zarr

from synthcal.config import load_config
from synthcal.generate.camera import homography
from synthcal.generate.pipeline import generate_dataset, load_scene
from synthcal.store import CAMERA_FIELDS, StoreError, open_store

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def spec():
    return load_config(ROOT / "datasets.yaml").resolve("intersection-2", "smoke")


@pytest.fixture(scope="module")
def reference(smoke_stores, tmp_path_factory) -> Path:
    """intersection-2 generated with one worker (a copy: one test generates into its folder)."""
    return smoke_stores.copy(["intersection-2"], tmp_path_factory.mktemp("reference"))["intersection-2"]


def store_files(store: Path) -> dict[str, bytes]:
    return {str(f.relative_to(store)): f.read_bytes() for f in sorted(store.rglob("*")) if f.is_file()}


def test_layout_and_attributes(spec, reference):
    group = open_store(reference)
    n, (width, height), s = spec.pool_size, spec.image_size, spec.shard_size
    assert group["image"].shape == (n, height, width, 3) and group["image"].dtype == np.uint8
    assert group["semantic"].shape == (n, height, width) and group["semantic"].dtype == np.uint8
    assert group["homography"].shape == (n, 3, 3) and group["homography"].dtype == np.float64
    assert group["image"].chunks == (1, height, width, 3) and group["image"].shards == (s, height, width, 3)
    for name in CAMERA_FIELDS:
        assert group[f"camera/{name}"].shape == (n,)
    assert group["camera/grid_index"].dtype == np.int64
    scene = load_scene(spec)
    np.testing.assert_array_equal(group["scene/semantic"][:], scene.semantic)
    attrs = group.attrs
    assert attrs["complete"] is True and attrs["N"] == n and attrs["seed"] == spec.seed
    assert attrs["config_hash"] == spec.config_hash() and attrs["scene"]["name"] == "intersection-2"
    assert attrs["focal_reference_width"] == 256 and attrs["image_size"] == [width, height]
    assert {"numpy", "zarr", "synthcal"} <= set(attrs["software"])


def test_homography_agrees_with_recorded_camera(spec, reference):
    group = open_store(reference)
    cam = {name: group[f"camera/{name}"][:] for name in CAMERA_FIELDS}
    scene = load_scene(spec)
    expected = homography(cam["pan_deg"] + scene.heading_deg, cam["tilt_deg"],
                          cam["focal_px"] * spec.image_size[0] / 256, np.c_[cam["x"], cam["y"], cam["z"]], spec.image_size)
    np.testing.assert_allclose(group["homography"][:], expected, rtol=1e-12)


def test_sky_is_black_and_background(reference):
    group = open_store(reference)
    semantic, image, H = group["semantic"][:], group["image"][:], group["homography"][:]
    width, height = image.shape[2], image.shape[1]
    ys, xs = np.mgrid[0:height, 0:width]
    pixels = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    sky_seen = 0
    for k in range(len(H)):
        sky = (np.linalg.solve(H[k], pixels)[2] <= 0).reshape(height, width)
        assert not semantic[k][sky].any() and not image[k][sky].any()
        sky_seen += sky.sum()
    assert sky_seen > 0, "some smoke cameras look at the horizon"
    assert all(np.isin(np.unique(semantic), [0, 1, 2, 3]))


def test_bit_identical_with_two_workers(spec, reference, tmp_path):
    other = generate_dataset(spec, tmp_path, workers=2, progress=False)
    assert store_files(other) == store_files(reference)


def test_bit_identical_on_a_dask_cluster(spec, reference, tmp_path):
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        other = generate_dataset(spec, tmp_path, scheduler=cluster.scheduler_address, progress=False)
    assert store_files(other) == store_files(reference)


class Crash(RuntimeError):
    pass


def test_interrupted_run_resumes_to_the_same_bytes(spec, reference, tmp_path):
    shards = -(-spec.pool_size // spec.shard_size)
    finished = []

    def crash_after_two(count: int) -> None:
        finished.append(count)
        if len(finished) == 2:
            raise Crash

    with pytest.raises(Crash):
        generate_dataset(spec, tmp_path, progress=False, on_shard=crash_after_two)
    final = tmp_path / f"{spec.name}.zarr"
    assert not final.exists()
    with pytest.raises(StoreError, match="resume"):
        open_store(final)
    partial = zarr.open_group(str(final) + ".partial", mode="r")
    assert partial.attrs["complete"] is False

    rendered = []
    generate_dataset(spec, tmp_path, progress=False, on_shard=rendered.append)
    assert len(rendered) == shards - 2, "only the missing shards are rendered again"
    assert store_files(final) == store_files(reference)
    assert not (tmp_path / f".{spec.name}.zarr.progress").exists()


def test_a_torn_shard_is_redone(spec, reference, tmp_path, monkeypatch):
    """A crash after writing images but before the shard's marker: the shard is redone."""
    import synthcal.generate.pipeline as pipeline

    real_write = pipeline.write_samples

    def write_images_then_die(path, shard, image, semantic):
        real_write(path, shard, image, np.zeros_like(semantic))
        raise Crash

    monkeypatch.setattr(pipeline, "write_samples", write_images_then_die)
    with pytest.raises(Crash):
        generate_dataset(spec, tmp_path, progress=False)
    monkeypatch.setattr(pipeline, "write_samples", real_write)
    generate_dataset(spec, tmp_path, progress=False)
    assert store_files(tmp_path / f"{spec.name}.zarr") == store_files(reference)


def test_different_seed_gives_different_pool(spec, reference, tmp_path):
    other = generate_dataset(spec.model_copy(update={"seed": spec.seed + 1}), tmp_path, progress=False)
    a, b = open_store(reference), open_store(other)
    assert not np.array_equal(a["camera/grid_index"][:], b["camera/grid_index"][:])


def test_existing_store_of_another_configuration_is_refused(spec, reference):
    from synthcal.config import ConfigError

    with pytest.raises(ConfigError, match="different configuration"):
        generate_dataset(spec.model_copy(update={"seed": 99}), reference.parent, progress=False)
