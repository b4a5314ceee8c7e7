"""Turning a command-line or config value into an estimator.

``load_estimator(name_or_path, **options)`` turns a command-line/config value
into an instance: a dotted path ``package.module:Class``, a name in the
entry-point group ``synthcal.estimators``, or a bundled short name.
"""

from __future__ import annotations

import importlib
from importlib import metadata
from typing import Any

from synthcal.estimators.protocol import Estimator, EstimatorError

__all__ = ["ENTRY_POINT_GROUP", "BUNDLED", "known_estimators", "resolve_estimator", "load_estimator"]

ENTRY_POINT_GROUP = "synthcal.estimators"

BUNDLED: dict[str, str] = {
    "identity": "synthcal.estimators.classic:IdentityEstimator",
    "template": "synthcal.estimators.classic:TemplateEstimator",
    "ecc": "synthcal.estimators.classic:ECCEstimator",
    "proposed": "synthcal.estimators.paper:ProposedEstimator",
    "baseline": "synthcal.estimators.paper:BaselineEstimator",
    "sha2020": "synthcal.estimators.paper:BaselineEstimator",
}


def _entry_points() -> dict[str, metadata.EntryPoint]:
    # Looked up through the module at call time so tests can monkeypatch it.
    return {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}


def known_estimators() -> dict[str, str]:
    """Resolvable short names → ``module:Class``: bundled ones, then entry points."""
    names = dict(BUNDLED)
    for name, ep in _entry_points().items():
        names.setdefault(name, ep.value)
    return names


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
    ``package.module:Class``; otherwise a bundled short name (``identity``,
    ``template``, ``ecc``, ``proposed``, ``baseline`` — bundled names cannot be
    shadowed by third-party packages); otherwise an entry point of that name in
    group ``synthcal.estimators``.

    Raises:
        EstimatorError: the value cannot be resolved (the message names it and
            lists the known names), or it is not callable.
    """
    value = str(name_or_path)
    if ":" in value:
        cls = _import_dotted(value)
    elif value in BUNDLED:
        cls = _import_dotted(BUNDLED[value])
    else:
        entry_points = _entry_points()
        if value not in entry_points:
            known = ", ".join(sorted(known_estimators()))
            raise EstimatorError(
                f"unknown estimator {value!r}: not a 'package.module:Class' path, a bundled name "
                f"or an entry point in group {ENTRY_POINT_GROUP!r}; known: {known}"
            )
        try:
            cls = entry_points[value].load()
        except Exception as error:  # a broken plug-in must name itself
            raise EstimatorError(f"estimator {value!r}: entry point {entry_points[value].value!r} "
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
