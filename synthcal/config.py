"""``datasets.yaml``: the one place where configuration is read and validated.

Every error is a :class:`ConfigError` whose message names the file, the key path
and the offending value, and is raised before anything is written.

A dataset's *resolved* configuration (:class:`DatasetSpec`) is the dataset entry
with the file's ``defaults`` filled in and a *profile* (``smoke``, ``quick``,
``paper``) applied; its hash is recorded in every store it produces.

This module imports nothing of synthcal (it is the root of the import graph). It
also spells, once, the option vocabularies of the bundled models and the benchmark
(:data:`LOSSES`, :data:`MATCHINGS`, ...): ``Literal`` aliases for signatures (checked
by mypy and pydantic) and tuples of their values in the paper's order (argparse
``choices``, run-time checks). The values are plain strings: they are what run
records, run ids, cache keys and tables contain.
The few facts of the generator that validation needs are recorded here as data:
the names of the built-in scenes (:data:`BUILTIN_SCENE_NAMES`) and the fixed
train/test sizes of each set of given poses (:data:`POSE_SET_SPLITS`).
``synthcal.generate`` checks that its scenes and pose files agree with them.
"""

from __future__ import annotations

import hashlib
import json
import re
import zlib
from importlib import resources
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np
import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

__all__ = [
    "Model",
    "Training",
    "Loss",
    "Matching",
    "Segmentation",
    "StnTemplate",
    "ClassReduction",
    "Dictionary",
    "MODELS",
    "MODEL_LABELS",
    "TRAININGS",
    "LOSSES",
    "MATCHINGS",
    "SEGMENTATIONS",
    "STN_TEMPLATES",
    "CLASS_REDUCTIONS",
    "DICTIONARIES",
    "ConfigError",
    "check_dataset_name",
    "GRID_AXES",
    "BUILTIN_SCENE_NAMES",
    "POSE_SET_SPLITS",
    "AxisRange",
    "GridConfig",
    "AppearanceConfig",
    "SplitSizes",
    "OsmSourceConfig",
    "UserSceneConfig",
    "DatasetConfig",
    "TrainingSettings",
    "TrainingProfile",
    "ProfileConfig",
    "Config",
    "DatasetSpec",
    "default_config_path",
    "load_config",
]

# --- option vocabularies (SPEC §7, §9) ------------------------------------------------------------

# The paper's STN (``proposed``), Sha et al.'s localisation network as the paper describes it
# (``baseline``) or as the public CCBV re-implementation builds it (``ccbv``).
Model = Literal["proposed", "baseline", "ccbv"]
# Three stages one after another, each with its own loss, or all at once (SPEC §7).
Training = Literal["step-by-step", "end-to-end"]
# ``L_warp``: plain or topological (patch-wise) MSE / Dice (SPEC §7).
Loss = Literal["top-mse", "mse", "top-dice", "dice"]
# The score that defines each train image's correct template.
Matching = Literal["top-mse", "mse"]
# A trained UNet, or the true class maps for every compared estimator.
Segmentation = Literal["unet", "ground-truth"]
# The template the STN reads in training: the one the Siamese retrieves (as at test time) or the true best.
StnTemplate = Literal["retrieved", "ground-truth"]
# How MSE-based losses and matching scores reduce over the class channels (SPEC §7):
# ``sum``: the squared distance between per-pixel class vectors; ``mean``: that divided by C.
ClassReduction = Literal["sum", "mean"]
# What ``synthcal bench`` searches: the seed's dictionary split, or every pool sample
# outside the seed's train and test sets (README "The pool dictionary").
Dictionary = Literal["split", "pool"]
# Which RGB images a store holds: every sample's, or only those of drawn splits (synthcal.store.images).
Images = Literal["all", "splits"]

MODELS: tuple[Model, ...] = get_args(Model)
TRAININGS: tuple[Training, ...] = get_args(Training)
LOSSES: tuple[Loss, ...] = get_args(Loss)
MATCHINGS: tuple[Matching, ...] = get_args(Matching)
SEGMENTATIONS: tuple[Segmentation, ...] = get_args(Segmentation)
STN_TEMPLATES: tuple[StnTemplate, ...] = get_args(StnTemplate)
CLASS_REDUCTIONS: tuple[ClassReduction, ...] = get_args(ClassReduction)
DICTIONARIES: tuple[Dictionary, ...] = get_args(Dictionary)

# Model option → its label in run records and tables (the paper calls the baseline "sha2020").
MODEL_LABELS: dict[Model, str] = {"proposed": "proposed", "baseline": "sha2020", "ccbv": "sha2020-ccbv"}

GRID_AXES = ("pan_deg", "tilt_deg", "focal_px", "x", "y", "z")

# The built-in scenes a dataset's ``scene:`` may name besides the file's own
# ``scenes:``, in listing order; synthcal.generate.scenes.BUILTIN_SCENES has exactly these keys.
BUILTIN_SCENE_NAMES: tuple[str, ...] = (
    "intersection-1", "intersection-2", "intersection-3", "intersection-4", "intersection-5", "soccer",
)

# Each set of given poses (``poses:``) → the sizes of its fixed train/test partition
# (worldcup2014: the 209 train_val + 186 test frames; synthcal.generate.worldcup
# checks its annotation files against these).
POSE_SET_SPLITS: dict[str, dict[str, int]] = {"worldcup2014": {"train": 209, "test": 186}}


class ConfigError(ValueError):
    """Invalid configuration; the message names the file, key and value."""


# A dataset name becomes a file name (``NAME.zarr``): a plain name, never a path.
_PLAIN_NAME = re.compile(r"[A-Za-z0-9._-]+")


def check_dataset_name(name: str, where: str = "") -> None:
    """Refuse a dataset name that is not a plain file name.

    Plain: letters, digits, ``-``, ``_`` and ``.``, not ``.`` or ``..`` — so
    ``NAME.zarr`` lies inside the output folder.

    >>> check_dataset_name("intersection-1")
    >>> check_dataset_name("../escaped", "datasets.yaml: ")
    Traceback (most recent call last):
    ...
    synthcal.config.ConfigError: datasets.yaml: datasets.../escaped: a dataset name is a plain name: letters, digits, '-', '_' and '.', not '.' or '..' (value '../escaped')

    Raises:
        ConfigError: naming ``where`` (e.g. the file), the key and the value.
    """
    if not isinstance(name, str) or not _PLAIN_NAME.fullmatch(name) or name in (".", ".."):
        raise ConfigError(f"{where}datasets.{name}: a dataset name is a plain name: letters, digits, '-', '_' "
                          f"and '.', not '.' or '..' (value {name!r})")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class AxisRange(_Strict):
    """An inclusive range ``start..stop`` in steps of ``step`` (SPEC §3)."""

    start: float
    stop: float
    step: float = 1.0

    @field_validator("step")
    @classmethod
    def _positive_step(cls, step: float) -> float:
        if step <= 0:
            raise ValueError(f"step must be > 0, got {step}")
        return step

    @model_validator(mode="after")
    def _non_empty(self) -> AxisRange:
        if self.stop < self.start:
            raise ValueError(f"empty range: stop {self.stop} < start {self.start}")
        return self

    def values(self, name: str = "") -> np.ndarray:
        """The values of the range.

        Args:
            name: the axis name; a ``pan_deg`` range spanning 360° drops its upper end
                (≡ its lower end).

        Returns:
            (K,) float64 values.
        """
        count = int(np.floor((self.stop - self.start) / self.step + 1e-9)) + 1
        values = self.start + self.step * np.arange(count, dtype=np.float64)
        if name == "pan_deg" and count > 1 and np.isclose(values[-1] - values[0], 360.0):
            values = values[:-1]
        return values


class GridConfig(_Strict):
    """Camera grid; X/Y/Z left out means the scene's own camera position.

    With ``xy_relative`` the X and Y ranges are offsets from the scene's camera
    *anchor* (its ``camera_position``, or the scene centre ``(W/2, H/2)``), so one
    grid fits scenes of any size; Z is always the height above the ground.
    :meth:`anchored` turns such a grid into the absolute one it stands for, which
    is what a store records (a relative grid and its absolute spelling give the
    same store). ``xy_relative`` is left out of dumps when false, so absolute grids
    keep their configuration hash.
    """

    pan_deg: AxisRange
    tilt_deg: AxisRange
    focal_px: AxisRange
    x: AxisRange | None = None
    y: AxisRange | None = None
    z: AxisRange | None = None
    jitter: bool = False
    xy_relative: bool = False

    @model_validator(mode="after")
    def _position_all_or_none(self) -> GridConfig:
        given = [axis for axis in ("x", "y", "z") if getattr(self, axis) is not None]
        if given and len(given) != 3:
            raise ValueError(f"x, y and z must be given together or not at all, got only {given}")
        if self.xy_relative and not given:
            raise ValueError("xy_relative: true needs x, y and z ranges (offsets from the scene's anchor)")
        return self

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data: dict[str, Any] = handler(self)
        if not self.xy_relative:
            data.pop("xy_relative", None)
        return data

    def anchored(self, anchor: tuple[float, float]) -> GridConfig:
        """The absolute grid: X/Y offsets moved to ``anchor`` (``self`` when already absolute).

        Args:
            anchor: the scene's camera anchor ``(X, Y)`` in bird's-eye pixels.
        """
        if not self.xy_relative or self.x is None or self.y is None:
            return self
        x = self.x.model_copy(update={"start": self.x.start + anchor[0], "stop": self.x.stop + anchor[0]})
        y = self.y.model_copy(update={"start": self.y.start + anchor[1], "stop": self.y.stop + anchor[1]})
        return self.model_copy(update={"x": x, "y": y, "xy_relative": False})

    def axis(self, name: str) -> AxisRange | None:
        """The range of one of :data:`GRID_AXES` (None: X/Y/Z left to the scene)."""
        if name not in GRID_AXES:
            raise KeyError(f"grid axis must be one of {', '.join(GRID_AXES)}, got {name!r}")
        axis: AxisRange | None = getattr(self, name)
        return axis

    def size(self) -> int:
        """Number of cameras in the grid (a missing X/Y/Z axis counts as one value)."""
        size = 1
        for name in GRID_AXES:
            axis = self.axis(name)
            size *= 1 if axis is None else len(axis.values(name))
        return size


class AppearanceConfig(_Strict):
    """Ranges of the per-sample photometric changes (see render.Appearance)."""

    brightness: float = Field(20.0, ge=0)
    contrast: float = Field(0.2, ge=0, lt=1)
    blur_sigma: float = Field(0.8, ge=0)
    noise_sigma: float = Field(3.0, ge=0)


class SplitSizes(_Strict):
    """Sizes of the per-seed train / test / dictionary splits (SPEC §6)."""

    train: int = Field(3000, ge=1)
    test: int = Field(500, ge=1)
    dictionary: int = Field(1000, ge=1)

    @property
    def total(self) -> int:
        return self.train + self.test + self.dictionary


class OsmSourceConfig(_Strict):
    """An OpenStreetMap scene's source (``osm:`` of a scene entry; SPEC §4).

    ``file`` (``.osm``, ``.osm.pbf``, ``.osm.bz2``) is relative to the YAML file;
    ``center`` is ``[lat, lon]`` in WGS84 degrees; ``size_m`` the window
    ``[width, height]`` in metres; ``classes`` moves tag selectors to classes
    (``{terrain: ["landuse=farmland"]}``, see docs/osm.md); ``seed`` seeds the RGB.
    """

    file: Path
    center: tuple[float, float]
    size_m: tuple[float, float] = (130.0, 190.0)
    pixels_per_metre: float = Field(10.0, gt=0, allow_inf_nan=False)
    classes: dict[str, list[str]] | None = None
    seed: int = 0

    @field_validator("center")
    @classmethod
    def _lat_lon(cls, center: tuple[float, float]) -> Any:
        if not (-90 <= center[0] <= 90 and -180 <= center[1] <= 180):
            raise ValueError(f"center must be [lat, lon] in degrees (-90..90, -180..180), got {list(center)}")
        return center

    @field_validator("size_m")
    @classmethod
    def _size(cls, size: tuple[float, float]) -> Any:
        if not all(0 < s < float("inf") for s in size):
            raise ValueError(f"size_m must be [width, height] in metres, both > 0, got {list(size)}")
        return size


# Keys of a PNG scene that an osm: scene takes from its source instead.
_PNG_ONLY_KEYS = ("image", "semantic", "palette", "classes", "pixels_per_metre")


class UserSceneConfig(_Strict):
    """A scene from two PNG files; paths are relative to the YAML file.

    Or, with ``osm:`` instead of ``image``/``semantic``/``palette``/``classes``/
    ``pixels_per_metre``, a scene built from OpenStreetMap (:class:`OsmSourceConfig`).

    ``classes`` names class ids 0..3; ``heading_deg`` is added to every pan;
    ``camera_position`` ``(X, Y, Z)`` (bird's-eye pixels, ``Z`` the height) is the
    camera of a grid without X/Y/Z and the anchor of a relative grid (default
    anchor: the scene centre); ``pixels_per_metre`` is the ground scale.
    """

    image: Path | None = None
    semantic: Path | None = None
    osm: OsmSourceConfig | None = None
    palette: dict[int, tuple[int, int, int]] | None = None
    classes: tuple[str, str, str, str] | None = None
    heading_deg: float = Field(0.0, allow_inf_nan=False)
    camera_position: tuple[float, float, float] | None = None
    pixels_per_metre: float = Field(10.0, gt=0, allow_inf_nan=False)

    @field_validator("classes")
    @classmethod
    def _class_names(cls, classes: tuple[str, str, str, str] | None) -> Any:
        if classes is not None and (any(not name.strip() for name in classes) or len(set(classes)) != 4):
            raise ValueError(f"classes must be 4 distinct, non-empty names (ids 0..3), got {list(classes)}")
        return classes

    @field_validator("camera_position")
    @classmethod
    def _camera_position(cls, position: tuple[float, float, float] | None) -> Any:
        if position is not None and (not all(np.isfinite(position)) or not position[2] > 0):
            raise ValueError(f"camera_position must be [X, Y, Z] in bird's-eye pixels with Z (height) > 0, "
                             f"got {list(position)}")
        return position

    @field_validator("palette")
    @classmethod
    def _palette_classes(cls, palette: dict[int, tuple[int, int, int]] | None) -> Any:
        for class_id, colour in (palette or {}).items():
            if not 0 <= class_id <= 3:
                raise ValueError(f"palette class id must be 0..3, got {class_id}")
            if any(not 0 <= c <= 255 for c in colour):
                raise ValueError(f"palette colour must be 0..255, got {colour}")
        return palette

    @model_validator(mode="after")
    def _one_source(self) -> UserSceneConfig:
        if self.osm is None:
            if self.image is None or self.semantic is None:
                raise ValueError("a scene needs image and semantic (two PNG files) or osm (an OpenStreetMap extract)")
            return self
        clash = [key for key in _PNG_ONLY_KEYS if key in self.model_fields_set]
        if clash:
            raise ValueError(f"an osm scene takes its classes and scale from osm:, not {', '.join(clash)}")
        return self

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data: dict[str, Any] = handler(self)
        if self.osm is None:
            data.pop("osm", None)  # PNG scenes keep their configuration hash
        else:  # what an osm scene does not take, so that the dump validates again (a store's attributes)
            for key in _PNG_ONLY_KEYS:
                data.pop(key, None)
        return data


class DatasetConfig(_Strict):
    """One dataset: a scene and its cameras (other keys override defaults).

    The cameras come from exactly one of ``grid:`` (sampled: ``pool_size`` of them)
    or ``poses:`` (given: the real broadcast cameras of ``worldcup2014``, whose
    pool is all of them and whose train/test sets are fixed). ``dictionary_from``
    names the datasets whose pools provide the dictionary instead of this dataset's
    own pool (a mixed dictionary, SPEC §6); a ``poses:`` dataset needs it.
    ``seed`` (≥ 0) is the dataset's own pool seed, used as is; without it the pool
    is drawn from ``defaults.seed`` and the name (:attr:`DatasetSpec.pool_entropy`).
    ``min_field_fraction`` (0 ≤ f < 1) redraws grid cameras whose semantic map has
    fewer non-background pixels than that share. ``dictionary`` is what ``synthcal
    bench`` searches for this dataset (``split``, the default, or ``pool``); it
    changes no stored byte. ``images`` is ``all`` (the default: every sample's RGB
    image is stored) or ``splits`` (images only for samples some drawn split uses;
    :mod:`synthcal.store.images`).
    """

    scene: str
    grid: str | None = None
    poses: Literal["worldcup2014"] | None = None
    pool_size: int | None = Field(None, ge=1)
    dictionary_from: tuple[str, ...] | None = None
    seed: int | None = Field(None, ge=0)
    image_size: tuple[int, int] | None = None
    splits: SplitSizes | None = None
    min_field_fraction: float | None = Field(None, ge=0, lt=1)
    dictionary: Dictionary | None = None
    images: Images | None = None

    @field_validator("dictionary_from", mode="before")
    @classmethod
    def _one_or_many(cls, value: Any) -> Any:
        return (value,) if isinstance(value, str) else value

    @model_validator(mode="after")
    def _cameras(self) -> DatasetConfig:
        if (self.grid is None) == (self.poses is None):
            given = "both" if self.grid is not None else "neither"
            raise ValueError(f"give exactly one of grid: (sampled cameras) or poses: (given cameras), got {given}")
        if self.grid is not None and self.pool_size is None:
            raise ValueError("pool_size is required with grid:")
        if self.poses is not None and self.pool_size is not None:
            raise ValueError(f"pool_size: the poses {self.poses!r} fix the pool; leave pool_size out")
        if self.poses is not None and not self.dictionary_from:
            raise ValueError(f"poses {self.poses!r}: every pose is in train or test, so dictionary_from: is required")
        if self.poses is not None and self.min_field_fraction:
            raise ValueError(f"min_field_fraction: the poses {self.poses!r} are given cameras, none can be redrawn")
        if self.dictionary == "pool" and self.dictionary_from:
            raise ValueError("dictionary: pool searches the dataset's own pool, but its dictionary comes from "
                             f"dictionary_from {list(self.dictionary_from)}; leave dictionary out")
        return self


class Defaults(_Strict):
    image_size: tuple[int, int] = (256, 144)
    focal_reference_width: int = Field(256, ge=1)
    shard_size: int = Field(64, ge=1)
    seed: int = Field(0, ge=0)
    supersample: int = Field(2, ge=1, le=8)
    appearance: AppearanceConfig = AppearanceConfig()
    splits: SplitSizes = SplitSizes()
    split_seeds: tuple[int, ...] = (0, 1, 2, 3, 4)

    @field_validator("image_size")
    @classmethod
    def _positive_size(cls, size: tuple[int, int]) -> tuple[int, int]:
        if min(size) < 8:
            raise ValueError(f"image_size must be at least 8 × 8 pixels, got {list(size)}")
        return size


class TrainingSettings(_Strict):
    """Network sizes and schedules of the bundled models (SPEC §7) under one profile.

    ``work_size`` is the ``(width, height)`` at which the networks see maps and
    images (None: the store's image size); a smaller one trades accuracy for
    speed on a CPU, and homographies are converted exactly between the two
    resolutions. ``max_train`` caps the train images used (the first ones of the
    split, which is itself a random draw). Epoch counts are per stage of
    step-by-step training; ``end_to_end_epochs`` is the whole end-to-end
    schedule, whose warm-up thresholds (SPEC §7: 20 and 40 of the paper's 100)
    scale with it (:func:`synthcal.training.end_to_end_stage`).
    ``scene_downsample`` reduces the bird's-eye map that ``L_warp`` samples, which
    anti-aliases it (:mod:`synthcal.training`). ``stn_template`` is the template
    the STN reads in training: ``retrieved`` (the Siamese's nearest, as at test
    time) or ``ground-truth`` (the template of lowest matching score).
    ``class_reduction`` is how MSE-based warp losses and matching scores reduce
    over the class channels (SPEC §7; docs/decisions.md gives the measurement
    behind the default). ``batch_norm`` switches the STN's batch normalisation
    (None: each STN's own default — on for ``proposed`` and ``ccbv``, off for
    ``baseline``; :mod:`synthcal.models.stn`), so BN is an ablation of its own.
    """

    work_size: tuple[int, int] | None = None
    max_train: int | None = Field(None, ge=1)
    batch_size: int = Field(16, ge=1)
    learning_rate: float = Field(1e-3, gt=0)
    unet_width: int = Field(16, ge=1)
    unet_depth: int = Field(4, ge=1)
    unet_epochs: int = Field(20, ge=1)
    siamese_width: int = Field(32, ge=1)
    embedding_dim: int = Field(128, ge=2)
    siamese_epochs: int = Field(20, ge=1)
    stn_width: int = Field(32, ge=1)
    stn_epochs: int = Field(40, ge=1)
    end_to_end_epochs: int = Field(100, ge=3)
    scene_downsample: int = Field(4, ge=1)
    stn_template: StnTemplate = "retrieved"
    class_reduction: ClassReduction = "sum"
    batch_norm: bool | None = None

    @field_validator("work_size")
    @classmethod
    def _work_size(cls, size: tuple[int, int] | None) -> tuple[int, int] | None:
        if size is not None and min(size) < 16:
            raise ValueError(f"work_size must be at least 16 × 16 pixels, got {list(size)}")
        return size


class TrainingProfile(TrainingSettings):
    """A profile's ``training:`` block: the settings and the default segmentation.

    ``segmentation: ground-truth`` feeds true semantic maps to the matching and STN
    stages instead of a trained UNet's (SPEC §7, "Optional segmentation"); the
    command line's ``--segmentation`` overrides it.
    """

    segmentation: Segmentation = "unet"

    def settings(self) -> dict[str, Any]:
        """The :class:`TrainingSettings` fields as a plain dict (what estimators take).

        ``batch_norm`` is left out while None (each STN's default), so that the runs
        recorded before it existed keep their ids (the settings are in the run's hash).
        """
        unset = {"batch_norm"} if self.batch_norm is None else set()
        return self.model_dump(mode="json", exclude={"segmentation", *unset})


class ProfileConfig(_Strict):
    """Overrides applied to every dataset: sizes for tests, laptops or the paper,
    the sizes of the bundled models (``training:``) and the dictionary ``bench``
    searches (``dictionary:``, for every dataset with an own pool) and which images
    stores keep (``images:``, overriding the datasets')."""

    image_size: tuple[int, int] | None = None
    shard_size: int | None = Field(None, ge=1)
    max_pool_size: int | None = Field(None, ge=1)
    supersample: int | None = Field(None, ge=1, le=8)
    splits: SplitSizes | None = None
    training: TrainingProfile | None = None
    dictionary: Dictionary | None = None
    images: Images | None = None


class Config(_Strict):
    version: int = 1
    defaults: Defaults = Defaults()
    grids: dict[str, GridConfig]
    scenes: dict[str, UserSceneConfig] = {}
    datasets: dict[str, DatasetConfig]
    # target dataset → the datasets whose pools give its mixed dictionary (SPEC §6)
    mixed_dictionaries: dict[str, tuple[str, ...]] = {}
    profiles: dict[str, ProfileConfig] = {}


class DatasetSpec(_Strict):
    """Everything that determines a generated store's arrays, and its splits.

    ``grid`` is None for a dataset of given ``poses``. ``mixed_sources`` lists the
    datasets whose pools give the mixed dictionary (empty: none);
    ``own_dictionary`` is False when the dictionary comes only from them
    (``dictionary_from``).

    ``seed`` is the configured seed: the dataset's own ``seed:`` if it has one
    (``seed_from_name`` False: the pool is drawn from it as is), else the file's
    ``defaults.seed``, which :attr:`pool_entropy` combines with the dataset's name
    so that every dataset draws an independent pool (SPEC §6).
    ``min_field_fraction`` > 0 redraws cameras whose semantic map has fewer
    non-background pixels than that fraction (:mod:`synthcal.generate.pipeline`).
    """

    name: str
    scene: str
    user_scene: UserSceneConfig | None
    grid: GridConfig | None
    poses: str | None = None
    pool_size: int
    seed: int
    seed_from_name: bool = True
    min_field_fraction: float = 0.0
    image_size: tuple[int, int]
    focal_reference_width: int
    shard_size: int
    supersample: int
    appearance: AppearanceConfig
    splits: SplitSizes
    split_seeds: tuple[int, ...]
    mixed_sources: tuple[str, ...] = ()
    own_dictionary: bool = True
    images: Images = "all"

    def stored_config(self) -> dict[str, Any]:
        """The ``config`` attribute a store records: ``images`` left out when ``all``
        (stores of the default stay byte-identical to those made before the option)."""
        return self.model_dump(mode="json", exclude={"images"} if self.images == "all" else set())

    def config_hash(self) -> str:
        """SHA-256 of the canonical JSON of what determines the pool's arrays.

        Split sizes, seeds and dictionary sources are left out: splits are drawn
        later, inside the store, and changing them must not invalidate a generated
        pool. ``poses`` is left out when unset, so grid datasets keep their hash;
        ``images`` when ``all``, so default stores keep theirs.
        A store records the hash of the spec whose relative grid is made absolute
        at the scene's anchor (``synthcal.generate.pipeline.anchored_spec``).
        """
        exclude = {"splits", "split_seeds", "mixed_sources", "own_dictionary"}
        if self.poses is None:
            exclude.add("poses")
        if self.images == "all":
            exclude.add("images")
        pool = self.model_dump(mode="json", exclude=exclude)
        text = json.dumps(pool, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def pool_entropy(self) -> int | tuple[int, int]:
        """The ``numpy.random.SeedSequence`` entropy of the pool's random streams.

        ``(seed, zlib.crc32(name.encode()))`` — stable across runs, machines and
        Python versions (unlike ``hash``) — or, for a dataset with its own
        ``seed:``, that seed as is. The cameras are drawn with
        ``SeedSequence(pool_entropy, spawn_key=(0,))`` and sample ``i``'s
        appearance with ``spawn_key=(1, i)``.
        """
        return (self.seed, zlib.crc32(self.name.encode())) if self.seed_from_name else self.seed

    def pool_seed_attributes(self) -> dict[str, Any]:
        """How the pool's seed was derived, as recorded in the store's ``pool_seed`` attribute."""
        entropy = self.pool_entropy
        rule = ("numpy.random.SeedSequence([seed, zlib.crc32(dataset.encode())])" if self.seed_from_name
                else "numpy.random.SeedSequence(seed): the dataset's own seed, as is")
        return {"seed": self.seed, "entropy": list(entropy) if isinstance(entropy, tuple) else entropy,
                "rule": rule, "from_name": self.seed_from_name}


def default_config_path() -> Path:
    """``./datasets.yaml`` when present, else the copy shipped with the package."""
    local = Path("datasets.yaml")
    if local.is_file():
        return local
    return Path(str(resources.files("synthcal") / "datasets.yaml"))


def _format_errors(path: Path, error: ValidationError, raw: Any) -> str:
    lines = [f"{path}: invalid configuration"]
    for item in error.errors():
        key = ".".join(str(part) for part in item["loc"])
        value = item.get("input")
        if item["type"] == "missing":
            lines.append(f"  {key}: missing required key")
        elif item["type"] == "extra_forbidden":
            lines.append(f"  {key}: unknown key (value {value!r})")
        else:
            message = item["msg"].removeprefix("Value error, ")
            lines.append(f"  {key}: {message} (value {value!r})")
    return "\n".join(lines)


class LoadedConfig:
    """A validated configuration file and the datasets it can resolve."""

    def __init__(self, path: Path, config: Config) -> None:
        self.path = path
        self.config = config

    @property
    def dataset_names(self) -> list[str]:
        return list(self.config.datasets)

    def resolve(self, dataset: str, profile: str | None = None, pool_size: int | None = None) -> DatasetSpec:
        """The resolved spec of one dataset under a profile.

        Args:
            dataset: a key of ``datasets``.
            profile: a key of ``profiles`` (None: the file's defaults alone).
            pool_size: overrides the pool size (≥ 1; not for a dataset of given poses).

        Raises:
            ConfigError: unknown dataset or profile, a bad ``pool_size``, or a pool
                larger than its grid.
        """
        cfg = self.config
        if dataset not in cfg.datasets:
            raise ConfigError(
                f"{self.path}: datasets.{dataset}: unknown dataset {dataset!r}; known: {', '.join(cfg.datasets)}"
            )
        if profile is not None and profile not in cfg.profiles:
            raise ConfigError(
                f"{self.path}: profiles.{profile}: unknown profile {profile!r}; known: {', '.join(cfg.profiles)}"
            )
        entry = cfg.datasets[dataset]
        prof = cfg.profiles[profile] if profile is not None else ProfileConfig()
        d = cfg.defaults
        splits = prof.splits or entry.splits or d.splits
        if entry.poses is not None:
            pool, splits = self._pose_pool(dataset, entry.poses, entry.splits, splits, pool_size)
        else:
            pool = self._grid_pool(dataset, entry, prof, pool_size)
        spec = DatasetSpec(
            name=dataset,
            scene=entry.scene,
            user_scene=cfg.scenes.get(entry.scene),
            grid=None if entry.grid is None else cfg.grids[entry.grid],
            poses=entry.poses,
            pool_size=pool,
            seed=d.seed if entry.seed is None else entry.seed,
            seed_from_name=entry.seed is None,
            min_field_fraction=entry.min_field_fraction or 0.0,
            image_size=prof.image_size or entry.image_size or d.image_size,
            focal_reference_width=d.focal_reference_width,
            shard_size=prof.shard_size or d.shard_size,
            supersample=prof.supersample or d.supersample,
            appearance=d.appearance,
            splits=splits,
            split_seeds=d.split_seeds,
            mixed_sources=entry.dictionary_from or cfg.mixed_dictionaries.get(dataset, ()),
            own_dictionary=entry.dictionary_from is None,
            images=prof.images or entry.images or "all",
        )
        if spec.grid is None:
            return spec
        size = spec.grid.size()
        if spec.pool_size > size:
            raise ConfigError(
                f"{self.path}: datasets.{dataset}.pool_size: {spec.pool_size} samples asked for, "
                f"but grid {entry.grid!r} holds only {size} cameras (value {spec.pool_size})"
            )
        return spec

    def training(self, profile: str | None = None) -> TrainingProfile:
        """The ``training:`` block of a profile (the built-in defaults without one).

        Raises:
            ConfigError: unknown profile.
        """
        if profile is None:
            return TrainingProfile()
        if profile not in self.config.profiles:
            raise ConfigError(
                f"{self.path}: profiles.{profile}: unknown profile {profile!r}; "
                f"known: {', '.join(self.config.profiles)}"
            )
        return self.config.profiles[profile].training or TrainingProfile()

    def dictionary(self, dataset: str, profile: str | None = None) -> Dictionary:
        """The dictionary ``bench`` searches for a dataset: the profile's ``dictionary:``, else the
        dataset's, else ``split``. A dataset whose dictionary comes from others (``dictionary_from``)
        or that is not in the file (a ``mixed-K`` label) always gets ``split`` here: its own
        (mixed) dictionary.

        Raises:
            ConfigError: unknown profile.
        """
        if profile is not None and profile not in self.config.profiles:
            raise ConfigError(f"{self.path}: profiles.{profile}: unknown profile {profile!r}; "
                              f"known: {', '.join(self.config.profiles)}")
        entry = self.config.datasets.get(dataset)
        if entry is None or entry.dictionary_from:
            return "split"
        prof = self.config.profiles[profile] if profile is not None else ProfileConfig()
        return prof.dictionary or entry.dictionary or "split"

    def _grid_pool(self, dataset: str, entry: DatasetConfig, prof: ProfileConfig, pool_size: int | None) -> int:
        """Pool size of a grid dataset: ``pool_size`` if given, else the entry's capped by the profile."""
        if pool_size is not None:
            if pool_size < 1:
                raise ConfigError(f"pool_size: the pool size must be ≥ 1 (value {pool_size})")
            return pool_size
        if entry.pool_size is None:  # DatasetConfig requires it with grid:, so only a hand-built entry gets here
            raise ConfigError(f"{self.path}: datasets.{dataset}.pool_size: missing required key")
        return entry.pool_size if prof.max_pool_size is None else min(entry.pool_size, prof.max_pool_size)

    def _pose_pool(
        self, dataset: str, poses: str, entry_splits: SplitSizes | None, splits: SplitSizes, pool_size: int | None
    ) -> tuple[int, SplitSizes]:
        """Pool size and split sizes of a dataset of given poses.

        The pool is every pose (profiles do not cap it) and train/test are the
        poses' own partition (:data:`POSE_SET_SPLITS`); only the dictionary size
        comes from the profile, the entry (``entry_splits``) or the defaults.
        """
        key = f"{self.path}: datasets.{dataset}"
        if pool_size is not None:
            raise ConfigError(f"{key}: pool_size: the poses {poses!r} fix the pool size (value {pool_size})")
        fixed = dict(POSE_SET_SPLITS[poses])
        if entry_splits is not None:
            for name in sorted(entry_splits.model_fields_set & set(fixed)):
                value = getattr(entry_splits, name)
                if value != fixed[name]:
                    raise ConfigError(
                        f"{key}.splits.{name}: the poses {poses!r} fix {name} at {fixed[name]} (value {value})"
                    )
        return sum(fixed.values()), splits.model_copy(update=fixed)


def _check_references(path: Path, config: Config) -> None:
    """Every name a dataset or ``mixed_dictionaries`` refers to exists (in file order)."""
    for name, entry in config.datasets.items():
        _check_dataset_references(path, config, name, entry)
    _check_mixed_dictionaries(path, config)


def _check_dataset_references(path: Path, config: Config, name: str, entry: DatasetConfig) -> None:
    """One dataset's name is plain and its ``dictionary_from``, ``scene`` and ``grid`` name things that exist."""
    check_dataset_name(name, f"{path}: ")
    for source in entry.dictionary_from or ():
        if source not in config.datasets or source == name:
            raise ConfigError(
                f"{path}: datasets.{name}.dictionary_from: {source!r} must be another dataset; "
                f"known: {', '.join(config.datasets)}"
            )
    if entry.dictionary_from and name in config.mixed_dictionaries:
        raise ConfigError(
            f"{path}: mixed_dictionaries.{name}: the dataset already takes its dictionary from "
            f"datasets.{name}.dictionary_from (value {list(config.mixed_dictionaries[name])})"
        )
    if entry.poses == "worldcup2014" and entry.scene != "soccer":
        raise ConfigError(
            f"{path}: datasets.{name}.scene: the poses 'worldcup2014' are World Cup broadcast cameras "
            f"over the 'soccer' scene (value {entry.scene!r})"
        )
    if entry.grid is not None and entry.grid not in config.grids:
        raise ConfigError(
            f"{path}: datasets.{name}.grid: unknown grid {entry.grid!r}; known: {', '.join(config.grids)}"
        )
    if entry.scene not in config.scenes and entry.scene not in BUILTIN_SCENE_NAMES:
        known = ", ".join([*BUILTIN_SCENE_NAMES, *config.scenes])
        raise ConfigError(f"{path}: datasets.{name}.scene: unknown scene {entry.scene!r}; known: {known}")


def _check_mixed_dictionaries(path: Path, config: Config) -> None:
    """Each ``mixed_dictionaries`` target and its sources are distinct, other datasets."""
    for target, sources in config.mixed_dictionaries.items():
        if target not in config.datasets:
            raise ConfigError(
                f"{path}: mixed_dictionaries.{target}: unknown dataset {target!r}; known: {', '.join(config.datasets)}"
            )
        if not sources or len(set(sources)) != len(sources):
            raise ConfigError(f"{path}: mixed_dictionaries.{target}: list distinct source datasets (value {list(sources)})")
        for source in sources:
            if source not in config.datasets or source == target:
                raise ConfigError(
                    f"{path}: mixed_dictionaries.{target}: {source!r} must be another dataset "
                    f"(value {list(sources)}); known: {', '.join(config.datasets)}"
                )


def _resolve_scene_paths(path: Path, scene: UserSceneConfig) -> UserSceneConfig:
    """A scene entry with its files made relative to the YAML file's folder."""
    if scene.osm is not None:
        return scene.model_copy(update={"osm": scene.osm.model_copy(update={"file": path.parent / scene.osm.file})})
    assert scene.image is not None and scene.semantic is not None  # _one_source
    return scene.model_copy(update={"image": path.parent / scene.image, "semantic": path.parent / scene.semantic})


def load_config(path: str | Path | None = None) -> LoadedConfig:
    """Read and validate a ``datasets.yaml``.

    Args:
        path: the file (default: :func:`default_config_path`).

    Raises:
        ConfigError: unreadable file, YAML syntax, unknown key, bad value or
            dangling reference; the message names the file, key path and value.
    """
    path = Path(path) if path is not None else default_config_path()
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the configuration ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: the top level must be a mapping, got {type(raw).__name__}")
    try:
        config = Config.model_validate(raw)
    except ValidationError as exc:
        raise ConfigError(_format_errors(path, exc, raw)) from None
    resolved_scenes = {name: _resolve_scene_paths(path, scene) for name, scene in config.scenes.items()}
    config = config.model_copy(update={"scenes": resolved_scenes})
    _check_references(path, config)
    return LoadedConfig(path, config)
