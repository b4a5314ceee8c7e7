"""OpenStreetMap scenes: the frame, the classes at known points, widths, determinism, bad input.

The fixtures (``osm_fixtures.py``) are OSM XML written in the tests from metres in
the frame; classes are looked up at pixels computed from the frame's formula
(``u = (W − 1)/2 + E·ppm``, ``v = (H − 1)/2 − N·ppm``) with an independent pyproj
transformer, never through the code under test. Scenes are tiny (60 × 80 m at
2–4 px/m).
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
from osm_fixtures import CENTER, OsmXml, junction, metres_of, pixel  # noqa: E402

from synthcal.cli import main  # noqa: E402
from synthcal.config import load_config  # noqa: E402
from synthcal.scenes import SceneError  # noqa: E402
from synthcal.scenes.osm import build_osm_scene  # noqa: E402
from synthcal.scenes.osm.read import Frame  # noqa: E402

SIZE_M, PPM = (60.0, 80.0), 4.0


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SYNTHCAL_CACHE", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture(scope="module")
def osm_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return junction(tmp_path_factory.mktemp("osm") / "junction.osm")


def _class_at(semantic: np.ndarray, east: float, north: float, ppm: float = PPM) -> int:
    row, col = pixel(east, north, (semantic.shape[1], semantic.shape[0]), ppm)
    return int(semantic[row, col])


def _build(path: Path, **kwargs) -> np.ndarray:
    settings = {"size_m": SIZE_M, "pixels_per_metre": PPM, "cache": False} | kwargs
    return build_osm_scene(path, CENTER, **settings).semantic


# --------------------------------------------------------------------------- frame


def test_frame_formula_against_an_independent_projection():
    frame = Frame(CENTER[0], CENTER[1], 60.0, 80.0, 4.0)
    assert (frame.width, frame.height) == (240, 320)
    lon, lat = 5.0003, 52.0002
    east, north = metres_of(lon, lat)
    mine = frame.metres(lon, lat)
    assert abs(float(mine[0]) - east) < 1e-6 and abs(float(mine[1]) - north) < 1e-6
    # ~ 20.6 m east (cos 52° × 111.3 km × 0.0003°), ~ 22.3 m north: north is up (v decreases)
    assert 20.0 < east < 21.0 and 21.5 < north < 23.0
    u, v = frame.pixels(east, north)
    assert float(u) == pytest.approx(119.5 + east * 4.0) and float(v) == pytest.approx(159.5 - north * 4.0)


def test_defaults_match_the_paper_grid(osm_file):
    scene = build_osm_scene(osm_file, CENTER, cache=False)
    assert scene.semantic.shape == (1900, 1300)
    assert scene.camera_position == (650.0, 950.0, 75.0)
    assert scene.classes == ("background", "road", "terrain", "bicycle path")
    assert "OpenStreetMap contributors" in scene.description


# --------------------------------------------------------------------------- classes


def test_classes_at_known_points(osm_file):
    semantic = _build(osm_file)
    assert semantic.shape == (320, 240)
    expected = {
        (-15.0, 0.0): 1, (15.0, 0.0): 1,  # the primary's carriageway, west and east legs
        (0.0, 20.0): 1, (0.0, -30.0): 1,  # the residential street, north and south
        (0.0, 0.0): 1,  # the junction
        (0.0, -15.0): 1,  # the cycleway crosses the street: the carriageway wins
        (4.0, 20.0): 3,  # cycleway:right=track of the northbound street: east of it
        (-4.0, 20.0): 0,  # ... and nothing on its left (west)
        (-20.0, -15.0): 3, (20.0, -15.0): 3,  # the separate highway=cycleway
        (-20.0, 25.0): 2, (-12.0, 14.0): 2,  # park interior
        (18.0, 18.0): 0,  # the building
        (20.0, -30.0): 0,  # plain ground
    }
    got = {point: _class_at(semantic, *point) for point in expected}
    assert got == expected


def test_track_lies_on_the_right_only(osm_file):
    semantic = _build(osm_file)
    row, _ = pixel(0.0, 25.0, (240, 320), PPM)
    bike = np.flatnonzero(semantic[row] == 3)
    u = (bike - 119.5) / PPM  # metres east
    assert len(bike) > 0 and u.min() > 2.4 and u.max() < 5.6  # half width 2.5 m + 0.5 m gap + 2 m track


@pytest.mark.parametrize("tags, width_m", [({"lanes": "2"}, 6.5), ({"lanes": "4"}, 13.0),
                                           ({"lanes": "2", "width": "10"}, 10.0), ({"lanes": "1"}, 3.25)])
def test_width_and_lanes_set_the_carriageway(tmp_path, tags, width_m):
    semantic = _build(junction(tmp_path / "j.osm", primary=tags))
    _, col = pixel(-20.0, 0.0, (240, 320), PPM)
    _, col2 = pixel(22.0, 0.0, (240, 320), PPM)
    for c in (col, col2):
        measured = int((semantic[:, c] == 1).sum()) / PPM
        assert abs(measured - width_m) <= 1.0 / PPM + 1e-9, (tags, measured)


def test_class_override_moves_selectors(osm_file):
    semantic = _build(osm_file, classes={"background": ["highway=cycleway"], "terrain": ["building=*"]})
    assert _class_at(semantic, -20.0, -15.0) == 0
    assert _class_at(semantic, 18.0, 18.0) == 2
    assert _class_at(semantic, -15.0, 0.0) == 1


def test_multipolygon_park_with_a_hole(tmp_path):
    osm = OsmXml()
    osm.way([(-100.0, 0.0), (100.0, 0.0)], {"highway": "residential"})
    ids = []
    for ring in ([(-28.0, 5.0), (28.0, 5.0), (28.0, 38.0), (-28.0, 38.0)], [(-10.0, 15.0), (10.0, 15.0),
                                                                              (10.0, 30.0), (-10.0, 30.0)]):
        osm.way(ring, {}, closed=True)
        ids.append(len(osm.ways))
    members = "".join(f'<member type="way" ref="{i}" role="{role}"/>' for i, role in
                      zip(ids, ("outer", "inner"), strict=True))
    osm.ways.append(f'<relation id="1" version="1">{members}<tag k="type" v="multipolygon"/>'
                    f'<tag k="leisure" v="park"/></relation>')
    semantic = _build(osm.write(tmp_path / "mp.osm"))
    assert _class_at(semantic, -20.0, 25.0) == 2 and _class_at(semantic, 0.0, 22.0) == 0
    assert _class_at(semantic, 0.0, 0.0) == 1


# --------------------------------------------------------------------------- determinism, cache, attributes


def _png(array: np.ndarray) -> bytes:
    return cv2.imencode(".png", array)[1].tobytes()


def test_same_file_centre_and_seed_give_identical_pngs(osm_file, tmp_path):
    a = build_osm_scene(osm_file, CENTER, SIZE_M, PPM, seed=3, cache=False)
    b = build_osm_scene(osm_file, CENTER, SIZE_M, PPM, seed=3, cache=False)
    c = build_osm_scene(osm_file, CENTER, SIZE_M, PPM, seed=4, cache=False)
    assert _png(a.image) == _png(b.image) and _png(a.semantic) == _png(b.semantic)
    assert _png(a.image) != _png(c.image) and _png(a.semantic) == _png(c.semantic)  # the seed is the RGB's only
    # the command line writes the same bytes, twice
    for out in ("one", "two"):
        assert main([*_osm_argv(osm_file, tmp_path / out, ppm="4"), "--seed", "3"]) == 0
    for name in ("image.png", "semantic.png"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes()
    assert cv2.imread(str(tmp_path / "one" / "semantic.png"), cv2.IMREAD_UNCHANGED).tobytes() == a.semantic.tobytes()


def test_a_way_cut_by_the_extract_keeps_its_runs_and_says_so(tmp_path):
    """A road whose first and last nodes lie outside the extract keeps its part through the
    window; a gap inside a way is not bridged; the provenance counts the missing nodes."""
    from synthcal.scenes.osm import osm_attributes

    osm = OsmXml()
    # North–south through the centre, its ends 150 m out and absent from the file.
    osm.way([(0.0, -150.0), (0.0, -20.0), (0.0, 20.0), (0.0, 150.0)], {"highway": "secondary"}, absent=(0, 3))
    # West–east at N = −30 with a node missing in the middle: two runs, 10 m apart.
    osm.way([(-25.0, -30.0), (-5.0, -30.0), (0.0, -300.0), (5.0, -30.0), (25.0, -30.0)], {"highway": "secondary"},
            absent=(2,))
    path = osm.write(tmp_path / "cut.osm")
    semantic = _build(path)
    # 6.5 m wide (secondary): road on the centre line of each located run ...
    assert [_class_at(semantic, 0.0, n) for n in (-15.0, 0.0, 15.0)] == [1, 1, 1]
    assert [_class_at(semantic, e, -30.0) for e in (-20.0, -8.0, 8.0, 20.0)] == [1, 1, 1, 1]
    # ... but not across the gap (round caps reach 3.25 m past E = ±5) nor beyond the last located node.
    assert _class_at(semantic, 0.0, -30.0) == 0 and _class_at(semantic, 0.0, 30.0) == 0
    source = osm_attributes(path, CENTER, SIZE_M, PPM)
    assert (source["missing_nodes"], source["cut_ways"]) == (3, 2)


def test_built_once_and_cached_by_content(osm_file, tmp_path, monkeypatch):
    import synthcal.scenes.osm.build as osm

    cache = tmp_path / "c"
    monkeypatch.setenv("SYNTHCAL_CACHE", str(cache))
    first = build_osm_scene(osm_file, CENTER, SIZE_M, PPM, seed=1)
    assert len(list((cache / "osm").glob("*/image.png"))) == 1
    osm.forget_scenes_in_memory()
    calls = []
    monkeypatch.setattr(osm, "paint_window", lambda *a: calls.append(a))
    again = build_osm_scene(osm_file, CENTER, SIZE_M, PPM, seed=1)  # from the disk cache
    assert not calls and again.image.tobytes() == first.image.tobytes()
    assert again.semantic.tobytes() == first.semantic.tobytes()


def _yaml(tmp_path: Path, osm_file: Path, **osm) -> Path:
    entry = {"file": osm_file.name, "center": list(CENTER), "size_m": [60, 80], "pixels_per_metre": 2} | osm
    text = {
        "grids": {"tiny": {"pan_deg": {"start": -180, "stop": 180, "step": 90}, "tilt_deg": {"start": -20, "stop": 0,
                           "step": 20}, "focal_px": {"start": 100, "stop": 100, "step": 50},
                           "x": {"start": 50, "stop": 70, "step": 10}, "y": {"start": 70, "stop": 90, "step": 10},
                           "z": {"start": 10, "stop": 10, "step": 10}}},
        "scenes": {"my-junction": {"osm": entry}},
        "datasets": {"my-junction": {"scene": "my-junction", "grid": "tiny", "pool_size": 6, "image_size": [32, 24]}},
    }
    (tmp_path / osm_file.name).write_bytes(osm_file.read_bytes())
    path = tmp_path / "datasets.yaml"
    path.write_text(yaml.safe_dump(text))
    return path


def test_generate_and_scene_from_a_yaml_entry(osm_file, tmp_path, capsys):
    config = _yaml(tmp_path, osm_file)
    assert main(["generate", "my-junction", "--out", str(tmp_path / "out"), "--quiet", "--config", str(config)]) == 0
    assert main(["info", str(tmp_path / "out" / "my-junction.zarr"), "--json"]) == 0
    out = capsys.readouterr().out
    attrs = json.loads(out[out.index("{"):])
    source = attrs["scene"]["source"]
    assert source["sha256"] == hashlib.sha256(osm_file.read_bytes()).hexdigest()
    assert source["center"] == list(CENTER) and source["size_m"] == [60.0, 80.0]
    assert source["licence"] == "ODbL-1.0" and source["attribution"] == "© OpenStreetMap contributors"
    assert (source["missing_nodes"], source["cut_ways"]) == (0, 0)  # the junction's ways are whole
    # The store's recorded configuration reads back: splits can be drawn from it.
    store = str(tmp_path / "out" / "my-junction.zarr")
    assert main(["split", store, "--seeds", "0", "--train", "2", "--test", "2", "--dictionary", "2", "--validation", "0"]) == 0
    assert main(["scene", "my-junction", "-o", str(tmp_path / "scene.png"), "--config", str(config)]) == 0
    assert cv2.imread(str(tmp_path / "scene.png")) is not None


def test_png_scenes_keep_their_configuration_hash(tmp_path):
    from synthcal.config import UserSceneConfig

    entry = UserSceneConfig(image=Path("a.png"), semantic=Path("b.png"))
    assert "osm" not in entry.model_dump(mode="json")


# --------------------------------------------------------------------------- bad input


def _error(capsys: pytest.CaptureFixture, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("synthcal: error: ") and "\n" not in err
    return err


def _osm_argv(path: Path, out: Path, center: str = f"{CENTER[0]},{CENTER[1]}", size: str = "60,80",
              ppm: str = "2") -> list[str]:
    return ["osm", str(path), "--center", center, "--size", size, "--ppm", ppm, "-o", str(out)]


def test_bad_inputs_name_file_key_and_value_and_write_nothing(osm_file, tmp_path, capsys):
    out = tmp_path / "out"
    missing = tmp_path / "nowhere.osm"
    assert str(missing) in _error(capsys, _osm_argv(missing, out))
    garbage = tmp_path / "garbage.osm"
    garbage.write_text("this is not XML <<<")
    err = _error(capsys, _osm_argv(garbage, out))
    assert str(garbage) in err and "cannot read" in err
    err = _error(capsys, _osm_argv(osm_file, out, center="10.0,10.0"))
    assert "osm.center" in err and "outside the data" in err and str(osm_file) in err and "10.0" in err
    lon, lat = _far_inside(osm_file)
    err = _error(capsys, _osm_argv(osm_file, out, center=f"{lat},{lon}"))
    assert "no road" in err and str(osm_file) in err
    for size, ppm, key, value in (("0,80", "2", "size_m", "0.0"), ("60,-5", "2", "size_m", "-5.0"),
                                  ("60,80", "0", "pixels_per_metre", "0.0"), ("60,80", "-1", "pixels_per_metre", "-1")):
        err = _error(capsys, _osm_argv(osm_file, out, size=size, ppm=ppm))
        assert f"osm.{key}" in err and value in err and str(osm_file) in err
    assert not out.exists()


def _far_inside(osm_file: Path) -> tuple[float, float]:
    """A centre inside the file's bounds (±300 m) but 250 m from every road."""
    from osm_fixtures import to_lonlat

    return to_lonlat(250.0, 250.0)


def test_unknown_class_key_and_bad_selector(osm_file):
    with pytest.raises(SceneError, match=r"osm\.classes .*junction\.osm.*unknown class 'roads'"):
        _build(osm_file, classes={"roads": ["highway=primary"]})
    with pytest.raises(SceneError, match=r"osm\.classes .*\.terrain: 'landuse' is not a tag selector"):
        _build(osm_file, classes={"terrain": ["landuse"]})


def test_yaml_errors_name_the_file_and_key(osm_file, tmp_path, capsys):
    from synthcal.config import ConfigError

    for osm, key in (({"size_m": [0, 80]}, "size_m"), ({"pixels_per_metre": -2}, "pixels_per_metre"),
                     ({"center": [95, 5]}, "center")):
        path = _yaml(tmp_path, osm_file, **osm)
        with pytest.raises(ConfigError) as info:
            load_config(path)
        assert str(path) in str(info.value) and f"scenes.my-junction.osm.{key}" in str(info.value)
    config = _yaml(tmp_path, osm_file, classes={"roads": ["highway=primary"]})
    err = _error(capsys, ["generate", "my-junction", "--out", str(tmp_path / "o2"), "--quiet", "--config",
                          str(config)])
    assert "unknown class 'roads'" in err and "junction.osm" in err
    assert not (tmp_path / "o2" / "my-junction.zarr").exists()
