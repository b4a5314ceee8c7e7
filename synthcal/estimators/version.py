"""What an estimator *is*, as a string that changes when its code does (SPEC §9).

A bench run's identity (:class:`synthcal.eval.runs.Run`) holds
:func:`estimator_version`, so that editing a plug-in's ``predict`` makes new runs
instead of reusing the old results:

* a bundled estimator (a class of ``synthcal``): ``synthcal:<hash>``, the hash of
  the bundled estimators' code, :func:`bundled_code_version`: every ``.py`` file of
  ``synthcal/estimators``, ``synthcal/models`` and ``synthcal/training`` (what the
  estimators, their networks and their training are), so no edit there can be
  forgotten (docs/decisions.md says why a hash and not a hand-bumped constant);
* a plug-in: ``source:<hash>`` of its source: the ``.py`` file defining it or, for
  a module inside a package, every ``.py`` file of its top-level package; a plug-in
  subclassing a bundled class adds ``+synthcal:<hash>``;
* a plug-in without readable source (compiled, zipped): ``dist:<name>==<version>``
  of the distribution that installed it, else ``unknown`` (its edits then go unseen).

Hashes are SHA-256 (first 16 hex digits) over the files' paths *relative* to the
package (or the file's name) and their bytes, ``\\r\\n`` read as ``\\n``: the same
code gives the same string on every machine and checkout, whatever its folder or
modification times.

>>> from synthcal.estimators import IdentityEstimator
>>> estimator_version(IdentityEstimator) == "synthcal:" + bundled_code_version()
True
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path
from typing import Any

__all__ = ["BUNDLED_PACKAGES", "bundled_code_version", "estimator_version", "source_digest"]

# The synthcal subpackages whose code the bundled estimators are.
BUNDLED_PACKAGES = ("estimators", "models", "training")
_SYNTHCAL_ROOT = Path(__file__).resolve().parents[1]


def source_digest(files: Iterable[tuple[str, Path]]) -> str:
    """16 hex digits of SHA-256 over ``(relative name, file)`` pairs, in name order (module docstring)."""
    digest = hashlib.sha256()
    for name, path in sorted(files):
        digest.update(name.encode() + b"\0" + path.read_bytes().replace(b"\r\n", b"\n") + b"\0")
    return digest.hexdigest()[:16]


def _package_files(folders: Iterable[Path], prefix: str = "") -> list[tuple[str, Path]]:
    return [(prefix + path.relative_to(folder).as_posix(), path)
            for folder in folders for path in folder.rglob("*.py")]


def bundled_code_version(root: Path = _SYNTHCAL_ROOT) -> str:
    """Hash of the bundled estimators' code: the ``.py`` files of :data:`BUNDLED_PACKAGES` under ``root``."""
    return source_digest(file for package in BUNDLED_PACKAGES
                         for file in _package_files([root / package], f"{package}/"))


def _source_files(module_name: str) -> list[tuple[str, Path]]:
    """A plug-in module's source: its file, or its top-level package's ``.py`` files; [] if unreadable."""
    top = sys.modules.get(module_name.partition(".")[0])
    folders = getattr(top, "__path__", None)
    if folders is not None:  # a package: every file of it, relative to its folder(s)
        return _package_files(Path(folder) for folder in folders)
    file = getattr(sys.modules.get(module_name), "__file__", None)
    return [(Path(file).name, Path(file))] if file and file.endswith(".py") and Path(file).is_file() else []


def _distribution_version(module_name: str) -> str:
    names = metadata.packages_distributions().get(module_name.partition(".")[0], [])
    return f"dist:{names[0]}=={metadata.version(names[0])}" if names else "unknown"


def estimator_version(cls: Any) -> str:
    """The code version of an estimator class (or factory): module docstring.

    Args:
        cls: what :func:`synthcal.estimators.resolve_estimator` returned (imported).

    Returns:
        ``synthcal:<hash>``, ``source:<hash>[+synthcal:<hash>]``, ``dist:<name>==<version>`` or ``unknown``.
    """
    module_name = str(getattr(cls, "__module__", "") or "")
    if module_name.partition(".")[0] == "synthcal":
        return f"synthcal:{bundled_code_version()}"
    files = _source_files(module_name) if module_name else []
    version = f"source:{source_digest(files)}" if files else _distribution_version(module_name)
    bases = getattr(cls, "__mro__", ())[1:]
    if any(str(getattr(base, "__module__", "")).partition(".")[0] == "synthcal" for base in bases):
        version += f"+synthcal:{bundled_code_version()}"
    return version
