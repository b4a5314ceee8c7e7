"""Aligned OSM scenes: the turn that lines a junction's legs up with a layout, and scenes drawn turned.

The fixture junction's legs are drawn at known bearings (35/125/215/305°: a right-angled
crossing turned 35° against intersection-1); what the tests expect is computed from
those drawn bearings and from cv2 rotating the north-up raster, never read back through
the code under test.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
from osm_fixtures import CENTER, OsmXml, ahead  # noqa: E402

from synthcal.cli import main  # noqa: E402
from synthcal.config import ConfigError, load_config  # noqa: E402
from synthcal.scenes import SceneError  # noqa: E402
from synthcal.scenes.osm import build_osm_scene, osm_attributes  # noqa: E402
from synthcal.scenes.osm.junctions import find_junctions, layout_bearings, layout_rotation, rank  # noqa: E402

LEGS = (35.0, 125.0, 215.0, 305.0)
SIZE_M, PPM = (60.0, 60.0), 4.0
TOLERANCE = 0.5  # degrees: the fixture's 7-decimal coordinates and local tangent plane


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SYNTHCAL_CACHE", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture(scope="module")
def turned_cross(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two primary roads crossing at the centre, along bearings 35–215° and 125–305°."""
    osm = OsmXml()
    for bearing in LEGS[:2]:
        osm.way([ahead((0.0, 0.0), bearing + 180.0, 150.0), (0.0, 0.0), ahead((0.0, 0.0), bearing, 150.0)],
                {"highway": "primary", "lanes": "2"})
    return osm.write(tmp_path_factory.mktemp("osm") / "turned.osm")


def _off(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_the_rotation_brings_the_drawn_legs_onto_the_reference(turned_cross):
    (junction,) = rank(find_junctions(turned_cross), "intersection-1")
    turned = sorted((b + junction.rotation) % 360.0 for b in LEGS)
    assert all(_off(t, r) < TOLERANCE for t, r in zip(turned, (0.0, 90.0, 180.0, 270.0), strict=True)), turned
    assert _off(junction.rotation, -35.0) < TOLERANCE  # the smallest of the four equal turns
    assert junction.difference < TOLERANCE


def test_layout_rotation_picks_the_smallest_turn_of_the_minimum():
    skew = layout_bearings("intersection-2")  # symmetric under 180° only: 2 equal turns
    assert layout_rotation([b - 20.0 for b in skew], skew) == pytest.approx(20.0)
    assert layout_rotation([b + 170.0 for b in skew], skew) == pytest.approx(10.0)  # not −170
    plain = layout_bearings("intersection-1")
    assert layout_rotation((45.0, 135.0, 225.0, 315.0), plain) == pytest.approx(45.0)  # a tie: clockwise
    assert layout_rotation(plain, plain) == 0.0


def _road(semantic: np.ndarray, east: float, south: float) -> bool:
    height, width = semantic.shape
    return bool(semantic[round((height - 1) / 2 + south * PPM), round((width - 1) / 2 + east * PPM)] == 1)


def test_a_turned_scene_has_its_roads_along_the_image_axes(turned_cross):
    (junction,) = rank(find_junctions(turned_cross), "intersection-1")
    turned = build_osm_scene(turned_cross, CENTER, SIZE_M, PPM, rotation_deg=junction.rotation, cache=False)
    north_up = build_osm_scene(turned_cross, CENTER, SIZE_M, PPM, cache=False)
    for semantic, legs in ((turned.semantic, (0.0, 90.0)), (north_up.semantic, LEGS[:2])):
        for bearing in legs:  # 20 m out along each leg: road; 20 m out between legs: none
            for at in (bearing, bearing + 180.0, bearing + 45.0, bearing + 135.0):
                east, north = ahead((0.0, 0.0), at, 20.0)
                assert _road(semantic, east, -north) == (at in (bearing, bearing + 180.0)), (legs, at)
    # The same as the north-up raster turned by cv2 (positive angles counter-clockwise on screen).
    height, width = north_up.semantic.shape
    matrix = cv2.getRotationMatrix2D(((width - 1) / 2, (height - 1) / 2), -junction.rotation, 1.0)
    warped = cv2.warpAffine(north_up.semantic, matrix, (width, height), flags=cv2.INTER_NEAREST)
    v, u = np.mgrid[:height, :width]
    inside = np.hypot(u - (width - 1) / 2, v - (height - 1) / 2) < min(width, height) / 2 - 2  # turned corners differ
    a, b = (turned.semantic == 1) & inside, (warped == 1) & inside
    assert (a & b).sum() / (a | b).sum() > 0.95
    assert f"rotation_deg {junction.rotation:g}" in turned.description and "rotation" not in north_up.description


def test_a_bad_rotation_is_one_line_naming_the_key(turned_cross, tmp_path):
    for value in (math.nan, math.inf, "east"):
        with pytest.raises(SceneError, match=rf"osm\.rotation_deg \(.*turned\.osm\).*value {value!r}"):
            build_osm_scene(turned_cross, CENTER, SIZE_M, PPM, rotation_deg=value, cache=False)  # type: ignore[arg-type]
    path = tmp_path / "datasets.yaml"
    for value in (".inf", "east"):
        path.write_text(f"scenes:\n  x:\n    osm: {{file: {turned_cross}, center: [{CENTER[0]}, {CENTER[1]}], "
                        f"rotation_deg: {value}}}\n")
        with pytest.raises(ConfigError, match=r"scenes\.x\.osm\.rotation_deg"):
            load_config(path)


def test_north_up_keeps_its_hash_and_attributes_a_turn_is_recorded(turned_cross, tmp_path):
    path = tmp_path / "datasets.yaml"
    entry = f"osm: {{file: {turned_cross}, center: [{CENTER[0]}, {CENTER[1]}], size_m: [60, 60]"
    path.write_text(f"scenes:\n  a: {{{entry}}}}}\n  b: {{{entry}, rotation_deg: 0.0}}}}\n"
                    f"  c: {{{entry}, rotation_deg: 35}}}}\n")
    scenes = load_config(path).config.scenes
    assert scenes["a"].model_dump() == scenes["b"].model_dump() and "rotation_deg" not in str(scenes["a"].model_dump())
    assert scenes["c"].osm.rotation_deg == 35.0 and scenes["c"].model_dump()["osm"]["rotation_deg"] == 35.0
    assert "rotation_deg" not in osm_attributes(turned_cross, CENTER, SIZE_M, PPM)
    assert osm_attributes(turned_cross, CENTER, SIZE_M, PPM, rotation_deg=35.0)["rotation_deg"] == 35.0


def test_the_mix_snippet_turns_each_junction_onto_the_target(turned_cross, tmp_path, capsys):
    snippet = tmp_path / "osm.yaml"
    assert main(["osm-junctions", str(turned_cross), "--legs", "4", "--like", "intersection-1", "--csv",
                 str(tmp_path / "j.csv"), "--datasets", "1", "--mix-for", "intersection-1", "--yaml", str(snippet)]) == 0
    text = snippet.read_text()
    (scene,) = yaml.safe_load(text)["scenes"].values()
    assert _off(scene["osm"]["rotation_deg"], -35.0) < TOLERANCE and "rotation_deg" in text.split("\nscenes:")[0]
    (name,) = [k for k in yaml.safe_load(text)["scenes"]]
    assert load_config(snippet).config.scenes[name].osm.rotation_deg == scene["osm"]["rotation_deg"]
    row = (tmp_path / "j.csv").read_text().splitlines()
    assert row[0].endswith(",rotation_deg") and _off(float(row[1].rsplit(",", 1)[1]), -35.0) < TOLERANCE
