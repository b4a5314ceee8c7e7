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
* :mod:`.yaml_input`: :func:`read_yaml`, YAML read within limits (size, depth, aliases);
* :mod:`.layers`: a user's file layered over the packaged one (merge rules, origins);
* :mod:`.load`: :func:`load_config` and :class:`LoadedConfig`;
* :mod:`.names` (not re-exported; :mod:`.load` uses it): did-you-mean suggestions for a
  mistyped name.
"""

# Each module lists its public names once (its __all__); the package offers them all.
from synthcal.config import layers, load, schema, spec, vocabulary, yaml_input
from synthcal.config.layers import *  # noqa: F403
from synthcal.config.load import *  # noqa: F403
from synthcal.config.schema import *  # noqa: F403
from synthcal.config.spec import *  # noqa: F403
from synthcal.config.vocabulary import *  # noqa: F403
from synthcal.config.yaml_input import *  # noqa: F403

__all__ = [*vocabulary.__all__, *schema.__all__, *spec.__all__, *yaml_input.__all__, *layers.__all__,
           *load.__all__]
