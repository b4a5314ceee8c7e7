"""The schema of ``datasets.yaml``: one strict pydantic model per block of the file.

Models forbid unknown keys and are frozen; their validators turn a bad value into a
message naming the value (:func:`synthcal.config.load.load_config` adds the file and
key path).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    StrictBool,
    StrictFloat,
    StrictInt,
    field_validator,
    model_serializer,
    model_validator,
)

from synthcal.config.vocabulary import (
    GRID_AXES,
    ClassReduction,
    Dictionary,
    Images,
    Segmentation,
    SelectionScore,
    StnTemplate,
    UnetClassWeights,
)

__all__ = [
    "CONFIG_VERSION",
    "MAX_GRID_CAMERAS",
    "MAX_IMAGE_SIDE",
    "AxisRange",
    "GridConfig",
    "AppearanceConfig",
    "SplitSizes",
    "OsmSourceConfig",
    "UserSceneConfig",
    "DatasetConfig",
    "Defaults",
    "TrainingSettings",
    "TrainingProfile",
    "SelectGrid",
    "ProfileConfig",
    "Config",
]


# The layout of datasets.yaml this code reads (its ``version:`` key).
CONFIG_VERSION = 1
# A grid's camera count is a closed form; past this many cameras it is a typo (a step of 1e-12), not a grid.
MAX_GRID_CAMERAS = 10**12
# A side above this is a typo too: one 16,384² RGB frame is already 768 MiB before supersampling.
MAX_IMAGE_SIDE = 16384


class StrictModel(BaseModel):
    """Unknown keys refused, instances frozen, and every float finite: an ``.inf`` or ``.nan``
    would otherwise flow into homographies and be stored as a "complete" store of NaNs.

    Numbers are strict as well, field by field (``StrictInt``, ``StrictFloat``, ``StrictBool``):
    YAML's ``true`` is not the integer 1, nor ``"5"`` a number (a model-wide ``strict`` would
    also refuse the lists YAML gives for tuples).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _image_side_range(size: tuple[int, int]) -> tuple[int, int]:
    if min(size) < 8 or max(size) > MAX_IMAGE_SIDE:
        raise ValueError(f"image_size must be [width, height] with sides from 8 to {MAX_IMAGE_SIDE} pixels, "
                         f"got {list(size)}")
    return size


# ``(width, height)`` of the stored images.
ImageSize = Annotated[tuple[StrictInt, StrictInt], AfterValidator(_image_side_range)]


class AxisRange(StrictModel):
    """An inclusive range ``start..stop`` in steps of ``step`` (SPEC §3)."""

    start: StrictFloat
    stop: StrictFloat
    step: StrictFloat = 1.0

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
        steps = (self.stop - self.start) / self.step  # inf when stop - start overflows
        if not steps < MAX_GRID_CAMERAS:
            raise ValueError(f"step {self.step:g} from {self.start:g} to {self.stop:g} gives more than "
                             f"{MAX_GRID_CAMERAS:.0e} values; raise the step")
        return self

    def count(self, name: str = "") -> int:
        """How many values :meth:`values` gives, computed without materialising them.

        Args:
            name: the axis name, as for :meth:`values`.
        """
        count = math.floor((self.stop - self.start) / self.step + 1e-9) + 1
        # The float64 operations of the materialised axis: its last value minus its first.
        if name == "pan_deg" and count > 1 and np.isclose(self.value_at(count - 1) - self.start, 360.0):
            count -= 1
        return count

    def value_at(self, positions: np.ndarray | int) -> np.ndarray:
        """The values at positions ``0 ≤ k < count``, bit-identical to ``values()[k]``.

        Args:
            positions: (...,) integer positions.

        Returns:
            (...,) float64 values ``start + step · k``.
        """
        return self.start + self.step * np.asarray(positions, dtype=np.float64)

    def values(self, name: str = "") -> np.ndarray:
        """The values of the range.

        Args:
            name: the axis name; a ``pan_deg`` range spanning 360° drops its upper end
                (≡ its lower end).

        Returns:
            (K,) float64 values.
        """
        return self.value_at(np.arange(self.count(name)))


class GridConfig(StrictModel):
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
    jitter: StrictBool = False
    xy_relative: StrictBool = False

    @model_validator(mode="after")
    def _position_all_or_none(self) -> GridConfig:
        given = [axis for axis in ("x", "y", "z") if getattr(self, axis) is not None]
        if given and len(given) != 3:
            raise ValueError(f"x, y and z must be given together or not at all, got only {given}")
        if self.xy_relative and not given:
            raise ValueError("xy_relative: true needs x, y and z ranges (offsets from the scene's anchor)")
        return self

    @model_validator(mode="after")
    def _not_too_many_cameras(self) -> GridConfig:
        counts = self.counts()
        if math.prod(counts.values()) > MAX_GRID_CAMERAS:
            largest = max(counts, key=counts.__getitem__)
            raise ValueError(f"the grid holds {math.prod(counts.values()):.3g} cameras, more than "
                             f"{MAX_GRID_CAMERAS:.0e}; raise the step of {largest} ({counts[largest]} values)")
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

    def counts(self) -> dict[str, int]:
        """Each of :data:`GRID_AXES` → its number of values (a missing X/Y/Z axis has one)."""
        return {name: 1 if (axis := self.axis(name)) is None else axis.count(name) for name in GRID_AXES}

    def size(self) -> int:
        """Number of cameras in the grid (a missing X/Y/Z axis counts as one value)."""
        return math.prod(self.counts().values())


class AppearanceConfig(StrictModel):
    """Ranges of the per-sample photometric changes (see render.Appearance)."""

    brightness: StrictFloat = Field(20.0, ge=0)
    contrast: StrictFloat = Field(0.2, ge=0, lt=1)
    blur_sigma: StrictFloat = Field(0.8, ge=0)
    noise_sigma: StrictFloat = Field(3.0, ge=0)


class SplitSizes(StrictModel):
    """Sizes of the per-seed train / test / dictionary / validation splits (SPEC §6).

    ``validation`` is drawn from what the other three leave; training choices read
    it, never test. 0 (the default here, so that a configuration or store written
    before it existed keeps its meaning): none; the bundled ``datasets.yaml`` sets 500.
    """

    train: StrictInt = Field(3000, ge=1)
    test: StrictInt = Field(500, ge=1)
    dictionary: StrictInt = Field(1000, ge=1)
    validation: StrictInt = Field(0, ge=0)

    @property
    def total(self) -> int:
        return self.train + self.test + self.dictionary + self.validation


class OsmSourceConfig(StrictModel):
    """An OpenStreetMap scene's source (``osm:`` of a scene entry; SPEC §4).

    ``file`` (``.osm``, ``.osm.pbf``, ``.osm.bz2``) is relative to the YAML file;
    ``center`` is ``[lat, lon]`` in WGS84 degrees; ``size_m`` the window
    ``[width, height]`` in metres; ``classes`` moves tag selectors to classes
    (``{terrain: ["landuse=farmland"]}``, see docs/osm.md); ``seed`` seeds the RGB;
    ``rotation_deg`` turns the window about the centre before rasterising (a road at
    bearing ``b`` is drawn at screen bearing ``b + rotation_deg``, clockwise from up; 0:
    north up), e.g. to line a junction's legs up with a built-in intersection's.
    """

    file: Path
    center: tuple[StrictFloat, StrictFloat]
    size_m: tuple[StrictFloat, StrictFloat] = (130.0, 190.0)
    pixels_per_metre: StrictFloat = Field(10.0, gt=0)
    classes: dict[str, list[str]] | None = None
    seed: StrictInt = 0
    rotation_deg: StrictFloat = 0.0

    @field_validator("center")
    @classmethod
    def _lat_lon(cls, center: tuple[StrictFloat, StrictFloat]) -> Any:
        if not (-90 <= center[0] <= 90 and -180 <= center[1] <= 180):
            raise ValueError(f"center must be [lat, lon] in degrees (-90..90, -180..180), got {list(center)}")
        return center

    @field_validator("size_m")
    @classmethod
    def _size(cls, size: tuple[float, float]) -> Any:
        if not all(0 < s < float("inf") for s in size):
            raise ValueError(f"size_m must be [width, height] in metres, both > 0, got {list(size)}")
        return size

    @model_serializer(mode="wrap")
    def _dump(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        data: dict[str, Any] = handler(self)
        if self.rotation_deg == 0.0:
            data.pop("rotation_deg", None)  # north-up scenes keep their configuration hash
        return data


# Keys of a PNG scene that an osm: scene takes from its source instead.
_PNG_ONLY_KEYS = ("image", "semantic", "palette", "classes", "pixels_per_metre")


class UserSceneConfig(StrictModel):
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
    # Class ids are lax: a store's JSON copy of the configuration spells them as strings ("0").
    palette: dict[int, tuple[StrictInt, StrictInt, StrictInt]] | None = None
    classes: tuple[str, str, str, str] | None = None
    heading_deg: StrictFloat = 0.0
    camera_position: tuple[StrictFloat, StrictFloat, StrictFloat] | None = None
    pixels_per_metre: StrictFloat = Field(10.0, gt=0)

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
    def _palette_classes(cls, palette: dict[StrictInt, tuple[StrictInt, StrictInt, StrictInt]] | None) -> Any:
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


class DatasetConfig(StrictModel):
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
    pool_size: StrictInt | None = Field(None, ge=1)
    dictionary_from: tuple[str, ...] | None = None
    seed: StrictInt | None = Field(None, ge=0)
    image_size: ImageSize | None = None
    splits: SplitSizes | None = None
    min_field_fraction: StrictFloat | None = Field(None, ge=0, lt=1)
    dictionary: Dictionary | None = None
    images: Images | None = None
    same_pool_as: str | None = None

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
        if self.same_pool_as is not None and (self.seed is not None or self.dictionary_from):
            raise ValueError(f"same_pool_as {self.same_pool_as!r} draws that dataset's pool from its name: leave "
                             f"seed: and dictionary_from: out")
        if self.dictionary == "pool" and self.dictionary_from:
            raise ValueError("dictionary: pool searches the dataset's own pool, but its dictionary comes from "
                             f"dictionary_from {list(self.dictionary_from)}; leave dictionary out")
        return self


class Defaults(StrictModel):
    image_size: ImageSize = (256, 144)
    focal_reference_width: StrictInt = Field(256, ge=1)
    shard_size: StrictInt = Field(64, ge=1)
    seed: StrictInt = Field(0, ge=0)
    supersample: StrictInt = Field(2, ge=1, le=8)
    appearance: AppearanceConfig = AppearanceConfig()
    splits: SplitSizes = SplitSizes()
    split_seeds: tuple[StrictInt, ...] = (0, 1, 2, 3, 4)


class SelectGrid(StrictModel):
    """The values a run tries, each trained in full, the best on the validation split kept
    (:mod:`synthcal.estimators.paper`). Only the learning rate so far."""

    learning_rate: tuple[Annotated[StrictFloat, Field(gt=0)], ...] = Field(min_length=1)


class TrainingSettings(StrictModel):
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
    ``patience`` (None: every epoch, the last weights): the step-by-step STN is
    scored on the validation split after each epoch, the best epoch's weights are
    kept, and training stops after ``patience`` epochs without a better score;
    a UNet in the loop (``segmentation: unet``) is stopped the same way by its
    validation cross-entropy.
    ``unet_class_weights`` (None: the paper's plain cross-entropy): ``inverse-frequency``
    weighs each class of the UNet's cross-entropy (step-by-step and end-to-end) by the
    inverse of its pixel share in the train maps, normalised to mean 1 — a reading the
    paper leaves open (docs/decisions.md, "The UNet's loss").
    ``select`` (None: ``learning_rate`` alone): the learning rates tried, the one
    whose trained model scores best on the validation split kept. Both read the
    validation split, never test.
    ``unet_learning_rate`` (None: the run's ``learning_rate``, so that ``select`` trains
    a UNet at each rate it tries): a step-by-step UNet's own rate, fixed while
    ``select`` varies the rate of the stages after it — every rate tried then reads
    the same UNet, and two models read the same UNet whatever rate each keeps (end to
    end trains every stage jointly at one rate, so it refuses the setting).
    ``selection_score`` (None: ``warp-loss``) is what ranks the fits for both: the
    run's own ``L_warp`` of the validation estimates, or ``iou`` — 1 − their mean
    ``iou``, the tables' reading at the working resolution
    (:func:`synthcal.training.validation_iou`; docs/decisions.md, "Early stopping and
    learning-rate selection").
    """

    work_size: tuple[StrictInt, StrictInt] | None = None
    max_train: StrictInt | None = Field(None, ge=1)
    batch_size: StrictInt = Field(16, ge=1)
    learning_rate: StrictFloat = Field(1e-3, gt=0)
    unet_learning_rate: StrictFloat | None = Field(None, gt=0)
    unet_width: StrictInt = Field(16, ge=1)
    unet_depth: StrictInt = Field(4, ge=1)
    unet_epochs: StrictInt = Field(20, ge=1)
    siamese_width: StrictInt = Field(32, ge=1)
    embedding_dim: StrictInt = Field(128, ge=2)
    siamese_epochs: StrictInt = Field(20, ge=1)
    stn_width: StrictInt = Field(32, ge=1)
    stn_epochs: StrictInt = Field(40, ge=1)
    end_to_end_epochs: StrictInt = Field(100, ge=3)
    scene_downsample: StrictInt = Field(4, ge=1)
    stn_template: StnTemplate = "retrieved"
    class_reduction: ClassReduction = "sum"
    batch_norm: StrictBool | None = None
    patience: StrictInt | None = Field(None, ge=1)
    unet_class_weights: UnetClassWeights | None = None
    select: SelectGrid | None = None
    selection_score: SelectionScore | None = None

    @field_validator("work_size")
    @classmethod
    def _work_size(cls, size: tuple[int, int] | None) -> tuple[int, int] | None:
        if size is not None and min(size) < 16:
            raise ValueError(f"work_size must be at least 16 × 16 pixels, got {list(size)}")
        return size

    @model_validator(mode="after")
    def _selection_score_ranks_something(self) -> TrainingSettings:
        if self.selection_score is not None and self.patience is None and self.select is None:
            raise ValueError(f"selection_score {self.selection_score!r} ranks fits on the validation split, and "
                             "nothing is chosen there: set patience or select too (bench --patience / --select)")
        return self


class TrainingProfile(TrainingSettings):
    """A profile's ``training:`` block: the settings and the default segmentation.

    ``segmentation: ground-truth`` feeds true semantic maps to the matching and STN
    stages instead of a trained UNet's (SPEC §7, "Optional segmentation"); the
    command line's ``--segmentation`` overrides it.
    """

    segmentation: Segmentation = "unet"

    def settings(self) -> dict[str, Any]:
        """The :class:`TrainingSettings` fields as a plain dict (what estimators take).

        ``batch_norm``, ``patience``, ``unet_class_weights``, ``unet_learning_rate``, ``select`` and
        ``selection_score`` are left out while None, so that the runs recorded before they existed keep their
        ids (the settings are in the run's hash; set, they are part of it).
        """
        unset = {name for name in ("batch_norm", "patience", "unet_class_weights", "unet_learning_rate", "select",
                                   "selection_score") if getattr(self, name) is None}
        return self.model_dump(mode="json", exclude={"segmentation", *unset})


class ProfileConfig(StrictModel):
    """Overrides applied to every dataset: sizes for tests, laptops or the paper,
    the sizes of the bundled models (``training:``) and the dictionary ``bench``
    searches (``dictionary:``, for every dataset with an own pool) and which images
    stores keep (``images:``, overriding the datasets')."""

    image_size: ImageSize | None = None
    shard_size: StrictInt | None = Field(None, ge=1)
    max_pool_size: StrictInt | None = Field(None, ge=1)
    supersample: StrictInt | None = Field(None, ge=1, le=8)
    splits: SplitSizes | None = None
    training: TrainingProfile | None = None
    dictionary: Dictionary | None = None
    images: Images | None = None


# An estimator option's value: a YAML scalar, each kind strict (YAML's true is not 1).
EstimatorOption = StrictBool | StrictInt | StrictFloat | str | None


class Config(StrictModel):
    version: StrictInt = CONFIG_VERSION
    defaults: Defaults = Defaults()
    grids: dict[str, GridConfig]
    scenes: dict[str, UserSceneConfig] = {}
    datasets: dict[str, DatasetConfig]
    # target dataset → the datasets whose pools give its mixed dictionary (SPEC §6)
    mixed_dictionaries: dict[str, tuple[str, ...]] = {}
    profiles: dict[str, ProfileConfig] = {}
    # estimator name or dotted path → its constructor options (synthcal.estimators.options)
    estimators: dict[str, dict[str, EstimatorOption]] = {}

    @field_validator("version")
    @classmethod
    def _known_version(cls, version: int) -> int:
        if version != CONFIG_VERSION:  # a later layout may mean other things by the same keys
            raise ValueError(f"this synthcal reads configuration version {CONFIG_VERSION} only")
        return version
