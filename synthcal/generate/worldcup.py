"""The World Cup 2014 broadcast cameras as a dataset of given poses.

Source: the 209 (``train_val.mat``) + 186 (``test.mat``) annotated frames of
Homayounfar et al. (CVPR 2017) as redistributed by SCCvSD (Chen & Little, 2019;
BSD 2-Clause, ``synthcal/data/wc14/LICENSE-SCCvSD.txt``). Each ``homography``
maps a pitch point in **yards** to a pixel of the **1280 × 720** frame. The yard
frame's origin is a pitch corner, its first axis runs along the pitch length
(0..114.83 yd) from left to right as seen by the camera, its second across the
pitch (0..74.37 yd) from the **far** touchline toward the camera (checked by
drawing the pitch model over frame ``16.jpg``; the line model
``worldcup2014.mat`` uses the same axes in metres — the pitch is symmetric, so the
soccer scene may draw it with its own y flip).

Conversion to a sample of the soccer scene (SPEC §2)::

    H_out = S · H_yards · A

* ``A`` maps a bird's-eye pixel to yards. The scene draws pitch point
  ``(x_m, y_m)`` (metres, ``y_m`` growing *away from* the camera) at
  ``u = margin + ppm·x_m``, ``v = margin + ppm·(68 − y_m)``; the yard frame has
  ``X = x_m / 0.9144``, ``Y = (68 − y_m) / 0.9144`` (the two y flips cancel, so
  ``A`` is a scale and shift: ``X = (u − margin) / (ppm·0.9144)``,
  ``Y = (v − margin) / (ppm·0.9144)``).
* ``S`` scales 1280 × 720 pixels to the output size with the pixel-centre rule
  ``x_out = (x_in + 0.5)·W/1280 − 0.5`` (likewise for rows).
* The sign is then fixed with :func:`~synthcal.generate.camera.orient_homography`
  so that the third output coordinate is the depth (SPEC §2).

The camera fields of a real pose (``pan_deg`` without the scene heading,
``tilt_deg``, ``focal_px`` at ``focal_reference_width``, ``x``, ``y``, ``z``) start
from :func:`~synthcal.generate.camera.decompose_homography` and are refined by a
reprojection fit (:func:`fit_cameras`; median residual ≈ 3 px at 1280 wide; the
fitted centres and focals match SCCvSD's published statistics of these cameras).
They describe the camera; the stored homography is the ground truth.
``grid_index`` is −1.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from synthcal.config import POSE_SET_SPLITS, ConfigError, DatasetSpec, GridConfig
from synthcal.generate.camera import decompose_homography, intrinsics, orient_homography
from synthcal.scenes import Scene, soccer
from synthcal.store import CAMERA_FIELDS

__all__ = [
    "METRES_PER_YARD",
    "WC14_FRAME",
    "WorldCupPoses",
    "data_dir",
    "load_worldcup_poses",
    "pose_partition",
    "pose_attributes",
    "bird_eye_to_yards",
    "bird_eye_to_pitch",
    "frame_scaling",
    "convert_homographies",
    "camera_scaled",
    "fit_cameras",
    "camera_fields",
    "plan_poses",
    "in_grid",
    "RealCameras",
    "real_cameras",
    "real_camera_lines",
    "montage_poses",
]

METRES_PER_YARD = 0.9144
WC14_FRAME = (1280, 720)
WC14_MEAN_FOCAL_PX = 3018.0  # at 1280 wide, SCCvSD's camera statistics
_PARTS = (("train", "train_val.mat"), ("test", "test.mat"))


def data_dir() -> Path:
    """The packaged copy of the annotations (``synthcal/data/wc14``)."""
    return Path(str(resources.files("synthcal") / "data" / "wc14"))


@dataclass(frozen=True)
class WorldCupPoses:
    """The 395 annotated broadcast frames, train_val first.

    Attributes:
        image_names: (N,) frame names ('1.jpg', …) of their part.
        homographies: (N, 3, 3) float64, pitch yards → 1280 × 720 pixels (any sign).
        partition: ``{"train": (0, 209), "test": (209, 395)}`` half-open ranges.
    """

    image_names: tuple[str, ...]
    homographies: np.ndarray
    partition: dict[str, tuple[int, int]]


@lru_cache(maxsize=1)
def load_worldcup_poses() -> WorldCupPoses:
    """Read ``train_val.mat`` and ``test.mat`` (MATLAB struct arrays ``annotation``)."""
    import scipy.io  # here: datasets without poses import this module but never need scipy (≈ 0.1 s)

    names, homographies, partition, start = [], [], {}, 0
    for part, filename in _PARTS:
        annotation = scipy.io.loadmat(data_dir() / filename)["annotation"][0]
        names += [str(entry["image_name"][0]) for entry in annotation]
        homographies += [np.asarray(entry["homography"], np.float64) for entry in annotation]
        partition[part] = (start, start + len(annotation))
        start += len(annotation)
    H = np.stack(homographies)
    H.flags.writeable = False
    return WorldCupPoses(tuple(names), H, partition)


def _poses(name: str) -> WorldCupPoses:
    """The pose set ``name``, checked against the sizes configuration validates with."""
    if name != "worldcup2014":
        raise ConfigError(f"poses: unknown pose set {name!r}; known: worldcup2014")
    poses = load_worldcup_poses()
    sizes = {part: stop - start for part, (start, stop) in poses.partition.items()}
    if sizes != POSE_SET_SPLITS[name]:
        # config.py cannot read the annotations (it imports nothing of synthcal), so it records the sizes
        raise ValueError(f"{data_dir()}: the {name} annotations hold {sizes} poses, "
                         f"but synthcal.config.POSE_SET_SPLITS records {POSE_SET_SPLITS[name]}")
    return poses


def pose_partition(name: str) -> dict[str, np.ndarray]:
    """The fixed train/test pool indices of a pose set, e.g. 209 + 186."""
    return {part: np.arange(*bounds, dtype=np.int64) for part, bounds in _poses(name).partition.items()}


def pose_attributes(name: str) -> dict:
    """What a poses store records about its cameras (group attribute ``poses``)."""
    poses = _poses(name)
    return {
        "set": name,
        "partition": {part: list(bounds) for part, bounds in poses.partition.items()},
        "image_names": list(poses.image_names),
        "source": "World Cup 2014 (Homayounfar et al. 2017) via SCCvSD (Chen & Little 2019), BSD 2-Clause",
        "frame": list(WC14_FRAME),
    }


def bird_eye_to_yards() -> np.ndarray:
    """(3, 3) affine map from a soccer-scene bird's-eye pixel to pitch yards."""
    # Pitch metres (scene convention: y_m grows away from the camera) → pixels, from
    # the scene module itself, and the matching yard coordinates of three points.
    metres = np.array([[0.0, 0.0], [soccer.PITCH_LENGTH_M, 0.0], [0.0, soccer.PITCH_WIDTH_M]])
    pixels = np.stack(soccer.pitch_to_pixel(metres[:, 0], metres[:, 1]), axis=-1)
    yards = np.stack([metres[:, 0], soccer.PITCH_WIDTH_M - metres[:, 1]], axis=-1) / METRES_PER_YARD
    # Solve yards = A · pixels for the 2 × 3 affine part.
    design = np.c_[pixels, np.ones(3)]
    affine = np.linalg.solve(design, yards).T
    return np.vstack([affine, [0.0, 0.0, 1.0]])


def bird_eye_to_pitch(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Soccer-scene bird's-eye pixels → pitch metres ``(x_m, y_m)`` (scene convention)."""
    A = bird_eye_to_yards()
    yards_x = A[0, 0] * np.asarray(u, np.float64) + A[0, 2]
    yards_y = A[1, 1] * np.asarray(v, np.float64) + A[1, 2]
    return yards_x * METRES_PER_YARD, soccer.PITCH_WIDTH_M - yards_y * METRES_PER_YARD


def frame_scaling(image_size: tuple[int, int], frame: tuple[int, int] = WC14_FRAME) -> np.ndarray:
    """(3, 3) map from ``frame`` pixels to ``image_size`` pixels (pixel centres kept)."""
    sx, sy = image_size[0] / frame[0], image_size[1] / frame[1]
    return np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])


def convert_homographies(homographies_yards: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Yard → 1280 × 720 homographies as soccer-scene bird's-eye → output image.

    Args:
        homographies_yards: (N, 3, 3) as in the ``.mat`` files.
        image_size: ``(width, height)`` of the output.

    Returns:
        (N, 3, 3) float64 ``S · H · A`` with the depth sign, scaled by a positive
        factor to the camera model's own scale ``K [r1 r2 t]`` (unit rotation
        columns, as grid samples have; SPEC §2 allows positive factors).
    """
    H = frame_scaling(image_size) @ np.asarray(homographies_yards, np.float64) @ bird_eye_to_yards()
    return camera_scaled(H, image_size)


def camera_scaled(homographies: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Bird's-eye → image homographies of any sign and scale, with the depth sign and the camera's scale.

    The sign is fixed with :func:`~synthcal.generate.camera.orient_homography`
    (SPEC §2), then each is divided by the positive factor that gives it the camera
    model's own scale ``K [r1 r2 t]`` (unit rotation columns, as grid samples have),
    ``K`` from :func:`~synthcal.generate.camera.decompose_homography`'s focal. Where
    no real focal exists (a homography no roll-free pinhole camera makes, e.g. an
    affine one), the Frobenius norm is the factor instead.

    Args:
        homographies: (N, 3, 3) bird's-eye → image at ``image_size``, invertible.
        image_size: ``(width, height)`` of the images.

    Returns:
        (N, 3, 3) float64.
    """
    H = orient_homography(homographies, image_size)
    with np.errstate(all="ignore"):
        focal = decompose_homography(H, image_size)["focal_px"]
        usable = np.isfinite(focal) & (focal > 0)
        # a stand-in focal keeps K invertible; its rows take the fallback below
        columns = np.linalg.solve(intrinsics(np.where(usable, focal, 1.0), image_size), H)[..., :, :2]
        scale = np.linalg.norm(columns, axis=-2).mean(axis=-1)
    fallback = ~usable | ~np.isfinite(scale) | ~(scale > 0)
    scale = np.where(fallback, np.linalg.norm(H, axis=(-2, -1)), scale)
    return H / scale[..., None, None]


def _project(params: np.ndarray, ground: np.ndarray, centre: tuple[float, float]) -> np.ndarray:
    """Image pixels (2, P) of ground points (2, P) seen by a PTZ camera with roll.

    ``params`` = pan, tilt, roll (degrees; roll as in ``decompose_homography``),
    log focal, X, Y, Z (SPEC §2 frame, Z the height).
    """
    pan, tilt, roll = np.deg2rad(params[:3])
    focal, x, y, z = np.exp(params[3]), params[4], params[5], params[6]
    view = np.array([np.cos(tilt) * np.cos(pan), np.cos(tilt) * np.sin(pan), -np.sin(tilt)])
    right = np.array([-np.sin(pan), np.cos(pan), 0.0])
    down = np.cross(view, right)
    right, down = np.cos(roll) * right + np.sin(roll) * down, np.cos(roll) * down - np.sin(roll) * right
    rays = np.vstack([ground[0] - x, ground[1] - y, np.full(ground.shape[1], z)])  # point − centre
    depth = view @ rays
    return np.vstack([centre[0] + focal * (right @ rays) / depth, centre[1] + focal * (down @ rays) / depth])


def fit_cameras(
    homographies: np.ndarray,
    image_size: tuple[int, int],
    fallback: tuple[tuple[float, float, float], float] | None = None,
) -> dict[str, np.ndarray]:
    """Cameras (with roll) that best reproduce given bird's-eye → image homographies.

    :func:`~synthcal.generate.camera.decompose_homography` is exact for cameras of
    the model, but a real annotated homography has 8 degrees of freedom against the
    camera's 7, and with long broadcast focal lengths its two focal equations
    disagree by tens of percent: on World Cup 2014 the closed form is off by ~200 px
    (median, at 1280 wide). Starting from it, each camera is refined by minimising
    the reprojection error over a 9 × 6 grid of image pixels that see the ground;
    a second start (``fallback``: position and focal) is tried when the first ends
    above 1 % of the width. Bounds keep tilt ≤ 5°, |roll| ≤ 30° and the focal within
    0.1–20 image widths.

    Args:
        homographies: (N, 3, 3) with the depth sign.
        image_size: ``(width, height)`` of their images.
        fallback: ``((X, Y, Z), focal_px)`` for the second start, or None.

    Returns:
        (N,) float64 ``pan_deg`` (world, heading included), ``tilt_deg``,
        ``roll_deg``, ``focal_px`` (image pixels), ``x``, ``y``, ``z`` and
        ``rms_px`` (the remaining reprojection error).
    """
    width, height = image_size
    centre = ((width - 1) / 2.0, (height - 1) / 2.0)
    xs, ys = np.meshgrid(np.linspace(0, width - 1, 9), np.linspace(0, height - 1, 6))
    pixels = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)])
    init = decompose_homography(homographies, image_size)
    low = np.array([-np.inf, -89.0, -30.0, np.log(0.1 * width), -np.inf, -np.inf, 1e-3])
    high = np.array([np.inf, 5.0, 30.0, np.log(20.0 * width), np.inf, np.inf, np.inf])
    out = np.empty((len(homographies), 8))
    for k, H in enumerate(np.asarray(homographies, np.float64)):
        ground = np.linalg.solve(H, pixels)
        seen = ground[2] > 0
        ground, target = ground[:2, seen] / ground[2, seen], pixels[:2, seen]
        starts = [[init["pan_deg"][k], init["tilt_deg"][k], init["roll_deg"][k], np.log(init["focal_px"][k]),
                   init["x"][k], init["y"][k], init["z"][k]]]
        if fallback is not None:
            (x, y, z), focal = fallback
            starts.append([init["pan_deg"][k], init["tilt_deg"][k], 0.0, np.log(focal), x, y, z])
        out[k, :7], out[k, 7] = _best_fit(starts, ground, target, centre, (low, high), 0.01 * width)
    out[:, 3] = np.exp(out[:, 3])
    names = ("pan_deg", "tilt_deg", "roll_deg", "focal_px", "x", "y", "z", "rms_px")
    return {name: out[:, i] for i, name in enumerate(names)}


def _best_fit(
    starts: list[list[float]],
    ground: np.ndarray,
    target: np.ndarray,
    centre: tuple[float, float],
    bounds: tuple[np.ndarray, np.ndarray],
    good_rms: float,
) -> tuple[np.ndarray, float]:
    """The best reprojection fit of one camera over its starts.

    Args:
        starts: the start parameters (as in :func:`_project`), tried in order
            until one ends below ``good_rms``.
        ground: (2, P) bird's-eye points; ``target``: (2, P) their pixels.
        centre: the principal point.
        bounds: (7,) lower and upper parameter bounds.

    Returns:
        (7,) parameters and their RMS reprojection error in pixels.
    """
    from scipy.optimize import least_squares  # here, as scipy.io above

    low, high = bounds

    def residuals(params: np.ndarray) -> np.ndarray:
        return (_project(params, ground, centre) - target).ravel()

    best: tuple[np.ndarray, float] | None = None
    for start in starts:
        x0 = np.clip(np.nan_to_num(np.asarray(start, np.float64)), low + 1e-6, high - 1e-6)
        fit = least_squares(residuals, x0, x_scale=np.array([1, 1, 1, 0.1, 10, 10, 10.0]), bounds=(low, high))
        rms = float(np.sqrt(np.mean(fit.fun ** 2)))
        if best is None or rms < best[1]:
            best = (fit.x, rms)
        if rms < good_rms:
            break
    if best is None:
        raise ValueError("fit_cameras: no start parameters")
    return best


def camera_fields(
    homographies: np.ndarray, scene: Scene, image_size: tuple[int, int], focal_reference_width: int
) -> dict[str, np.ndarray]:
    """Grid-style camera values of given bird's-eye → image homographies.

    Fitted with :func:`fit_cameras` (fallback start: the scene's camera position
    and the World Cup 2014 mean focal length).

    Returns:
        (N,) float64 ``pan_deg`` (heading removed, wrapped to [−180, 180)),
        ``tilt_deg``, ``focal_px`` (at ``focal_reference_width``), ``x``, ``y``,
        ``z`` (bird's-eye pixels), ``roll_deg`` and ``rms_px``.
    """
    fallback = None
    if scene.camera_position is not None:
        fallback = (scene.camera_position, WC14_MEAN_FOCAL_PX * image_size[0] / WC14_FRAME[0])
    fields = fit_cameras(homographies, image_size, fallback)
    fields["pan_deg"] = (fields["pan_deg"] - scene.heading_deg + 180.0) % 360.0 - 180.0
    fields["focal_px"] = fields["focal_px"] * focal_reference_width / image_size[0]
    return fields


def plan_poses(spec: DatasetSpec, scene: Scene) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Cameras and homographies of a dataset of given poses.

    Returns:
        camera fields (``CAMERA_FIELDS`` (N,) float64, ``grid_index`` (N,) int64
        all −1) and (N, 3, 3) homographies at ``spec.image_size``.
    """
    if spec.poses is None:
        raise ValueError(f"dataset {spec.name!r} has a grid, not given poses")
    H = convert_homographies(_poses(spec.poses).homographies, spec.image_size)
    fitted = camera_fields(H, scene, spec.image_size, spec.focal_reference_width)
    # roll and the fit's residual are not store fields: the homography is the ground truth
    camera = {name: fitted[name] for name in CAMERA_FIELDS}
    camera["grid_index"] = np.full(len(H), -1, np.int64)
    return camera, H


def in_grid(fields: dict[str, np.ndarray], grid: GridConfig) -> dict[str, np.ndarray]:
    """Which cameras lie inside a grid's pan, tilt and focal ranges (ends included).

    Returns:
        (N,) bool masks ``pan_deg``, ``tilt_deg``, ``focal_px`` and ``all``.
    """
    masks = {}
    for axis in ("pan_deg", "tilt_deg", "focal_px"):
        limits = getattr(grid, axis)
        masks[axis] = (fields[axis] >= limits.start - 1e-9) & (fields[axis] <= limits.stop + 1e-9)
    masks["all"] = masks["pan_deg"] & masks["tilt_deg"] & masks["focal_px"]
    return masks


@dataclass(frozen=True)
class RealCameras:
    """The World Cup 2014 cameras fitted at a dataset's image size, measured against a camera grid.

    Attributes:
        poses: the annotated frames (:func:`load_worldcup_poses`).
        homographies: (N, 3, 3) bird's-eye → image at the dataset's image size.
        fields: (N,) float64 per axis, as :func:`camera_fields`, but ``x``, ``y`` in
            pitch metres (:func:`bird_eye_to_pitch`) and ``z`` in metres.
        inside: (N,) bool masks of :func:`in_grid`.
    """

    poses: WorldCupPoses
    homographies: np.ndarray
    fields: dict[str, np.ndarray]
    inside: dict[str, np.ndarray]


def real_cameras(spec: DatasetSpec, scene: Scene, grid: GridConfig) -> RealCameras:
    """Fit the real cameras at ``spec``'s image size on ``scene`` (the pitch) and test them against ``grid``."""
    poses = load_worldcup_poses()
    H = convert_homographies(poses.homographies, spec.image_size)
    fields = camera_fields(H, scene, spec.image_size, spec.focal_reference_width)
    inside = in_grid(fields, grid)
    fields["x"], fields["y"] = bird_eye_to_pitch(fields["x"], fields["y"])
    fields["z"] = fields["z"] / scene.pixels_per_metre
    return RealCameras(poses, H, fields, inside)


def real_camera_lines(cameras: RealCameras, spec: DatasetSpec, grid_name: str, grid: GridConfig) -> list[str]:
    """The report of ``synthcal worldcup-stats``: min, median and max of each camera value, and how many
    cameras lie inside the grid's ranges."""
    n = len(cameras.homographies)
    parts = ", ".join(f"{k} {b - a}" for k, (a, b) in cameras.poses.partition.items())
    lines = [f"World Cup 2014: {n} real cameras ({parts}), fitted at {spec.image_size[0]} × {spec.image_size[1]}, "
             f"focal at width {spec.focal_reference_width}",
             f"{'':10s}{'min':>9s}{'median':>9s}{'max':>9s}   grid {grid_name!r}"]
    for axis in ("pan_deg", "tilt_deg", "focal_px", "roll_deg", "x", "y", "z", "rms_px"):
        values = cameras.fields[axis]
        rule = ""
        if axis in cameras.inside:
            limits = getattr(grid, axis)
            rule = f"{limits.start:g}..{limits.stop:g}: {cameras.inside[axis].sum()} inside"
        label = f"{axis} (m)" if axis in ("x", "y", "z") else axis
        lines.append(f"{label:10s}{values.min():9.1f}{np.median(values):9.1f}{values.max():9.1f}   {rule}")
    lines.append("(x, y: pitch metres, y growing away from the camera; z: height)")
    everything = cameras.inside["all"]
    lines.append(f"inside the {grid_name!r} grid's pan, tilt and focal ranges: {everything.sum()} of {n} "
                 f"({100 * everything.mean():.1f} %)")
    return lines


def montage_poses(poses: WorldCupPoses, count: int) -> np.ndarray:
    """(count,) int64 pool indices of ``count`` test poses, evenly spaced over the test part."""
    first, stop = poses.partition["test"]
    return np.linspace(first, stop - 1, count).round().astype(np.int64)
