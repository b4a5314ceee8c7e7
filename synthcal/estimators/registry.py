"""Turning a command-line or config value into an estimator.

``load_estimator(name_or_path, **options)`` turns a command-line/config value
into an instance: a dotted path ``package.module:Class`` or a name in the
entry-point group ``synthcal.estimators``.

The bundled estimators are synthcal's own entry points in that group (the
``[project.entry-points."synthcal.estimators"]`` table of ``pyproject.toml``, the
one list of their names): ``identity``, ``template``, ``ecc``, ``proposed``,
``baseline`` and its alias ``sha2020``, ``sha2020-ccbv``, and the diagnostics
``retrieved`` and ``oracle-template``. Plug-ins add theirs the same way; a
plug-in cannot shadow a bundled name.
"""

from __future__ import annotations

import importlib
from importlib import metadata
from typing import Any

from synthcal.estimators.protocol import Estimator, EstimatorError

__all__ = ["ENTRY_POINT_GROUP", "bundled_estimators", "known_estimators", "estimator_entry_points", "resolve_estimator", "load_estimator"]

ENTRY_POINT_GROUP = "synthcal.estimators"
# The distribution whose entry points are the bundled estimators.
_DISTRIBUTION = "synthcal"


def estimator_entry_points() -> list[metadata.EntryPoint]:
    """Every installed entry point of the group :data:`ENTRY_POINT_GROUP`, bundled and plug-in alike."""
    # Looked up through the module at call time so tests can monkeypatch it.
    return list(metadata.entry_points(group=ENTRY_POINT_GROUP))


def _is_bundled(entry_point: metadata.EntryPoint) -> bool:
    dist = entry_point.dist
    return dist is not None and dist.name.lower() == _DISTRIBUTION


def _by_name() -> dict[str, metadata.EntryPoint]:
    """Entry points by name, synthcal's own first: a third-party name cannot shadow a bundled one."""
    entry_points = sorted(estimator_entry_points(), key=lambda ep: not _is_bundled(ep))  # stable: bundled first
    found: dict[str, metadata.EntryPoint] = {}
    for ep in entry_points:
        found.setdefault(ep.name, ep)
    return found


def bundled_estimators() -> dict[str, str]:
    """Bundled short names → ``module:Class`` (synthcal's own entry points)."""
    return {ep.name: ep.value for ep in estimator_entry_points() if _is_bundled(ep)}


def known_estimators() -> dict[str, str]:
    """Resolvable short names → ``module:Class``: bundled ones, then the plug-ins' entry points."""
    return {name: ep.value for name, ep in _by_name().items()}


def _import_dotted(path: str) -> Any:
    module_name, _, attribute = path.partition(":")
    if not module_name or not attribute:
        raise EstimatorError(f"estimator {path!r}: expected 'package.module:Class'")
    try:
        obj = importlib.import_module(module_name)
    except ImportError as error:
        raise EstimatorError(f"estimator {path!r}: cannot import module {module_name!r} ({error})") from error
    for part in attribute.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise EstimatorError(
                f"estimator {path!r}: module {module_name!r} has no attribute {attribute!r}") from None
    return obj


def resolve_estimator(name_or_path: str) -> Any:
    """The class (or factory) a command-line or config value names, not instantiated.

    Resolution order: a value containing ``:`` is a dotted path
    ``package.module:Class``; otherwise a bundled short name (synthcal's own entry
    point of that name: ``identity``, ``template``, ``ecc``, ``proposed``,
    ``baseline``, ``sha2020``, ``sha2020-ccbv``, ``retrieved``, ``oracle-template`` — bundled names cannot be shadowed by third-party
    packages); otherwise another distribution's entry point of that name in group
    ``synthcal.estimators``.

    Raises:
        EstimatorError: the value cannot be resolved (the message names it and
            lists the known names), or it is not callable.
    """
    value = str(name_or_path)
    if ":" in value:
        cls = _import_dotted(value)
    else:
        entry_points = _by_name()
        if value not in entry_points:
            known = ", ".join(sorted(entry_points))
            # Without its metadata (not installed) synthcal has no entry points: say so.
            hint = "" if any(map(_is_bundled, entry_points.values())) else (
                " (no bundled names: synthcal's entry points are missing; install it, e.g. `pip install -e .`)")
            raise EstimatorError(
                f"unknown estimator {value!r}: not a 'package.module:Class' path, a bundled name "
                f"or an entry point in group {ENTRY_POINT_GROUP!r}; known: {known}{hint}"
            )
        entry_point = entry_points[value]
        try:
            cls = entry_point.load()
        except Exception as error:  # a broken plug-in must name itself
            raise EstimatorError(f"estimator {value!r}: entry point {entry_point.value!r} "
                                 f"failed to load ({error})") from error
    if not callable(cls):
        raise EstimatorError(f"estimator {value!r}: {cls!r} is not a class or factory")
    return cls


def load_estimator(name_or_path: str, **options: Any) -> Estimator:
    """Instantiate an estimator from a command-line or config value.

    Args:
        name_or_path: the value to resolve (see :func:`resolve_estimator`).
        **options: keyword arguments for the class's constructor.

    Returns:
        The estimator instance.

    Raises:
        EstimatorError: the value cannot be resolved, the options do not fit the
            constructor, or the object has no ``fit``/``predict``.
    """
    value = str(name_or_path)
    cls = resolve_estimator(value)
    try:
        estimator = cls(**options)
    except TypeError as error:  # e.g. an option the class does not take
        raise EstimatorError(f"estimator {value!r}: cannot construct with options {options}: {error}") from error
    if not isinstance(estimator, Estimator):
        raise EstimatorError(f"estimator {value!r}: {estimator!r} has no fit(train, dictionary, scene) "
                             "and predict(images) methods")
    return estimator
