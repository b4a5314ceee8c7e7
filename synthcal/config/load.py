"""Reading ``datasets.yaml``: :func:`load_config` and the :class:`LoadedConfig` it returns.

A user's file is layered over the packaged one (:mod:`.layers`). Every error is a
:class:`~synthcal.config.vocabulary.ConfigError` whose message names the file that
set the key, the key path and the offending value, and is raised before anything is
written.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from synthcal.config.layers import Origins, merge_layers, origin_of
from synthcal.config.names import did_you_mean
from synthcal.config.schema import Config, DatasetConfig, ProfileConfig, SplitSizes, TrainingProfile, UserSceneConfig
from synthcal.config.spec import DatasetSpec
from synthcal.config.vocabulary import (
    BUILTIN_SCENE_NAMES,
    POSE_SET_SPLITS,
    POSE_VALIDATION_FRACTION,
    ConfigError,
    Dictionary,
    brief,
    check_dataset_name,
)
from synthcal.config.yaml_input import read_yaml

__all__ = ["LoadedConfig", "default_config_path", "load_config", "packaged_config_path"]

# Where a key came from: the file that set it (a ConfigError names it).
Where = Callable[[Sequence[object]], Path]


def packaged_config_path() -> Path:
    """The ``datasets.yaml`` shipped with the package: the base every user file is layered over."""
    return Path(str(resources.files("synthcal") / "datasets.yaml"))


def default_config_path() -> Path:
    """``./datasets.yaml`` when present, else the packaged one (:func:`packaged_config_path`)."""
    local = Path("datasets.yaml")
    if local.is_file():
        return local
    return packaged_config_path()


def _format_errors(where: Where, error: ValidationError) -> str:
    """The first problem pydantic found, as one line (file, key path, what, value), and how many more."""
    errors = error.errors()
    item = errors[0]
    path = where(item["loc"])
    key = ".".join(brief(str(part), 40) for part in item["loc"])
    value = brief(repr(item.get("input")), 60)
    if item["type"] == "missing":
        problem = "missing required key"
    elif item["type"] == "extra_forbidden":
        problem = f"unknown key (value {value})"
    else:
        problem = f"{brief(item['msg'].removeprefix('Value error, '), 150)} (value {value})"
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return f"{path}: {key}: {problem}{more}"


class LoadedConfig:
    """A validated configuration file and the datasets it can resolve."""

    def __init__(self, path: Path, config: Config, layers: Sequence[Path] = (), raw: dict[Any, Any] | None = None,
                 origins: Origins | None = None) -> None:
        """``path``: the user's file (the packaged one when there is none); ``layers``: the files read,
        the packaged one first; ``raw``: their merged YAML; ``origins``: key path → the file that set it."""
        self.path = path
        self.config = config
        self.layers = tuple(layers) or (path,)
        self.raw = raw if raw is not None else {}
        self.origins = origins if origins is not None else {}

    def origin(self, *keys: object) -> Path:
        """The file that set a key path (``origin("datasets", "soccer", "pool_size")``), else
        that of its nearest enclosing mapping, else the user's file."""
        return origin_of(self.origins, keys, self.path)

    @property
    def dataset_names(self) -> list[str]:
        return list(self.config.datasets)

    def profile(self, profile: str | None) -> ProfileConfig:
        """A profile's overrides (None: no profile, an empty :class:`ProfileConfig`).

        Raises:
            ConfigError: unknown profile, naming the file and the known ones.
        """
        if profile is None:
            return ProfileConfig()
        if profile not in self.config.profiles:
            raise ConfigError(f"{self.path}: profiles.{profile}: unknown profile {profile!r}"
                              f"{did_you_mean(profile, self.config.profiles)}; known: {', '.join(self.config.profiles)}")
        return self.config.profiles[profile]

    def split_caps(self, profile: str | None) -> dict[str, int] | None:
        """A profile's ``splits:`` as caps on a store's drawn splits (None: no profile, or it sets none).

        Raises:
            ConfigError: unknown profile (:meth:`profile`).
        """
        splits = self.profile(profile).splits
        return None if splits is None else splits.model_dump()

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
                f"{self.path}: datasets.{dataset}: unknown dataset {dataset!r}{did_you_mean(dataset, cfg.datasets)}; "
                f"known: {', '.join(cfg.datasets)}"
            )
        prof = self.profile(profile)
        entry = cfg.datasets[dataset]
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
            pool_name=entry.same_pool_as,
        )
        if entry.same_pool_as is not None:
            self._check_same_pool(dataset, spec, self.resolve(entry.same_pool_as, profile, pool_size))
        if spec.grid is None:
            return spec
        size = spec.grid.size()
        if spec.pool_size > size:
            raise ConfigError(
                f"{self.origin('datasets', dataset, 'pool_size')}: datasets.{dataset}.pool_size: "
                f"{spec.pool_size} samples asked for, "
                f"but grid {entry.grid!r} holds only {size} cameras (value {spec.pool_size})"
            )
        return spec

    def training(self, profile: str | None = None) -> TrainingProfile:
        """The ``training:`` block of a profile (the built-in defaults without one).

        Raises:
            ConfigError: unknown profile.
        """
        return self.profile(profile).training or TrainingProfile()

    def dictionary(self, dataset: str, profile: str | None = None) -> Dictionary:
        """The dictionary ``bench`` searches for a dataset: the profile's ``dictionary:``, else the
        dataset's, else ``split``. A dataset whose dictionary comes from others (``dictionary_from``)
        or that is not in the file (a ``mixed-K`` label) always gets ``split`` here: its own
        (mixed) dictionary.

        Raises:
            ConfigError: unknown profile.
        """
        prof = self.profile(profile)
        entry = self.config.datasets.get(dataset)
        if entry is None or entry.dictionary_from:
            return "split"
        return prof.dictionary or entry.dictionary or "split"

    def _check_same_pool(self, dataset: str, spec: DatasetSpec, other: DatasetSpec) -> None:
        """A ``same_pool_as`` dataset resolves to its pool's dataset in everything but the name and mixed sources.

        Raises:
            ConfigError: a pool or split setting differs, naming it and both values.
        """
        ignored = {"name", "pool_name", "mixed_sources"}
        mine, theirs = spec.model_dump(mode="json", exclude=ignored), other.model_dump(mode="json", exclude=ignored)
        for key in mine:
            if mine[key] != theirs[key]:
                raise ConfigError(
                    f"{self.origin('datasets', dataset)}: datasets.{dataset}.same_pool_as: {key} differs from "
                    f"{other.name!r}'s ({brief(repr(theirs[key]), 60)}) (value {brief(repr(mine[key]), 60)})")

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
        poses' own partition (:data:`POSE_SET_SPLITS`); the dictionary size comes
        from the profile, the entry (``entry_splits``) or the defaults. Validation
        is carved from the given train part (``train`` stays its full size: the
        split drawer keeps the rest for training): the entry's
        ``splits.validation`` if it sets one, else :data:`POSE_VALIDATION_FRACTION`
        of it — not the profile's or the defaults', sized for synthetic pools.
        """
        key = f"{self.origin('datasets', dataset)}: datasets.{dataset}"
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
        validation = round(POSE_VALIDATION_FRACTION * fixed["train"])
        if entry_splits is not None and "validation" in entry_splits.model_fields_set:
            validation = entry_splits.validation
        if validation >= fixed["train"]:
            raise ConfigError(f"{key}.splits.validation: carved from the poses' {fixed['train']} train samples, "
                              f"it must leave at least one for training (value {validation})")
        return sum(fixed.values()), splits.model_copy(update={**fixed, "validation": validation})


def _check_references(where: Where, config: Config) -> None:
    """Every name a dataset or ``mixed_dictionaries`` refers to exists (in file order)."""
    for name, entry in config.datasets.items():
        _check_dataset_references(where, config, name, entry)
    _check_mixed_dictionaries(where, config)


def _check_dataset_references(where: Where, config: Config, name: str, entry: DatasetConfig) -> None:
    """One dataset's name is plain and its ``dictionary_from``, ``scene`` and ``grid`` name things that exist."""
    check_dataset_name(name, f"{where(['datasets', name])}: ")
    for source in entry.dictionary_from or ():
        if source not in config.datasets or source == name:
            raise ConfigError(
                f"{where(['datasets', name, 'dictionary_from'])}: datasets.{name}.dictionary_from: {source!r} must "
                f"be another dataset; known: {', '.join(config.datasets)}"
            )
    if entry.dictionary_from and name in config.mixed_dictionaries:
        raise ConfigError(
            f"{where(['mixed_dictionaries', name])}: mixed_dictionaries.{name}: the dataset already takes its "
            f"dictionary from datasets.{name}.dictionary_from (value {list(config.mixed_dictionaries[name])})"
        )
    if entry.same_pool_as is not None:
        target = config.datasets.get(entry.same_pool_as)
        if target is None or entry.same_pool_as == name or target.same_pool_as is not None:
            raise ConfigError(
                f"{where(['datasets', name, 'same_pool_as'])}: datasets.{name}.same_pool_as: must be another dataset "
                f"that draws its own pool (value {entry.same_pool_as!r}); known: {', '.join(config.datasets)}")
    if entry.poses == "worldcup2014" and entry.scene != "soccer":
        raise ConfigError(
            f"{where(['datasets', name, 'scene'])}: datasets.{name}.scene: the poses 'worldcup2014' are World Cup "
            f"broadcast cameras over the 'soccer' scene (value {entry.scene!r})"
        )
    if entry.grid is not None and entry.grid not in config.grids:
        raise ConfigError(f"{where(['datasets', name, 'grid'])}: datasets.{name}.grid: unknown grid "
                          f"{entry.grid!r}; known: {', '.join(config.grids)}")
    if entry.scene not in config.scenes and entry.scene not in BUILTIN_SCENE_NAMES:
        known = ", ".join([*BUILTIN_SCENE_NAMES, *config.scenes])
        raise ConfigError(f"{where(['datasets', name, 'scene'])}: datasets.{name}.scene: unknown scene "
                          f"{entry.scene!r}; known: {known}")


def _check_mixed_dictionaries(where: Where, config: Config) -> None:
    """Each ``mixed_dictionaries`` target and its sources are distinct, other datasets."""
    for target, sources in config.mixed_dictionaries.items():
        key = f"{where(['mixed_dictionaries', target])}: mixed_dictionaries.{target}"
        if target not in config.datasets:
            raise ConfigError(f"{key}: unknown dataset {target!r}; known: {', '.join(config.datasets)}")
        if not sources or len(set(sources)) != len(sources):
            raise ConfigError(f"{key}: list distinct source datasets (value {list(sources)})")
        for source in sources:
            if source not in config.datasets or source == target:
                raise ConfigError(f"{key}: {source!r} must be another dataset (value {list(sources)}); "
                                  f"known: {', '.join(config.datasets)}")


def _resolve_scene_paths(where: Where, name: str, scene: UserSceneConfig) -> UserSceneConfig:
    """A scene entry with each file made relative to the folder of the YAML file that named it."""
    def beside(keys: list[str], file: Path) -> Path:
        return where(["scenes", name, *keys]).parent / file

    if scene.osm is not None:
        return scene.model_copy(update={"osm": scene.osm.model_copy(update={"file": beside(["osm", "file"],
                                                                                         scene.osm.file)})})
    assert scene.image is not None and scene.semantic is not None  # _one_source
    return scene.model_copy(update={"image": beside(["image"], scene.image),
                                    "semantic": beside(["semantic"], scene.semantic)})


def load_config(path: str | Path | None = None) -> LoadedConfig:
    """Read and validate a ``datasets.yaml``, layered over the packaged one.

    The packaged grids, defaults, datasets and profiles apply unless the file sets
    them; a key set in both is the file's; mappings merge, lists replace, ``null``
    removes a packaged key (:mod:`synthcal.config.layers`). A file that is the
    packaged one is read alone.

    Args:
        path: the user's file (default: ``./datasets.yaml`` when present, else the
            packaged configuration alone).

    Raises:
        ConfigError: unreadable file, YAML syntax or over the limits of
            :func:`~synthcal.config.yaml_input.read_yaml`, unknown key, bad value or
            dangling reference; one line of at most :data:`MAX_MESSAGE` characters
            naming the file that set the key, the key path and the value.
    """
    packaged = packaged_config_path()
    user = Path(path) if path is not None else default_config_path()
    files = [packaged] if _same_file(user, packaged) else [packaged, user]
    try:
        return _load(files)
    except ConfigError as exc:  # the guarantee, whatever a message quotes (long names, long lists)
        raise ConfigError(brief(str(exc))) from None


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # a missing file is not the packaged one; reading it says what is wrong
        return False


def _load(files: list[Path]) -> LoadedConfig:
    """:func:`load_config`'s work; its messages may still be long."""
    layers = []
    for path in files:
        raw = read_yaml(path)
        if not isinstance(raw, dict):
            raise ConfigError(f"{path}: the top level must be a mapping, got {type(raw).__name__}")
        layers.append((path, raw))
    merged, origins = merge_layers(layers)
    user = files[-1]

    def where(keys: Sequence[object]) -> Path:
        return origin_of(origins, keys, user)

    try:
        config = Config.model_validate(merged)
    except ValidationError as exc:
        raise ConfigError(_format_errors(where, exc)) from None
    resolved_scenes = {name: _resolve_scene_paths(where, name, scene) for name, scene in config.scenes.items()}
    config = config.model_copy(update={"scenes": resolved_scenes})
    _check_references(where, config)
    return LoadedConfig(user, config, files, merged, origins)
