"""`synthcal generate`: store layout, reproducibility across workers, resume, Dask."""

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
import zarr

from synthcal.config import load_config
from synthcal.generate.camera import homography
from synthcal.generate.pipeline import anchored_spec, generate_dataset, load_scene
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
    # a relative grid is recorded (and hashed) as the absolute grid it stands for at the scene's anchor
    assert attrs["config_hash"] == anchored_spec(spec, scene).config_hash() != spec.config_hash()
    assert attrs["scene"]["name"] == "intersection-2"
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


# SHA-256 of the smoke intersection-2 store's arrays as generated before the renderer was
# sped up (issue 22): a faster form that changes any byte changes every store made since.
# The RGB image goes through cv2.warpPerspective's bilinear kernel, which differs between
# OpenCV versions (render.py), so its digest is recorded per version.
GOLDEN_ARRAYS = {
    "homography": "cabba0ad4ca29dd0d3f2365a6faa6a5b28860edcb21aa49b0efc2f55d1240a6f",
    "semantic": "4cc3eaa201beccb4b58e50eaab3f0f450cf08e93252a7ab15cc92f290d1e6fd0",
}
# The 5.1.0 one was computed by the code before the speed-up (d2bad53~1 = a3ffd61) run under OpenCV 5.1.0.
GOLDEN_IMAGE = {"5.0.0": "a111dc2456e13c72e96b8f4160478f4b6ab193f68c964fb22b37bd459a43b653",
                "5.1.0": "967844cb31a0f45a0dfa7d4bc60b97557b07c0b2ffec29a27fe716d0f4d01936"}


def test_arrays_bit_identical_to_their_recorded_digests(reference):
    group = open_store(reference)
    digests = {name: hashlib.sha256(group[name][:].tobytes()).hexdigest() for name in (*GOLDEN_ARRAYS, "image")}
    assert {name: digests[name] for name in GOLDEN_ARRAYS} == GOLDEN_ARRAYS
    assert cv2.__version__ in GOLDEN_IMAGE, f"no image digest recorded for OpenCV {cv2.__version__}"
    assert digests["image"] == GOLDEN_IMAGE[cv2.__version__]


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


# --- one writer, clean resumes, no orphans (issue 11) ---------------------------------------


def cli_generate(out: Path, *extra: str) -> list[str]:
    """The `synthcal generate` command line of the module's ``spec`` (smoke profile) as a subprocess."""
    import sys

    return [sys.executable, "-m", "synthcal.cli", "generate", "intersection-2", "--profile", "smoke",
            "--config", str(ROOT / "datasets.yaml"), "--out", str(out), "--quiet", *extra]


def test_a_second_generate_of_the_same_store_exits_2_naming_the_lock(spec, reference, tmp_path):
    import os
    import subprocess
    import threading

    reached, release = threading.Event(), threading.Event()

    def hold_after_first_shard(count: int) -> None:
        reached.set()
        assert release.wait(120)

    first = threading.Thread(target=generate_dataset, args=(spec, tmp_path),
                             kwargs={"progress": False, "on_shard": hold_after_first_shard})
    first.start()
    try:
        assert reached.wait(120)
        before = store_files(tmp_path / f"{spec.name}.zarr.partial")
        second = subprocess.run(cli_generate(tmp_path), capture_output=True, text=True, timeout=120)
        after = store_files(tmp_path / f"{spec.name}.zarr.partial")
    finally:
        release.set()
        first.join()
    assert second.returncode == 2, second.stderr
    assert second.stderr.startswith(f"synthcal: error: {tmp_path / spec.name}.zarr: another synthcal process "
                                    f"(PID {os.getpid()}) is writing this store (lock {tmp_path}/.{spec.name}.lock)")
    assert after == before, "the refused run touched nothing"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f".{spec.name}.lock", f"{spec.name}.zarr"]
    assert store_files(tmp_path / f"{spec.name}.zarr") == store_files(reference)


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (from /proc)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(stat.parent.name))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def alive(pid: int) -> bool:
    """Running, not a zombie awaiting its reaper."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_kill_9_leaves_no_worker_and_the_run_resumes_to_the_same_bytes(spec, tmp_path):
    import signal
    import subprocess
    import time

    big = spec.model_copy(update={"pool_size": 240})  # 30 shards: time to kill it mid-run
    out = tmp_path / "killed"
    run = subprocess.Popen(cli_generate(out, "--n", "240", "--workers", "2"))
    progress = out / f".{spec.name}.zarr.progress"
    deadline = time.monotonic() + 120
    while not any(progress.glob("*.done")) and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = descendants(run.pid)
    run.send_signal(signal.SIGKILL)
    run.wait()
    assert not (out / f"{spec.name}.zarr").exists(), "killed mid-run"
    assert len(workers) >= 2, "two workers (and the resource tracker) were running"
    deadline = time.monotonic() + 30  # a bound on waiting, not a speed requirement
    while any(map(alive, workers)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [pid for pid in workers if alive(pid)], "no process of the killed run is left"

    # what a kill between a file's write and its rename leaves (atomic_write's and zarr's temporaries)
    partial = out / f"{spec.name}.zarr.partial"
    shard_folder = partial / "image" / "c" / "0" / "0" / "0"
    shard_folder.mkdir(parents=True, exist_ok=True)  # shard 0 may not have been written yet
    (shard_folder / ".0.4242-0123abcd.tmp").write_bytes(b"torn")
    (partial / "zarr.0123456789abcdef0123456789abcdef.partial").write_bytes(b"torn")
    resumed = generate_dataset(big, out, progress=False)
    fresh = generate_dataset(big, tmp_path / "fresh", progress=False)
    assert store_files(resumed) == store_files(fresh), "same file list, same bytes"
    assert sorted(p.name for p in out.iterdir()) == [f".{spec.name}.lock", f"{spec.name}.zarr"]


def test_a_progress_folder_left_by_a_kill_after_the_final_rename_goes_away(spec, reference, tmp_path):
    import shutil

    store = Path(shutil.copytree(reference, tmp_path / reference.name))
    progress = tmp_path / f".{spec.name}.zarr.progress"
    progress.mkdir()
    (progress / "shard-0000000.done").touch()
    assert generate_dataset(spec, tmp_path, progress=False) == store
    assert not progress.exists() and store_files(store) == store_files(reference)


def test_dataset_names_are_plain_names(tmp_path):
    from synthcal.config import ConfigError
    from synthcal.generate.pipeline import store_path

    text = (ROOT / "datasets.yaml").read_text().replace("\n  intersection-2:", "\n  ../escaped:", 1)
    assert "../escaped:" in text
    config = tmp_path / "datasets.yaml"
    config.write_text(text)
    with pytest.raises(ConfigError, match=rf"{config}: datasets\.\.\./escaped: a dataset name is a plain name.*"
                                          r"\(value '\.\./escaped'\)"):
        load_config(config)
    for name in ("/abs", "a/b", "..", ".", ""):
        with pytest.raises(ConfigError, match="plain name"):
            store_path(tmp_path, name)
    assert store_path(tmp_path, "v1.2_b-c") == tmp_path / "v1.2_b-c.zarr"
