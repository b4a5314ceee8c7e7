"""Estimators (SPEC §9): loading, the example plug-in, the store-reading oracle through
the public plug-in path, and the simple bundled estimators on a small synthetic world.

Split and scene objects are stand-ins (SimpleNamespace) carrying the attributes the
interface promises: .images, .semantics, .homographies, .indices, .store; .image,
.semantic, .palette, .classes.
"""

import importlib.metadata
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import zarr

from synthcal.estimators import (
    ENTRY_POINT_GROUP,
    ColourSegmenter,
    ECCEstimator,
    Estimator,
    EstimatorError,
    IdentityEstimator,
    TemplateEstimator,
    bundled_estimators,
    ecc_warp,
    known_estimators,
    load_estimator,
    medoid_index,
    one_hot,
    registry,
)
from synthcal.eval.metrics import iou
from synthcal.eval.polygon import iou_whole
from synthcal.eval.scoring import evaluate
from synthcal.generate.camera import homography
from synthcal.generate.render import render_image, render_semantic

ROOT = Path(__file__).resolve().parents[2]
SIZE = (64, 36)
PALETTE = np.array([[0, 0, 0], [90, 90, 90], [40, 160, 40], [200, 50, 50]], np.uint8)


def make_scene(seed: int = 0, shape=(400, 300)) -> SimpleNamespace:
    coarse = np.random.default_rng(seed).integers(0, 4, (shape[0] // 25, shape[1] // 25)).astype(np.uint8)
    semantic = cv2.resize(coarse, shape[::-1], interpolation=cv2.INTER_NEAREST)
    return SimpleNamespace(image=PALETTE[semantic], semantic=semantic, palette=PALETTE,
                           classes=("background", "road", "terrain", "bicycle path"))


def make_split(scene, pans, tilts, focal=40.0, size=SIZE, store="unused", start=0) -> SimpleNamespace:
    n = len(pans)
    H = homography(np.asarray(pans, float), np.asarray(tilts, float), np.full(n, focal),
                   np.tile([150.0, 200.0, 40.0], (n, 1)), size)
    return SimpleNamespace(
        images=np.stack([render_image(scene.image, h, size) for h in H]),
        semantics=np.stack([render_semantic(scene.semantic, h, size) for h in H]),
        homographies=H, indices=np.arange(start, start + n), store=store,
    )


@pytest.fixture(scope="module")
def world():
    scene = make_scene()
    grid = [(p, t) for p in range(-30, 31, 6) for t in (-25, -18, -12)]
    train = make_split(scene, *zip(*grid, strict=True))
    dictionary = make_split(scene, *zip(*grid[::2], strict=True))
    test = make_split(scene, [-20.5, -7.0, 4.2, 17.0], [-22.0, -14.0, -19.0, -13.0])
    return scene, train, dictionary, test


# --- loading ----------------------------------------------------------------------------------


def test_bundled_names_and_dotted_paths_load():
    assert isinstance(load_estimator("identity"), IdentityEstimator)
    assert isinstance(load_estimator("template"), TemplateEstimator)
    ecc = load_estimator("ecc", iterations=7)
    assert isinstance(ecc, ECCEstimator) and ecc.iterations == 7
    template = load_estimator("synthcal.estimators.classic:TemplateEstimator", stride=4)
    assert type(template) is TemplateEstimator and template.stride == 4
    assert isinstance(template, Estimator)
    assert {"identity", "template", "ecc"} <= set(known_estimators())


def test_bundled_names_are_synthcals_entry_points():
    """pyproject.toml's entry-point table is the one list of bundled names (``sha2020`` included).

    Reads the *installed* metadata: after a change of the table, ``pip install -e .``.
    """
    bundled = bundled_estimators()
    assert set(bundled) == {"identity", "template", "ecc", "proposed", "baseline", "sha2020", "sha2020-ccbv",
                            "retrieved", "oracle-template"}
    assert bundled["sha2020"] == bundled["baseline"] == "synthcal.estimators.paper:BaselineEstimator"
    assert bundled.items() <= known_estimators().items()


def test_a_plugin_cannot_shadow_a_bundled_name(monkeypatch):
    real = registry.estimator_entry_points()
    # Listed first, from no synthcal distribution: a third party's "identity".
    impostor = importlib.metadata.EntryPoint(name="identity", value="collections:OrderedDict", group=ENTRY_POINT_GROUP)
    monkeypatch.setattr(registry, "estimator_entry_points", lambda: [impostor, *real])
    assert isinstance(load_estimator("identity"), IdentityEstimator)
    assert known_estimators()["identity"] == "synthcal.estimators.classic:IdentityEstimator"


def test_missing_entry_points_are_explained(monkeypatch):
    monkeypatch.setattr(registry, "estimator_entry_points", lambda: [])
    with pytest.raises(EstimatorError, match="unknown estimator 'identity'.*synthcal's entry points are missing"):
        load_estimator("identity")


@pytest.mark.parametrize("value, fragment", [
    ("no-such-estimator", "unknown estimator 'no-such-estimator'"),
    ("nosuchpackage.module:Thing", "cannot import module 'nosuchpackage.module'"),
    ("synthcal.estimators.classic:NoSuchClass", "has no attribute 'NoSuchClass'"),
    ("collections:OrderedDict", "has no fit(train, dictionary, scene)"),
    (":Thing", "expected 'package.module:Class'"),
])
def test_unresolvable_values_are_named(value, fragment):
    with pytest.raises(EstimatorError) as error:
        load_estimator(value)
    assert repr(value) in str(error.value) and fragment in str(error.value)
    if ":" not in value:
        assert "identity" in str(error.value)  # the known names are listed


def test_bad_options_name_the_estimator():
    with pytest.raises(EstimatorError, match="'identity'.*no_such_option"):
        load_estimator("identity", no_such_option=1)


def test_example_plugin_by_dotted_path_and_entry_point(world, monkeypatch):
    scene, train, dictionary, _ = world
    monkeypatch.syspath_prepend(str(ROOT / "examples" / "plugin_estimator"))
    path = "synthcal_plugin_example:NearestThumbnailEstimator"
    estimator = load_estimator(path)
    assert type(estimator).__name__ == "NearestThumbnailEstimator" and isinstance(estimator, Estimator)
    estimator.fit(train, dictionary, scene)
    np.testing.assert_array_equal(estimator.predict(train.images[:5]), train.homographies[:5])

    fake = importlib.metadata.EntryPoint(name="nearest-thumbnail", value=path, group=ENTRY_POINT_GROUP)

    def entry_points(**selection):
        found = importlib.metadata.EntryPoints([fake])
        return found.select(**selection) if selection else found

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)
    plugin = load_estimator("nearest-thumbnail", width=16, height=9)
    assert type(plugin) is type(estimator) and plugin.size == (16, 9)
    assert known_estimators()["nearest-thumbnail"] == path


def test_oracle_plugin_reads_the_store_and_scores_one(world, tmp_path, monkeypatch):
    """The oracle gets labels only through the store path the splits carry, like any plug-in."""
    scene, train, dictionary, test = world
    everything = [train, dictionary, test]
    store = tmp_path / "tiny.zarr"
    group = zarr.open_group(str(store), mode="w")
    group.create_array("image", data=np.concatenate([s.images for s in everything]))
    group.create_array("homography", data=np.concatenate([s.homographies for s in everything]))
    splits = [SimpleNamespace(**{**vars(s), "store": store}) for s in everything]

    monkeypatch.syspath_prepend(str(ROOT / "tests"))
    oracle = load_estimator("synthcal_oracle_plugin:OracleEstimator")
    oracle.fit(splits[0], splits[1], scene)
    images = np.concatenate([test.images, np.zeros_like(test.images[:1])])  # + one unknown image
    truth = np.concatenate([test.homographies, test.homographies[:1]])
    frame = evaluate(scene.semantic, oracle.predict(images), truth, SIZE)
    assert (frame.loc[: len(test.images) - 1, ["iou", "iou_part", "iou_whole"]] == 1.0).all().all()
    assert frame["failed"].tolist() == [False] * len(test.images) + [True]
    assert frame["failure"].iloc[-1] == "non-finite entries"


# --- the simple estimators ---------------------------------------------------------------------


def test_medoid_matches_brute_force():
    rng = np.random.default_rng(3)
    maps = rng.integers(0, 4, (9, 6, 5)).astype(np.uint8)
    maps[4] = np.median(maps, axis=0).astype(np.uint8)  # a central-ish map
    x = one_hot(maps)
    brute = np.argmin(((x[:, None] - x[None]) ** 2).sum(-1).mean(1))
    assert medoid_index(maps, chunk=4) == brute


def test_identity_ignores_the_image(world):
    scene, train, dictionary, test = world
    estimator = IdentityEstimator()
    estimator.fit(train, dictionary, scene)
    H = estimator.predict(test.images)
    assert H.shape == (len(test.images), 3, 3)
    np.testing.assert_array_equal(H, np.repeat(train.homographies[medoid_index(train.semantics)][None], len(H), 0))


def test_colour_segmenter_learns_the_palette(world):
    _, train, _, test = world
    segmenter = ColourSegmenter()
    segmenter.fit(train.images, train.semantics)
    accuracy = (segmenter(test.images) == test.semantics).mean()
    assert accuracy > 0.95  # errors only on anti-aliased class borders


def test_template_returns_the_nearest_template(world):
    scene, train, dictionary, test = world
    estimator = TemplateEstimator()
    estimator.fit(train, dictionary, scene)
    # A dictionary image is its own nearest template.
    np.testing.assert_array_equal(estimator.predict(dictionary.images[3:6]), dictionary.homographies[3:6])
    identity = IdentityEstimator()
    identity.fit(train, dictionary, scene)
    ours = [iou(scene.semantic, h, t, SIZE) for h, t in zip(estimator.predict(test.images), test.homographies, strict=True)]
    base = [iou(scene.semantic, h, t, SIZE) for h, t in zip(identity.predict(test.images), test.homographies, strict=True)]
    assert np.mean(ours) > np.mean(base) + 0.1


def _small_warp(size):
    """A known small image homography: scale 1.03 about the centre, a shift, a little perspective."""
    cx, cy = (size[0] - 1) / 2, (size[1] - 1) / 2
    centre = np.array([[1.0, 0, cx], [0, 1.0, cy], [0, 0, 1]])
    local = np.array([[1.03, 0.01, 1.5], [-0.01, 1.03, -1.0], [2e-4, -1e-4, 1.0]])
    return centre @ local @ np.linalg.inv(centre)


def test_ecc_recovers_a_known_image_warp():
    size = (128, 72)
    scene = make_scene(seed=5)
    H0 = homography([5.0], [-20.0], [80.0], [[150.0, 200.0, 40.0]], size)[0]
    W0 = _small_warp(size)
    template = render_semantic(scene.semantic, H0, size)
    target = render_semantic(scene.semantic, W0 @ H0, size)
    W = ecc_warp(template, target)
    assert W is not None
    ys, xs = np.mgrid[0:size[1]:4, 0:size[0]:4]
    points = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])

    def project(M):
        p = M @ points
        return p[:2] / p[2]

    error = np.linalg.norm(project(W) - project(W0), axis=0)
    unrefined = np.linalg.norm(project(np.eye(3)) - project(W0), axis=0)
    # The warp moves pixels by ~2 px on average; ECC on nearest-neighbour class maps
    # recovers it to a fifth of a pixel (the direction convention is what is at stake:
    # the inverse warp would double the error).
    assert unrefined.mean() > 1.5
    assert error.mean() < 0.25 and error.max() < 0.75


def test_ecc_estimator_composes_the_warp_with_the_template(world):
    size = (128, 72)
    scene = make_scene(seed=5)
    H0 = homography([5.0], [-20.0], [80.0], [[150.0, 200.0, 40.0]], size)[0]
    H1 = _small_warp(size) @ H0

    def split(H):
        return SimpleNamespace(images=np.stack([render_image(scene.image, h, size) for h in H]),
                               semantics=np.stack([render_semantic(scene.semantic, h, size) for h in H]),
                               homographies=H, indices=np.arange(len(H)), store="unused")

    dictionary, test = split(H0[None]), split(H1[None])
    estimator = ECCEstimator()
    estimator.fit(dictionary, dictionary, scene)
    H = estimator.predict(test.images)[0]
    template_score = iou(scene.semantic, H0, H1, size)
    assert iou(scene.semantic, H, H1, size) > max(0.97, template_score + 0.1)
    assert iou_whole(H, H1, size) > 0.98
