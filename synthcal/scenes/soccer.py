"""The built-in ``soccer`` scene: a FIFA pitch from the World Cup 2014 line model.

Geometry: the 151 line segments of ``synthcal/data/wc14/worldcup2014.mat``
(SCCvSD, BSD 2-Clause; ``points`` in metres, x along the 105 m length, y across
the 68 m width; arcs are polylines), drawn at 10 px per metre with a 10 m margin:

    u = MARGIN_PX + 10 · x_m,    v = MARGIN_PX + 10 · (68 − y_m)

(:func:`pitch_to_pixel`). The y flip is deliberate: the World Cup cameras stand at
``y ≈ −45 m``, and with the flip our z-down world (SPEC §2) sees the pitch as
those cameras do. The scene is 1251 × 881 px (pixel 0 at −10 m, the last at
+115 m / +78 m).

Classes (semantic ids)

====  ===============  ======================================================
id    name             what it covers
====  ===============  ======================================================
0     background       everything outside the touchlines and goal lines:
                       run-off grass, advertising boards, stands' concrete
1     pitch            grass inside the touchlines not covered by 2 or 3
2     marked areas     interiors of both penalty areas (goal areas included,
                       separated from them by their lines) and of the centre
                       circle (split by the halfway line)
3     line markings    every segment of the line model, drawn 3 px (0.3 m)
                       wide — the real 0.12 m would vanish in rendered views —
                       plus the centre and penalty spots (discs of 0.35 m radius,
                       which the model file lacks; 11 m from each goal line)
====  ===============  ======================================================

Class 2 includes the centre circle, not only the penalty areas, because the
broadcast grid (pan ±25° around mid-field) mostly sees the middle third: there the
circle makes the map's topology informative.

The areas are found by flood-filling the rasterised lines from seed points
inside each area, so they follow the model's own geometry exactly.

Field (SPEC §4): the pitch rectangle between the touchlines' and goal lines'
centres, u ∈ [100, 1150], v ∈ [100, 780] (:data:`FIELD`) — what ``iou_part``
is clipped to, as the sports-field literature clips to its pitch template.

Camera: the default position is pitch point (52.5 m, −45 m) at 17 m height (the
World Cup 2014 camera statistics), i.e. ``(X, Y, Z) = (625, 1230, 170)`` px — it
stands outside the image, beyond the near touchline; ``heading_deg = −90`` turns
pan 0 toward −v, at the pitch centre (625, 440), which a tilt of
``−atan(17/79) ≈ −12.1°`` puts at the image centre.

RGB (distractors absent from the class map): mown stripes every 5.25 m, worn
white lines, goals with nets behind the goal lines, advertising boards, 22
players, a referee and the ball with their shadows, and the shadow of the
stadium roof over the far part of the pitch.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import cv2
import numpy as np

from .base import Scene, freeze
from .dressing import MaterialLook, add_grain, base_colours, fill_rgb, shade
from .roadkit import SHIFT, circle, fixed

__all__ = ["PITCH_LENGTH_M", "PITCH_WIDTH_M", "PPM", "MARGIN_PX", "SIZE", "CLASSES", "PALETTE", "CAMERA_POSITION",
           "HEADING_DEG", "FIELD", "pitch_to_pixel", "pitch_model", "build_soccer"]

PITCH_LENGTH_M = 105.0
PITCH_WIDTH_M = 68.0
PPM = 10.0
MARGIN_PX = 100.0
SIZE = (1251, 881)  # (width, height): 125 m × 88 m, the margin on every side
LINE_PX = 3
CLASSES = ("background", "pitch", "marked areas", "line markings")
PALETTE = ((0, 0, 0), (60, 150, 60), (250, 200, 40), (255, 255, 255))
CAMERA_POSITION_M = (52.5, -45.0, 17.0)
SPOTS = ((PITCH_LENGTH_M / 2, PITCH_WIDTH_M / 2), (11.0, PITCH_WIDTH_M / 2), (PITCH_LENGTH_M - 11.0, PITCH_WIDTH_M / 2))
HEADING_DEG = -90.0
SEED = 1006


def pitch_to_pixel(x_m, y_m):
    """Pitch metres → soccer-scene bird's-eye pixels.

    Args:
        x_m: array-like, along the length (0..105).
        y_m: array-like, across the width (0..68), growing away from the camera.

    Returns:
        ``(u, v)`` float64 arrays of the same shape.
    """
    x, y = np.asarray(x_m, np.float64), np.asarray(y_m, np.float64)
    return MARGIN_PX + PPM * x, MARGIN_PX + PPM * (PITCH_WIDTH_M - y)


_cam_u, _cam_v = pitch_to_pixel(CAMERA_POSITION_M[0], CAMERA_POSITION_M[1])
CAMERA_POSITION = (float(_cam_u), float(_cam_v), CAMERA_POSITION_M[2] * PPM)
# The field ``iou_part`` is clipped to (SPEC §4): the 105 × 68 m pitch between the
# lines' centres, as the sports-field literature's pitch template — not the margin.
_field_u, _field_v = pitch_to_pixel([0.0, PITCH_LENGTH_M, PITCH_LENGTH_M, 0.0], [0.0, 0.0, PITCH_WIDTH_M, PITCH_WIDTH_M])
FIELD = tuple((float(u), float(v)) for u, v in zip(_field_u, _field_v, strict=True))


@lru_cache(maxsize=1)
def pitch_model() -> tuple[np.ndarray, np.ndarray]:
    """The packaged line model.

    Returns:
        ``(points, segments)``: (302, 2) float64 metres and (151, 2) int64 index pairs.
    """
    ref = resources.files("synthcal") / "data/wc14/worldcup2014.mat"
    with resources.as_file(ref) as path:
        import scipy.io  # here, not at the top: only the soccer scene reads .mat files (scipy costs ≈ 0.1 s to import)

        model = scipy.io.loadmat(str(path))
    points = np.asarray(model["points"], np.float64)
    segments = np.asarray(model["line_segment_index"], np.int64)
    return points, segments


def _px(x_m: float, y_m: float) -> tuple[float, float]:
    u, v = pitch_to_pixel(x_m, y_m)
    return float(u), float(v)


def _semantic(lines: np.ndarray) -> np.ndarray:
    """Class map from the rasterised line mask ((H, W) uint8, 1 on lines)."""
    height, width = lines.shape
    semantic = np.zeros((height, width), np.uint8)
    cv2.fillPoly(semantic, [fixed([_px(0, 0), _px(PITCH_LENGTH_M, 0), _px(PITCH_LENGTH_M, PITCH_WIDTH_M),
                                   _px(0, PITCH_WIDTH_M)])], 1, cv2.LINE_8, SHIFT)
    areas = np.zeros((height + 2, width + 2), np.uint8)  # floodFill's mask: lines block the fill
    areas[1:-1, 1:-1] = lines
    seeds = [(11.0, 20.0), (2.5, 34.0), (94.0, 20.0), (102.5, 34.0), (48.0, 34.0), (57.0, 34.0)]
    scratch = lines.copy()
    for x, y in seeds:  # penalty areas, goal areas, both halves of the centre circle
        u, v = _px(x, y)
        cv2.floodFill(scratch, areas, (int(round(u)), int(round(v))), 2, flags=4 | (2 << 8) | cv2.FLOODFILL_MASK_ONLY)
    semantic[areas[1:-1, 1:-1] == 2] = 2
    semantic[lines == 1] = 3
    return semantic


def build_soccer(description: str = "") -> Scene:
    """Build the soccer scene (deterministic, read-only arrays).

    Returns:
        The scene: (881, 1251, 3) RGB and (881, 1251) class ids.
    """
    width, height = SIZE
    rng = np.random.default_rng(SEED)
    points, segments = pitch_model()
    # Lines as explicit quads: cv2's thick lines come out wider than asked, and
    # cv2.fillPoly fills the pixels from round(left) to round(right) inclusive, so a
    # quad of width LINE_PX − 1 covers LINE_PX pixels.
    half = (LINE_PX - 1) / 2
    shapes = [_quad(_px(*points[a]), _px(*points[b]), half) for a, b in segments]
    shapes += [circle(_px(*points[k]), half, 45.0) for k in np.unique(segments)]  # round joints
    shapes += [circle(_px(*spot), 0.35 * PPM, 30.0) for spot in SPOTS]
    lines = np.zeros((height, width), np.uint8)
    for shape in shapes:
        cv2.fillPoly(lines, [fixed(shape)], 1, cv2.LINE_8, SHIFT)
    semantic = _semantic(lines)

    # materials: 0/1 mown stripes (5.25 m along x), 2 surroundings beyond the boards
    u = np.arange(width, dtype=np.float64)
    stripe = (np.floor((u - MARGIN_PX) / (5.25 * PPM)).astype(np.int64) % 2).astype(np.uint8)
    material = np.broadcast_to(stripe, (height, width)).copy()
    board = 7.0 * PPM  # boards 7 m beyond the lines; concrete beyond 8 m
    x0, y0 = _px(0, PITCH_WIDTH_M)
    x1, y1 = _px(PITCH_LENGTH_M, 0)
    outside = np.ones((height, width), bool)
    outside[int(y0 - board - 10): int(y1 + board + 10) + 1, int(x0 - board - 10): int(x1 + board + 10) + 1] = False
    material[outside] = 2
    looks = (MaterialLook((70, 136, 54), (84, 150, 62), 7), MaterialLook((56, 116, 44), (68, 128, 52), 7),
             MaterialLook((58, 60, 68), (84, 86, 94), 12))
    rgb = base_colours(material, looks, rng)
    for k, (bx0, by0, bx1, by1) in enumerate(_boards(x0, y0, x1, y1, board)):
        colour = ((200, 30, 40), (20, 60, 160), (240, 240, 240), (250, 190, 20), (20, 20, 24))[k % 5]
        cv2.rectangle(rgb, (int(bx0), int(by0)), (int(bx1), int(by1)), colour, -1)
    line_rgb = np.zeros_like(lines)
    for shape in shapes:
        fill_rgb(line_rgb, shape, 255)
    wear = 200 + (rng.integers(0, 56, (height, width), dtype=np.int32))  # lines are not perfectly white
    alpha = (line_rgb.astype(np.int32) * wear) >> 8
    rgb[...] = ((rgb.astype(np.int32) * (256 - alpha[..., None]) + 236 * alpha[..., None]) >> 8).astype(np.uint8)
    _goals(rgb)
    add_grain(rgb, material, looks, rng)

    # distractors: roof shadow over the far side, players with shadows
    mask = np.zeros((height, width), np.uint8)
    fill_rgb(mask, [(-10, -10), (width + 10, -10), (width + 10, _px(0, 52.0)[1]), (-10, _px(0, 40.0)[1])], 255)
    players = _players(rng)
    for (pu, pv), _ in players:
        fill_rgb(mask, circle((pu - 0.9 * PPM, pv - 0.6 * PPM), 0.45 * PPM, 30.0), 255)
    shade(rgb, mask, 90)
    for (pu, pv), colour in players:
        fill_rgb(rgb, circle((pu, pv), 0.35 * PPM, 30.0), colour)
        fill_rgb(rgb, circle((pu, pv), 0.14 * PPM, 60.0), (60, 40, 30))  # head
    return Scene("soccer", freeze(rgb), freeze(semantic), CLASSES, PALETTE, heading_deg=HEADING_DEG,
                 camera_position=CAMERA_POSITION, pixels_per_metre=PPM, description=description, field=FIELD)


def _quad(p: tuple[float, float], q: tuple[float, float], half: float) -> list[tuple[float, float]]:
    """Rectangle of half-width ``half`` around the segment p–q."""
    length = max(((q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2) ** 0.5, 1e-9)
    nx, ny = -(q[1] - p[1]) / length * half, (q[0] - p[0]) / length * half
    return [(p[0] + nx, p[1] + ny), (q[0] + nx, q[1] + ny), (q[0] - nx, q[1] - ny), (p[0] - nx, p[1] - ny)]


def _boards(x0: float, y0: float, x1: float, y1: float, d: float) -> list[tuple[float, float, float, float]]:
    """Advertising boards (1 m deep, 6 m long) around the pitch, leaving the corners free."""
    out = []
    for sx in np.arange(x0 + 2 * PPM, x1 - 7 * PPM, 6.5 * PPM):
        out += [(sx, y0 - d - PPM, sx + 6 * PPM, y0 - d), (sx, y1 + d, sx + 6 * PPM, y1 + d + PPM)]
    for sy in np.arange(y0 + 2 * PPM, y1 - 7 * PPM, 6.5 * PPM):
        out += [(x0 - d - PPM, sy, x0 - d, sy + 6 * PPM), (x1 + d, sy, x1 + d + PPM, sy + 6 * PPM)]
    return out


def _goals(rgb: np.ndarray) -> None:
    """Goal frames on the goal lines (7.32 m) with a grey net 2 m deep behind them."""
    half = 7.32 / 2
    for x, depth in ((0.0, -2.0), (PITCH_LENGTH_M, 2.0)):
        net = [_px(x, PITCH_WIDTH_M / 2 - half), _px(x + depth, PITCH_WIDTH_M / 2 - half),
               _px(x + depth, PITCH_WIDTH_M / 2 + half), _px(x, PITCH_WIDTH_M / 2 + half)]
        fill_rgb(rgb, net, (190, 190, 195))
        for k in range(1, 12):  # mesh
            a = _px(x, PITCH_WIDTH_M / 2 - half + k * 7.32 / 12)
            b = _px(x + depth, PITCH_WIDTH_M / 2 - half + k * 7.32 / 12)
            cv2.line(rgb, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (150, 150, 155), 1, cv2.LINE_AA)
        cv2.line(rgb, tuple(fixed([net[0]])[0]), tuple(fixed([net[3]])[0]), (250, 250, 250), 3, cv2.LINE_AA, SHIFT)


def _players(rng: np.random.Generator) -> list[tuple[tuple[float, float], tuple[int, int, int]]]:
    """22 players (two kits) and a referee at random pitch positions."""
    kits = [(200, 30, 40)] * 11 + [(235, 235, 240)] * 11 + [(30, 30, 30)]
    xs = rng.uniform(5, PITCH_LENGTH_M - 5, len(kits))
    ys = rng.uniform(3, PITCH_WIDTH_M - 3, len(kits))
    return [(_px(float(x), float(y)), kit) for x, y, kit in zip(xs, ys, kits, strict=True)]

