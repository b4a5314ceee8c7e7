"""OSM tags → semantic classes of an OSM scene: the documented defaults and their overrides.

A *selector* is one or more ``key=value`` conditions joined by ``&``; a value may
be ``*`` (any value) or alternatives ``a|b|c``. Each class holds a list of
selectors (:data:`DEFAULT_CLASSES`). A feature matching a selector of a class is
painted as that class: lines are buffered to their width (:func:`line_width`),
areas are painted as they are.

Painting order (later wins, so the tagged reality wins): background ground
(everything) → ``terrain`` → ``background`` (buildings, pavements, water, car
parks: they cut holes into parks) → ``bicycle path`` (separate cycle tracks) →
``road`` (carriageways; where a cycle track crosses a road the road wins, as
the crossing is part of the carriageway) → cycle strips tagged on a road
(``cycleway[:left|:right|:both]=track|lane``: a lane lies on the carriageway
it belongs to, a track beside it; neither is painted across another road).

Overrides (``classes:`` of a scene entry) map a class name to selectors that move
to that class, e.g. ``{terrain: ["landuse=farmland"], background: ["highway=service"]}``.

Example
-------
>>> rules = class_rules({"terrain": ["landuse=farmland"]})
>>> classify({"landuse": "farmland"}, rules), classify({"highway": "primary"}, rules)
(2, 1)
>>> line_width({"highway": "primary", "lanes": "2"}, 1)
6.5
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..base import SceneError

__all__ = ["CLASS_NAMES", "CLASS_IDS", "PAINT_ORDER", "DEFAULT_CLASSES", "Selector", "ClassRules", "class_rules",
           "classify", "line_width", "parse_metres", "strips", "Strip", "LANE_WIDTH", "relevant_keys"]

CLASS_NAMES = ("background", "road", "terrain", "bicycle path")
CLASS_IDS = {"background": 0, "road": 1, "terrain": 2, "bicycle path": 3, "bicycle_path": 3}
# class ids in painting order (later wins); cycle strips on roads come after all of them
PAINT_ORDER = (2, 0, 3, 1)

ROAD_VALUES = ("motorway|trunk|primary|secondary|tertiary|unclassified|residential|service|living_street|road|"
               "busway|motorway_link|trunk_link|primary_link|secondary_link|tertiary_link")
DEFAULT_CLASSES: dict[str, tuple[str, ...]] = {
    "road": (f"highway={ROAD_VALUES}", f"area:highway={ROAD_VALUES}|junction"),
    "terrain": ("landuse=grass|meadow|village_green|recreation_ground|flowerbed", "leisure=park|garden",
                "natural=grassland|scrub|heath"),
    "background": ("building=*", "building:part=*", "natural=water", "waterway=riverbank", "amenity=parking",
                   "highway=footway|pedestrian|steps|path|bridleway|track|platform", "area:highway=footway|pedestrian"),
    "bicycle path": ("highway=cycleway", "highway=path|footway|bridleway & bicycle=designated",
                     "area:highway=cycleway"),
}

LANE_WIDTH = 3.25  # m, for ``lanes`` without ``width``
# carriageway width (m) of each highway value without ``width`` or ``lanes``
HIGHWAY_WIDTH = {
    "motorway": 7.5, "trunk": 7.0, "primary": 7.0, "secondary": 6.5, "tertiary": 6.0, "unclassified": 5.0,
    "residential": 5.0, "living_street": 4.0, "service": 3.5, "road": 5.0, "busway": 3.5,
    "motorway_link": 4.0, "trunk_link": 4.0, "primary_link": 4.0, "secondary_link": 4.0, "tertiary_link": 4.0,
    "cycleway": 2.0, "footway": 2.0, "path": 1.5, "bridleway": 2.0, "pedestrian": 4.0, "steps": 2.0, "track": 3.0,
    "platform": 2.5,
}
CLASS_WIDTH = {0: 2.0, 1: 5.0, 2: 3.0, 3: 2.0}  # m: lines of other tags, per class
TRACK_WIDTH, TRACK_GAP, BIKE_LANE_WIDTH = 2.0, 0.5, 1.5  # m


@dataclass(frozen=True)
class Selector:
    """Conditions ``key ∈ values`` (``values`` None: any value), all of which must hold."""

    conditions: tuple[tuple[str, frozenset[str] | None], ...]
    text: str

    def matches(self, tags: Mapping[str, str]) -> bool:
        for key, values in self.conditions:
            value = tags.get(key)
            if value is None or (values is not None and value not in values):
                return False
        return True


_CONDITION = re.compile(r"\s*([^=&\s][^=&]*?)\s*=\s*([^=&]+?)\s*")


def parse_selector(text: str, where: str) -> Selector:
    """``"highway=path|footway & bicycle=designated"`` → :class:`Selector`.

    Raises:
        SceneError: not ``key=value`` conditions joined by ``&`` (names ``where`` and the value).
    """
    conditions = []
    for part in str(text).split("&"):
        match = _CONDITION.fullmatch(part)
        if match is None:
            raise SceneError(f"{where}: {text!r} is not a tag selector: key=value, key=a|b or key=*, "
                             f"joined by '&'")
        key, value = match.groups()
        conditions.append((key, None if value == "*" else frozenset(v.strip() for v in value.split("|"))))
    return Selector(tuple(conditions), str(text))


@dataclass(frozen=True)
class ClassRules:
    """Selectors per class id, the defaults with the overrides applied."""

    selectors: dict[int, tuple[Selector, ...]]

    def keys(self) -> set[str]:
        return {key for sels in self.selectors.values() for s in sels for key, _ in s.conditions}


def class_rules(overrides: Mapping[str, Sequence[str]] | None = None, where: str = "classes") -> ClassRules:
    """The default selectors with ``overrides`` (class name → selectors moved to that class).

    Raises:
        SceneError: an unknown class name, or a selector that does not parse;
            the message names ``where``, the key and the value.
    """
    moved: dict[int, list[Selector]] = {}
    for name, texts in (overrides or {}).items():
        if name not in CLASS_IDS:
            raise SceneError(f"{where}: unknown class {name!r}; classes: {', '.join(CLASS_NAMES)} (value {texts!r})")
        if isinstance(texts, str) or not isinstance(texts, Sequence):
            raise SceneError(f"{where}.{name}: a list of tag selectors is expected (value {texts!r})")
        moved.setdefault(CLASS_IDS[name], []).extend(parse_selector(t, f"{where}.{name}") for t in texts)
    overridden = {s.text.replace(" ", "") for sels in moved.values() for s in sels}
    selectors: dict[int, tuple[Selector, ...]] = {}
    for name, texts in DEFAULT_CLASSES.items():
        class_id = CLASS_IDS[name]
        kept = [parse_selector(t, "default") for t in texts if t.replace(" ", "") not in overridden]
        selectors[class_id] = (*moved.get(class_id, []), *kept)
    return ClassRules(selectors)


def classify(tags: Mapping[str, str], rules: ClassRules) -> int | None:
    """The class a feature is painted as: the first class, in reverse painting order, with a matching selector."""
    for class_id in reversed(PAINT_ORDER):
        if any(s.matches(tags) for s in rules.selectors[class_id]):
            return class_id
    return None


def relevant_keys(rules: ClassRules) -> set[str]:
    """Tag keys the reader must let through: the selectors' and those of crossings, trees and strips."""
    return rules.keys() | {"highway", "natural", "footway", "crossing", "building", "cycleway"}


_NUMBER = re.compile(r"\s*([0-9]+(?:[.,][0-9]+)?)\s*(m|metres?|meters?)?\s*")


def parse_metres(text: str | None) -> float | None:
    """A ``width`` tag in metres (``"7"``, ``"7.5 m"``, ``"6,5"``); None when absent or not plain metres."""
    if text is None:
        return None
    match = _NUMBER.fullmatch(text)
    if match is None:
        return None
    value = float(match.group(1).replace(",", "."))
    return value if value > 0 else None


def _lanes(text: str | None) -> int | None:
    try:
        lanes = int(str(text).strip())
    except ValueError:
        return None
    return lanes if lanes > 0 else None


def line_width(tags: Mapping[str, str], class_id: int) -> float:
    """Painted width (m) of a line: ``width``, else ``lanes`` × :data:`LANE_WIDTH` (roads),
    else the highway value's default, else the class default."""
    width = parse_metres(tags.get("width"))
    if width is not None:
        return width
    lanes = _lanes(tags.get("lanes"))
    if lanes is not None and class_id == 1:
        return lanes * LANE_WIDTH
    return HIGHWAY_WIDTH.get(tags.get("highway", ""), CLASS_WIDTH[class_id])


@dataclass(frozen=True)
class Strip:
    """A cycle strip beside a way's centre line: ``side`` +1 left, −1 right; lateral range in metres."""

    side: int
    near: float
    far: float
    kind: str  # "track" or "lane"


def strips(tags: Mapping[str, str], half_width: float) -> list[Strip]:
    """The cycle strips a road's tags ask for (``cycleway``, ``cycleway:left|right|both`` = track or lane)."""
    sides: dict[int, str] = {}
    for key, which in (("cycleway", (1, -1)), ("cycleway:both", (1, -1)), ("cycleway:left", (1,)),
                       ("cycleway:right", (-1,))):
        value = tags.get(key, "").removeprefix("opposite_")
        if value in ("track", "lane"):
            for side in which:
                sides[side] = value
    out = []
    for side, kind in sorted(sides.items()):
        name = "left" if side > 0 else "right"
        own = parse_metres(tags.get(f"cycleway:{name}:width") or tags.get("cycleway:width"))
        if kind == "track":
            width = own or TRACK_WIDTH
            out.append(Strip(side, half_width + TRACK_GAP, half_width + TRACK_GAP + width, kind))
        else:
            width = min(own or BIKE_LANE_WIDTH, half_width)
            out.append(Strip(side, half_width - width, half_width, kind))
    return out
