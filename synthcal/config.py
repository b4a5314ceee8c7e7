"""``datasets.yaml``: the one place where configuration is read and validated.

Every error is a :class:`ConfigError` whose message names the file, the key path
and the offending value, and is raised before anything is written.

A dataset's *resolved* configuration (:class:`DatasetSpec`) is the dataset entry
with the file's ``defaults`` filled in and a *profile* (``smoke``, ``quick``,
``paper``) applied; its hash is recorded in every store it produces.
"""

from __future__ import annotations

import hashlib
import json
from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

__all__ = [
    "ConfigError",
    "AxisRange",
    "GridConfig",
    "AppearanceConfig",
    "SplitSizes",
    "UserSceneConfig",
    "DatasetConfig",
    "ProfileConfig",
    "Config",
    "DatasetSpec",
    "default_config_path",
    "load_config",
]

GRID_AXES = ("pan_deg", "tilt_deg", "focal_px", "x", "y", "z")


class ConfigError(ValueError):
    """Invalid configuration; the message names the file, key and value."""


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
    def _non_empty(self) -> "AxisRange":
        if self.stop < self.start:
            raise ValueError(f"empty range: stop {self.stop} < start {self.start}")
        return self


class GridConfig(_Strict):
    """Camera grid; X/Y/Z left out means the scene's own camera position."""

    pan_deg: AxisRange
    tilt_deg: AxisRange
    focal_px: AxisRange
    x: AxisRange | None = None
    y: AxisRange | None = None
    z: AxisRange | None = None
    jitter: bool = False

    @model_validator(mode="after")
    def _position_all_or_none(self) -> "GridConfig":
        given = [axis for axis in ("x", "y", "z") if getattr(self, axis) is not None]
        if given and len(given) != 3:
            raise ValueError(f"x, y and z must be given together or not at all, got only {given}")
        return self


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


class UserSceneConfig(_Strict):
    """A scene from two PNG files; paths are relative to the YAML file."""

    image: Path
    semantic: Path
    palette: dict[int, tuple[int, int, int]] | None = None
    classes: tuple[str, str, str, str] | None = None
    heading_deg: float = 0.0
    camera_position: tuple[float, float, float] | None = None
    pixels_per_metre: float = Field(10.0, gt=0)

    @field_validator("palette")
    @classmethod
    def _palette_classes(cls, palette: dict[int, tuple[int, int, int]] | None) -> Any:
        for class_id, colour in (palette or {}).items():
            if not 0 <= class_id <= 3:
                raise ValueError(f"palette class id must be 0..3, got {class_id}")
            if any(not 0 <= c <= 255 for c in colour):
                raise ValueError(f"palette colour must be 0..255, got {colour}")
        return palette


class DatasetConfig(_Strict):
    """One dataset: a scene, a grid and a pool size (other keys override defaults)."""

    scene: str
    grid: str
    pool_size: int = Field(ge=1)
    seed: int | None = None
    image_size: tuple[int, int] | None = None
    splits: SplitSizes | None = None


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


class ProfileConfig(_Strict):
    """Overrides applied to every dataset: sizes for tests, laptops or the paper."""

    image_size: tuple[int, int] | None = None
    shard_size: int | None = Field(None, ge=1)
    max_pool_size: int | None = Field(None, ge=1)
    supersample: int | None = Field(None, ge=1, le=8)
    splits: SplitSizes | None = None


class Config(_Strict):
    version: int = 1
    defaults: Defaults = Defaults()
    grids: dict[str, GridConfig]
    scenes: dict[str, UserSceneConfig] = {}
    datasets: dict[str, DatasetConfig]
    profiles: dict[str, ProfileConfig] = {}


class DatasetSpec(_Strict):
    """Everything that determines a generated store's arrays."""

    name: str
    scene: str
    user_scene: UserSceneConfig | None
    grid: GridConfig
    pool_size: int
    seed: int
    image_size: tuple[int, int]
    focal_reference_width: int
    shard_size: int
    supersample: int
    appearance: AppearanceConfig
    splits: SplitSizes
    split_seeds: tuple[int, ...]

    def config_hash(self) -> str:
        """SHA-256 of the canonical JSON of what determines the pool's arrays.

        Split sizes and seeds are left out: splits are drawn later, inside the
        store, and changing them must not invalidate a generated pool.
        """
        pool = self.model_dump(mode="json", exclude={"splits", "split_seeds"})
        text = json.dumps(pool, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


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
            pool_size: overrides the pool size (the CLI's ``--n``).

        Raises:
            ConfigError: unknown dataset or profile, or a pool larger than its grid.
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
        pool = entry.pool_size if prof.max_pool_size is None else min(entry.pool_size, prof.max_pool_size)
        if pool_size is not None:
            if pool_size < 1:
                raise ConfigError(f"--n: the pool size must be ≥ 1 (value {pool_size})")
            pool = pool_size
        spec = DatasetSpec(
            name=dataset,
            scene=entry.scene,
            user_scene=cfg.scenes.get(entry.scene),
            grid=cfg.grids[entry.grid],
            pool_size=pool,
            seed=d.seed if entry.seed is None else entry.seed,
            image_size=prof.image_size or entry.image_size or d.image_size,
            focal_reference_width=d.focal_reference_width,
            shard_size=prof.shard_size or d.shard_size,
            supersample=prof.supersample or d.supersample,
            appearance=d.appearance,
            splits=prof.splits or entry.splits or d.splits,
            split_seeds=d.split_seeds,
        )
        from synthcal.generate.grid import grid_size  # late import: grid imports config

        size = grid_size(spec.grid)
        if spec.pool_size > size:
            raise ConfigError(
                f"{self.path}: datasets.{dataset}.pool_size: {spec.pool_size} samples asked for, "
                f"but grid {entry.grid!r} holds only {size} cameras (value {spec.pool_size})"
            )
        return spec


def _check_references(path: Path, config: Config) -> None:
    from synthcal.generate.scenes import BUILTIN_SCENES

    for name, entry in config.datasets.items():
        if entry.grid not in config.grids:
            raise ConfigError(
                f"{path}: datasets.{name}.grid: unknown grid {entry.grid!r}; known: {', '.join(config.grids)}"
            )
        if entry.scene not in config.scenes and entry.scene not in BUILTIN_SCENES:
            known = ", ".join([*BUILTIN_SCENES, *config.scenes])
            raise ConfigError(f"{path}: datasets.{name}.scene: unknown scene {entry.scene!r}; known: {known}")


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
    resolved_scenes = {
        name: scene.model_copy(
            update={"image": (path.parent / scene.image), "semantic": (path.parent / scene.semantic)}
        )
        for name, scene in config.scenes.items()
    }
    config = config.model_copy(update={"scenes": resolved_scenes})
    _check_references(path, config)
    return LoadedConfig(path, config)
