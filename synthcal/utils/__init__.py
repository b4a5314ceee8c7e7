"""Small infrastructure shared by the packages: atomic file writes and task dispatch.

* :mod:`synthcal.utils.atomic` — write a file under a temporary name, then rename it;
* :mod:`synthcal.utils.dispatch` — run tasks here, on local processes or on a Dask
  cluster, results as they complete;
* :mod:`synthcal.utils.progress` — progress bars only on a terminal.

A leaf: imports nothing of synthcal.
"""

from synthcal.utils.atomic import atomic_write
from synthcal.utils.dispatch import dispatch

__all__ = ["atomic_write", "dispatch"]
