"""Scenes derived from a built one: the same scene turned, and a blank one (issue 27's controls).

**Turned** (:func:`turned_scene`): the scene's ground turned by ``angle`` degrees
about its camera anchor ``c`` (the junction centre of a built-in intersection), in
the image-angle sense (0° = +u, 90° = +v, so clockwise on the screen, the sense in
which pan grows): the ground point at bird's-eye pixel ``p`` moves to
``p' = c + R(angle) (p − c)``, ``R(a) = [[cos a, −sin a], [sin a, cos a]]``. The
canvas keeps the scene's size and anchor, so the same relative grid applies; ground
turned out of the canvas is lost and canvas pixels no ground turns into are
background (class 0) and black, as everything beyond a scene's border already is.
The class map is resampled nearest-neighbour (it holds only the ids it held), the
RGB bilinearly.

``heading_deg`` grows by ``angle``, so a grid camera at pan ``θ`` and offset ``d``
from the anchor sees what the original scene's camera at pan ``θ`` and offset
``R(−angle) d`` sees: the templates show the *same layout* from the same grid of
pans, and record the same ``pan_deg``. Their homographies, though, map the *turned*
frame: used as templates for the original scene, one that looks right carries a pose
turned by ``angle`` about the anchor — wrong unless the layout is symmetric under
that turn. (``heading_deg`` alone, without turning the ground, would change nothing
a template carries: on a pan grid of 15° steps, turns by multiples of 15° give the
same cameras, and every homography stays in the scene's own frame.)

**Blank** (:func:`blank_scene`): the scene's size, anchor, classes and palette, every
pixel background (class 0) and black. Its grid cameras are real cameras of the same
grid (so their homographies have the same prior), their semantic maps are all
background whatever the pose, and their images black but for the per-sample
appearance jitter (brightness and noise on the ground, which may show where the
ground ends). The bundled estimators read a template's semantic map and homography
only.

Example
-------
>>> import numpy as np
>>> from synthcal.scenes.base import Scene
>>> semantic = np.zeros((5, 5), np.uint8); semantic[2, 3:] = 1   # a road east of the centre (2, 2)
>>> scene = Scene("t", np.zeros((5, 5, 3), np.uint8), semantic, ("background", "road", "a", "b"),
...               ((0, 0, 0),) * 4, camera_position=(2.0, 2.0, 5.0))
>>> np.argwhere(turned_scene(scene, 90.0, "t90", "").semantic == 1).tolist()   # now south of it
[[3, 2], [4, 2]]
"""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np

from .base import Scene, freeze

__all__ = ["turned_scene", "blank_scene"]


def _turn_maps(shape: tuple[int, int], anchor: tuple[float, float], angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) float32 ``cv2.remap`` maps: each turned-canvas pixel's source point ``c + R(−angle)(p' − c)``."""
    a = math.radians(angle_deg)
    cos, sin = math.cos(a), math.sin(a)
    height, width = shape
    du = np.arange(width, dtype=np.float64)[None, :] - anchor[0]
    dv = np.arange(height, dtype=np.float64)[:, None] - anchor[1]
    # R(−a) = [[cos, sin], [−sin, cos]]; numpy's + and × are exact IEEE operations, the same on every machine
    map_u = anchor[0] + cos * du + sin * dv
    map_v = anchor[1] - sin * du + cos * dv
    return map_u.astype(np.float32), map_v.astype(np.float32)


def turned_scene(scene: Scene, angle_deg: float, name: str, description: str) -> Scene:
    """``scene`` turned by ``angle_deg`` about its anchor, ``heading_deg`` grown by as much (module docstring).

    Args:
        scene: the scene to turn (its :attr:`~Scene.anchor` is the pivot).
        angle_deg: the turn, degrees, in the image-angle sense (+u toward +v).
        name, description: the new scene's.

    Returns:
        A scene of the same size, classes, palette, anchor and field, arrays read-only.
    """
    maps = _turn_maps(scene.semantic.shape, scene.anchor, angle_deg)
    semantic = cv2.remap(scene.semantic, *maps, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    image = cv2.remap(scene.image, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
    return dataclasses.replace(scene, name=name, image=freeze(image), semantic=freeze(semantic),
                               heading_deg=scene.heading_deg + angle_deg, description=description)


def blank_scene(scene: Scene, name: str, description: str) -> Scene:
    """A scene of ``scene``'s size, anchor, classes and palette with every pixel class 0 and black (module docstring)."""
    return dataclasses.replace(scene, name=name, image=freeze(np.zeros_like(scene.image)),
                               semantic=freeze(np.zeros_like(scene.semantic)), description=description)
