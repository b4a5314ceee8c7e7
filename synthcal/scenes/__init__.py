"""Scenes: bird's-eye RGB images with their semantic maps (SPEC §4).

Built-in scenes are procedural and deterministic (``build_scene``: the same name
gives bit-identical, read-only arrays on every call and machine); user scenes are
read from two PNG files (``load_user_scene``) or built from an OpenStreetMap
extract around a centre (``build_osm_scene``, :mod:`.osm`).

Example
-------
>>> scene = build_scene("intersection-1")
>>> scene.semantic.shape, scene.classes[3]
((1900, 1300), 'bicycle path')
"""

from __future__ import annotations

from functools import cache

from synthcal.config import BUILTIN_SCENE_NAMES

from .base import NUM_CLASSES, Scene, SceneError, colorize, draw_scene, freeze
from .intersection import CLASSES as INTERSECTION_CLASSES
from .intersection import LAYOUTS, PPM, build_intersection
from .intersection import PALETTE as INTERSECTION_PALETTE
from .osm import build_osm_scene
from .soccer import build_soccer
from .user import load_user_scene
from .variants import blank_scene, turned_scene

__all__ = ["Scene", "SceneError", "BUILTIN_SCENES", "build_scene", "load_user_scene", "build_osm_scene", "draw_scene",
           "colorize", "NUM_CLASSES"]

# Scenes derived from intersection-1 (synthcal.scenes.variants): name → turn in degrees, None for blank.
_DERIVED: dict[str, float | None] = {"intersection-1-turn15": 15.0, "intersection-1-turn45": 45.0,
                                     "intersection-1-turn90": 90.0, "intersection-1-blank": None}

BUILTIN_SCENES: dict[str, str] = {
    **{name: layout.description for name, layout in LAYOUTS.items()},
    "soccer": "FIFA pitch 105 x 68 m from the World Cup 2014 line model; camera 45 m behind the touchline, 17 m up",
    **{name: f"intersection-1 turned {turn:g} deg about its centre, heading_deg {turn:g} (same views, turned frame)"
       for name, turn in _DERIVED.items() if turn is not None},
    "intersection-1-blank": "intersection-1's frame and camera anchor, every pixel background and black (a control)",
}
if tuple(BUILTIN_SCENES) != BUILTIN_SCENE_NAMES:
    # config.py validates ``scene:`` against its own copy of the names (it imports nothing of synthcal)
    raise ImportError(f"synthcal.config.BUILTIN_SCENE_NAMES {BUILTIN_SCENE_NAMES} differs from the built-in "
                      f"scenes {tuple(BUILTIN_SCENES)}")


@cache
def build_scene(name: str) -> Scene:
    """A built-in scene, built once per process.

    Args:
        name: a key of :data:`BUILTIN_SCENES`.

    Returns:
        The scene, its arrays read-only (shared by the cache).

    Raises:
        SceneError: unknown name.
    """
    if name in LAYOUTS:
        image, semantic = build_intersection(LAYOUTS[name])
        centre = LAYOUTS[name].centre
        return Scene(name, freeze(image), freeze(semantic), INTERSECTION_CLASSES, INTERSECTION_PALETTE,
                     heading_deg=0.0, camera_position=(centre[0], centre[1], 75.0), pixels_per_metre=PPM,
                     description=BUILTIN_SCENES[name])
    if name == "soccer":
        return build_soccer(BUILTIN_SCENES[name])
    if name in _DERIVED:
        turn = _DERIVED[name]
        base = build_scene("intersection-1")
        if turn is None:
            return blank_scene(base, name, BUILTIN_SCENES[name])
        return turned_scene(base, turn, name, BUILTIN_SCENES[name])
    raise SceneError(f"scene: unknown built-in scene {name!r}; built-in scenes: {', '.join(BUILTIN_SCENES)}")
