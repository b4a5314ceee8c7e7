"""The junction catalogue (SPEC §4): legs, bearings, classes, cycleways, ranking, the YAML snippet, bad input.

The extract is OSM XML written from metres east/north of a centre (``osm_fixtures.py``);
expected bearings are the directions the test drew the legs in, never read back
through the code under test.
"""

from __future__ import annotations

import csv
import sys
from importlib import resources
from pathlib import Path

import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
from osm_fixtures import CENTER, OsmXml, ahead, to_lonlat  # noqa: E402

from synthcal.cli import main  # noqa: E402
from synthcal.config import load_config  # noqa: E402
from synthcal.scenes import SceneError  # noqa: E402
from synthcal.scenes.osm.junctions import find_junctions, layout_bearings, layout_difference, rank  # noqa: E402

CROSS, TEE, SKEWED = (0.0, 0.0), (400.0, 0.0), (800.0, 0.0)
# intersection-2's legs (image angles 0, 65, 180, 245 → bearings 90, 155, 270, 335), turned by 30°.
SKEWED_BEARINGS = (5.0, 120.0, 185.0, 300.0)
TOLERANCE = 1.5  # degrees: the fixture's projection and the 20 m reach past a kinked first segment


@pytest.fixture(scope="module")
def extract(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, int]]:
    """A plain crossing (a primary through it, two residential streets ending at it, the northern one with a
    kink 3 m out, a footway through it), a T (a residential street through it, a service road ending at it, a
    cycleway ending at it), a skewed crossing of four secondary roads ending at it, and two ways joined end
    to end (not a junction)."""
    osm = OsmXml()
    osm.way([(-100.0, 0.0), CROSS, (100.0, 0.0)], {"highway": "primary"})
    osm.way([CROSS, (0.5, 3.0), (0.0, 100.0)], {"highway": "residential"})
    osm.way([CROSS, (0.0, -100.0)], {"highway": "residential"})
    osm.way([(-30.0, -30.0), CROSS, (30.0, 30.0)], {"highway": "footway"})
    osm.way([(300.0, 0.0), TEE, (500.0, 0.0)], {"highway": "residential"})
    osm.way([TEE, (400.0, -80.0)], {"highway": "service"})
    osm.way([TEE, (400.0, 80.0)], {"highway": "cycleway"})
    for bearing in SKEWED_BEARINGS:
        osm.way([SKEWED, ahead(SKEWED, bearing, 80.0)], {"highway": "secondary"})
    osm.way([(0.0, 200.0), (100.0, 200.0)], {"highway": "residential"})
    osm.way([(100.0, 200.0), (200.0, 210.0)], {"highway": "residential"})
    path = osm.write(tmp_path_factory.mktemp("junctions") / "town.osm", bounds_m=1000.0)
    return path, {"cross": osm.ids[CROSS], "tee": osm.ids[TEE], "skewed": osm.ids[SKEWED]}


def assert_bearings(found, expected) -> None:
    assert len(found) == len(expected)
    for a, b in zip(found, sorted(expected), strict=True):
        assert abs((a - b + 180) % 360 - 180) < TOLERANCE, (found, expected)


def test_legs_bearings_classes_and_cycleways(extract):
    path, ids = extract
    found = {j.node_id: j for j in find_junctions(path)}
    assert sorted(found) == sorted(ids.values())  # the joined ways' shared node and the bends are not junctions
    cross, tee, skewed = found[ids["cross"]], found[ids["tee"]], found[ids["skewed"]]
    # A way through counts 2, a way ending 1: 2 + 1 + 1 at the crossing, 2 + 1 at the T, 4 × 1 skewed.
    assert (cross.legs, tee.legs, skewed.legs) == (4, 3, 4)
    assert_bearings(cross.bearings[1:], (90.0, 180.0, 270.0))
    assert cross.bearings[0] < TOLERANCE or cross.bearings[0] > 360 - TOLERANCE  # north, past the kink
    assert_bearings(tee.bearings, (90.0, 180.0, 270.0))
    assert_bearings(skewed.bearings, SKEWED_BEARINGS)
    assert cross.road_classes == ("primary", "residential") and tee.road_classes == ("residential", "service")
    assert (cross.cycleway, tee.cycleway, skewed.cycleway) == (False, True, False)  # the footway is no cycleway
    lon, lat = to_lonlat(*TEE)
    assert tee.lat == pytest.approx(lat, abs=1e-7) and tee.lon == pytest.approx(lon, abs=1e-7)  # OSM: 7 decimals
    assert [j.node_id for j in find_junctions(path, legs=3)] == [ids["tee"]]


def test_the_bbox_keeps_what_lies_inside(extract):
    path, ids = extract
    (west, south), (east, north) = to_lonlat(-50.0, -50.0), to_lonlat(450.0, 50.0)
    assert [j.node_id for j in find_junctions(path, (west, south, east, north))] == sorted([ids["cross"], ids["tee"]])


def test_layout_difference_is_rotation_free_and_symmetric():
    plain = (0.0, 90.0, 180.0, 270.0)
    assert layout_difference(plain, [b + 37.0 for b in plain]) == pytest.approx(0.0, abs=1e-9)
    assert layout_difference((0.0, 180.0), (0.0, 90.0)) == pytest.approx(45.0)  # one leg off by 90 both ways
    skew = layout_bearings("intersection-2")
    assert skew == (90.0, 155.0, 270.0, 335.0)
    assert layout_difference(plain, skew) == pytest.approx(layout_difference(skew, plain))
    assert layout_difference(plain, skew) > 10


def test_ranking_by_likeness(extract):
    path, ids = extract
    junctions = find_junctions(path)
    one = rank(junctions, "intersection-1")
    assert [j.node_id for j in one] == [ids["cross"], ids["skewed"], ids["tee"]]
    assert one[0].difference < TOLERANCE < one[1].difference
    two = rank(junctions, "intersection-2")
    assert [j.node_id for j in two] == [ids["skewed"], ids["cross"], ids["tee"]] and two[0].difference < TOLERANCE
    with pytest.raises(SceneError, match="not a built-in intersection"):
        rank(junctions, "soccer")


def test_cli_writes_the_catalogue_and_a_snippet_that_loads(extract, tmp_path, capsys):
    path, ids = extract
    out = tmp_path / "town.csv"
    assert main(["osm-junctions", str(path), "--like", "intersection-1", "--csv", str(out), "--datasets", "2"]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [int(r["node_id"]) for r in rows] == [ids["cross"], ids["skewed"], ids["tee"]]
    assert rows[0]["legs"] == "4" and rows[0]["road_classes"] == "primary;residential" and rows[2]["cycleway"] == "true"
    assert float(rows[0]["lat"]) == pytest.approx(CENTER[0], abs=1e-7)
    # The snippet, merged into a copy of the packaged datasets.yaml beside it, is a valid configuration.
    snippet = yaml.safe_load((tmp_path / "town.datasets.yaml").read_text())
    config = yaml.safe_load(resources.files("synthcal").joinpath("datasets.yaml").read_text())
    for block in ("scenes", "datasets", "mixed_dictionaries"):
        config[block] = {**(config.get(block) or {}), **snippet[block]}
    (tmp_path / "datasets.yaml").write_text(yaml.safe_dump(config))
    loaded = load_config(tmp_path / "datasets.yaml").config
    cross, skewed = f"osm-{ids['cross']}", f"osm-{ids['skewed']}"
    assert set(snippet["datasets"]) == {cross, skewed}
    assert loaded.datasets[cross].scene == cross and loaded.datasets[cross].grid == "intersection"
    assert loaded.mixed_dictionaries[cross] == (skewed,) and loaded.mixed_dictionaries[skewed] == (cross,)
    assert Path(loaded.scenes[cross].osm.file).resolve() == path.resolve()
    assert loaded.scenes[cross].osm.center == pytest.approx(CENTER, abs=1e-7)


def test_a_mix_for_a_builtin_intersection_is_a_layered_config(extract, tmp_path, capsys):
    """--mix-for: the K junctions become one mix, intersection-1's through a second store of its pool."""
    path, ids = extract
    snippet = tmp_path / "osm.yaml"
    assert main(["osm-junctions", str(path), "--legs", "4", "--like", "intersection-1", "--csv", str(tmp_path / "j.csv"),
                 "--datasets", "2", "--mix-for", "intersection-1", "--yaml", str(snippet)]) == 0
    assert "mixed-osm2-1" in capsys.readouterr().out
    config = load_config(snippet)  # the snippet alone, layered over the packaged configuration
    cross, skewed = f"osm-{ids['cross']}", f"osm-{ids['skewed']}"
    assert {k: v for k, v in config.config.mixed_dictionaries.items() if "osm" in k} == {"osm2-1": (cross, skewed)}
    mix, own = config.resolve("osm2-1", "quick"), config.resolve("intersection-1", "quick")
    assert mix.pool_name == "intersection-1" and mix.mixed_sources == (cross, skewed)
    assert (mix.scene, mix.pool_size, mix.seed, mix.splits) == (own.scene, own.pool_size, own.seed, own.splits)
    assert main(["datasets", "--config", str(snippet)]) == 0
    listed = [line for line in capsys.readouterr().out.splitlines() if line.startswith("mixed-osm")]
    assert len(listed) == 1 and listed[0].split()[0] == "mixed-osm2-1" and listed[0].endswith(f"{cross}, {skewed}")
    # A mix needs junctions to draw on.
    assert main(["osm-junctions", str(path), "--csv", str(tmp_path / "k.csv"), "--mix-for", "intersection-1"]) == 2
    assert "--datasets" in capsys.readouterr().err and not (tmp_path / "k.csv").exists()


@pytest.mark.parametrize("case", ["no junction", "bbox outside", "no such file", "no junction in bbox"])
def test_bad_input_is_one_line_and_writes_nothing(extract, tmp_path, capsys, case):
    path, _ = extract
    if case == "no junction":
        osm = OsmXml()
        osm.way([(0.0, 0.0), (50.0, 0.0), (50.0, 50.0)], {"highway": "primary"})
        path = osm.write(tmp_path / "lonely.osm")
    box = {"bbox outside": "10,40,11,41", "no junction in bbox": ",".join(
        f"{v:.7f}" for v in (*to_lonlat(150.0, -50.0), *to_lonlat(250.0, 50.0)))}.get(case)
    if case == "no such file":
        path = tmp_path / "missing.osm.pbf"
    out = tmp_path / "out.csv"
    assert main(["osm-junctions", str(path), "--csv", str(out), "--datasets", "3",
                 *(["--bbox", box] if box else [])]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("synthcal: error: ") and str(path) in err
    assert {"no junction": "no road junctions", "bbox outside": "outside", "no such file": "cannot read",
            "no junction in bbox": "inside bbox"}[case] in err
    assert not out.exists() and not (tmp_path / "out.datasets.yaml").exists()
