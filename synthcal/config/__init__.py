"""``datasets.yaml``: the one place where configuration is read and validated (see :mod:`.schema`)."""

from synthcal.config.schema import *  # noqa: F403
from synthcal.config.schema import __all__  # noqa: F401
