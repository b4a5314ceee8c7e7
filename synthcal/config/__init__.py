"""``datasets.yaml``: the one place where configuration is read and validated.

Every error is a :class:`ConfigError` whose message names the file, the key path
and the offending value, and is raised before anything is written.

A dataset's *resolved* configuration (:class:`DatasetSpec`) is the dataset entry
with the file's ``defaults`` filled in and a *profile* (``smoke``, ``quick``,
``paper``) applied; its hash is recorded in every store it produces.

The package imports nothing of synthcal (it is the root of the import graph). Its
modules, each re-exported here:

* :mod:`.vocabulary`: the option vocabularies of the bundled models and the
  benchmark (:data:`LOSSES`, :data:`MATCHINGS`, ..., the metric names
  :data:`METRICS`), the generator's facts that validation needs, :class:`ConfigError`;
* :mod:`.schema`: the pydantic models of the file's blocks;
* :mod:`.spec`: :class:`DatasetSpec`, a resolved dataset, and its hash;
* :mod:`.load`: :func:`load_config` and :class:`LoadedConfig`.
"""

from synthcal.config.load import LoadedConfig, default_config_path, load_config
from synthcal.config.schema import (
    AppearanceConfig,
    AxisRange,
    Config,
    DatasetConfig,
    Defaults,
    GridConfig,
    OsmSourceConfig,
    ProfileConfig,
    SplitSizes,
    TrainingProfile,
    TrainingSettings,
    UserSceneConfig,
)
from synthcal.config.spec import DatasetSpec
from synthcal.config.vocabulary import (
    BUILTIN_SCENE_NAMES,
    CLASS_REDUCTIONS,
    DEFAULT_READING,
    DESCRIPTIONS,
    DICTIONARIES,
    GRID_AXES,
    LOSSES,
    MATCHINGS,
    METRICS,
    MODEL_LABELS,
    MODELS,
    POSE_SET_SPLITS,
    READINGS,
    SEGMENTATIONS,
    STN_TEMPLATES,
    TRAININGS,
    ClassReduction,
    ConfigError,
    Dictionary,
    Images,
    Loss,
    Matching,
    Model,
    Segmentation,
    StnTemplate,
    Training,
    check_dataset_name,
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
    "Images",
    "MODELS",
    "MODEL_LABELS",
    "TRAININGS",
    "LOSSES",
    "MATCHINGS",
    "SEGMENTATIONS",
    "STN_TEMPLATES",
    "CLASS_REDUCTIONS",
    "DICTIONARIES",
    "READINGS",
    "METRICS",
    "DESCRIPTIONS",
    "DEFAULT_READING",
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
    "Defaults",
    "TrainingSettings",
    "TrainingProfile",
    "ProfileConfig",
    "Config",
    "DatasetSpec",
    "LoadedConfig",
    "default_config_path",
    "load_config",
]
