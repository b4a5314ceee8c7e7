"""Options for an estimator's constructor, from the configuration and the command line.

Three sources, later ones winning key by key (:func:`merge_options`):

1. ``estimators:`` of ``datasets.yaml`` — ``{name: {key: value}}``, e.g.
   ``estimators: {sift: {ratio: 0.7}}``, applying to every bench of ``name``;
2. ``--estimator 'NAME?key=value&key=value'`` — options of that one entry
   (:func:`parse_estimator_spec`; two entries of one name with other options
   are two estimators);
3. ``--option NAME.KEY=VALUE`` — every ``--estimator`` entry named ``NAME``
   (:func:`parse_option_flag`).

A command-line ``VALUE`` is read as a YAML scalar (:func:`parse_value`): ``0.7`` a
float, ``3`` an int, ``true`` a bool, ``null`` None, anything else a string.

:func:`check_options` validates options against the constructor before any run:
each key must be a parameter of it (a ``**options`` constructor takes any), a
value must fit the parameter's annotation where that is simple (``int``,
``float``, ``bool``, ``str``, ``Literal[…]``, unions of these and None), a key
the harness sets itself (:data:`HARNESS_KEYWORDS`) is refused, and a required
parameter the options leave out is an error then, not in every run. Options are
part of a run's identity and its table label: ``sift(ratio=0.7)``
(:func:`options_label`).
"""

from __future__ import annotations

import inspect
import re
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, Union

import yaml

from synthcal.estimators.protocol import EstimatorError

__all__ = ["HARNESS_KEYWORDS", "EstimatorSpec", "parse_value", "parse_estimator_spec", "parse_option_flag",
           "merge_options", "check_options", "options_label"]

# Constructor keywords the bench harness passes itself (synthcal.eval.runs, "Axes"): never options.
HARNESS_KEYWORDS = ("training", "loss", "matching", "segmentation", "settings", "device", "cache_dir", "seed",
                    "progress")
# What an option's value may be: a YAML scalar.
Scalar = bool | int | float | str | None
_SCALARS = (bool, int, float, str, type(None))
# A number in exponent notation without a dot, which YAML 1.1 (PyYAML) leaves a string.
_EXPONENT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


@dataclass(frozen=True)
class EstimatorSpec:
    """An estimator as a bench names it: its name or dotted path and its constructor options."""

    name: str
    options: dict[str, Scalar] = field(default_factory=dict, hash=False)


def parse_value(text: str, where: str) -> Scalar:
    """A command-line option value read as a YAML scalar (``0.7``, ``3``, ``true``, ``null``, ``fast``).

    Raises:
        EstimatorError: not a scalar (a list, a mapping) or not YAML; names ``where``.
    """
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        value = ...  # not YAML: reported below like a list would be
    if not isinstance(value, _SCALARS):
        raise EstimatorError(f"{where}: value {text!r} is not a number, true/false, null or a string")
    if isinstance(value, str) and _EXPONENT.fullmatch(value.strip()):  # YAML 1.1 reads 1e-3 as a string
        return float(value)
    return typing.cast(Scalar, value)


def _assignment(text: str, where: str) -> tuple[str, Scalar]:
    key, equals, value = text.partition("=")
    if not equals or not key.strip().isidentifier():
        raise EstimatorError(f"{where}: expected KEY=VALUE with KEY a parameter name, got {text!r}")
    return key.strip(), parse_value(value, f"{where}: {key.strip()}")


def parse_estimator_spec(text: str) -> EstimatorSpec:
    """``NAME`` or ``NAME?key=value&key=value`` (an ``--estimator`` entry) → :class:`EstimatorSpec`.

    >>> parse_estimator_spec("sift?ratio=0.7&cross=true")
    EstimatorSpec(name='sift', options={'ratio': 0.7, 'cross': True})

    Raises:
        EstimatorError: an assignment that is not ``KEY=VALUE``, a key given twice.
    """
    name, _, query = text.partition("?")
    options: dict[str, Scalar] = {}
    for part in filter(None, query.split("&")):
        key, value = _assignment(part, f"--estimator {text!r}")
        if key in options:
            raise EstimatorError(f"--estimator {text!r}: option {key!r} given twice")
        options[key] = value
    return EstimatorSpec(name, options)


def parse_option_flag(text: str) -> tuple[str, str, Scalar]:
    """``NAME.KEY=VALUE`` (an ``--option``) → ``(NAME, KEY, VALUE)``; NAME may be a dotted path.

    >>> parse_option_flag("my_pkg.module:Sift.ratio=0.7")
    ('my_pkg.module:Sift', 'ratio', 0.7)

    Raises:
        EstimatorError: no ``NAME.`` before the key, or not ``KEY=VALUE``.
    """
    target, equals, value = text.partition("=")
    name, dot, key = target.rpartition(".")
    if not (name and dot and equals):
        raise EstimatorError(f"--option {text!r}: expected NAME.KEY=VALUE, e.g. sift.ratio=0.7")
    key, parsed = _assignment(f"{key}={value}", f"--option {text!r}")
    return name, key, parsed


def merge_options(names: list[str], configured: Mapping[str, Mapping[str, Any]],
                  flags: list[str]) -> list[EstimatorSpec]:
    """The ``--estimator`` entries with their options: configuration, then ``?…``, then ``--option``.

    Args:
        names: ``--estimator`` entries (``NAME`` or ``NAME?query``).
        configured: ``estimators:`` of the configuration, by name.
        flags: ``--option`` values.

    Raises:
        EstimatorError: an entry or flag that does not parse, or an ``--option`` naming
            no ``--estimator`` entry.
    """
    specs = [parse_estimator_spec(name) for name in names]
    overrides: dict[str, dict[str, Scalar]] = {}
    for flag in flags:
        name, key, value = parse_option_flag(flag)
        if name not in {spec.name for spec in specs}:
            raise EstimatorError(f"--option {flag!r}: estimator {name!r} is not benched "
                                 f"(--estimator {' '.join(spec.name for spec in specs)})")
        overrides.setdefault(name, {})[key] = value
    return [EstimatorSpec(spec.name, {**configured.get(spec.name, {}), **spec.options,
                                      **overrides.get(spec.name, {})}) for spec in specs]


def _fits(value: Any, annotation: Any) -> bool:
    """Whether ``value`` fits a simple annotation; True for any annotation this does not judge."""
    origin = typing.get_origin(annotation)
    if origin is Literal:
        return any(value == choice and type(value) is type(choice) for choice in typing.get_args(annotation))
    if origin in (Union, types.UnionType):
        arms = typing.get_args(annotation)
        return any(_fits(value, arm) for arm in arms if _judged(arm)) or not all(map(_judged, arms))
    if annotation is type(None) or annotation is None:
        return value is None
    if annotation is bool:
        return isinstance(value, bool)
    if annotation in (int, float):  # YAML's true is no number; an int passes for a float
        return isinstance(value, int if annotation is int else (int, float)) and not isinstance(value, bool)
    if annotation is str:
        return isinstance(value, str)
    return True


def _judged(annotation: Any) -> bool:
    """Whether :func:`_fits` judges the annotation (else any value passes)."""
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        return all(map(_judged, typing.get_args(annotation)))
    return origin is Literal or annotation in (bool, int, float, str, None, type(None))


def _signature(cls: Any) -> inspect.Signature | None:
    """The constructor's signature, string annotations resolved where they can be; None if it has none."""
    try:
        return inspect.signature(cls, eval_str=True)
    except (TypeError, ValueError):  # a builtin or C factory: nothing to check against
        return None
    except Exception:  # an annotation that does not resolve: keep it a string, which is judged as anything
        return inspect.signature(cls)


def check_options(name: str, cls: Any, options: Mapping[str, Any], supplied: frozenset[str] = frozenset()) -> None:
    """Refuse options the constructor cannot take, before any run (module docstring).

    Args:
        name: the estimator as given (named in the message).
        cls: its class or factory (:func:`synthcal.estimators.resolve_estimator`).
        options: the options it will be constructed with.
        supplied: the harness keywords its runs pass (these satisfy required parameters).

    Raises:
        EstimatorError: one line naming the estimator, the key and the value.
    """
    signature = _signature(cls)
    if signature is None:
        return
    parameters = signature.parameters
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())
    keywords = {key for key, p in parameters.items()
                if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)}
    for key, value in options.items():
        if key in HARNESS_KEYWORDS:
            raise EstimatorError(f"estimator {name!r}: option {key}={value!r}: {key!r} is set by bench itself "
                                 f"(its own flag or the profile), not an option")
        if key not in keywords and not takes_any:
            raise EstimatorError(f"estimator {name!r}: option {key}={value!r}: its constructor takes no {key!r} "
                                 f"(parameters: {', '.join(sorted(keywords)) or 'none'})")
        annotation = parameters[key].annotation if key in parameters else inspect.Parameter.empty
        if not _fits(value, annotation):
            raise EstimatorError(f"estimator {name!r}: option {key}={value!r}: expected {_spelled(annotation)}")
    missing = [key for key, p in parameters.items() if p.default is inspect.Parameter.empty
               and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
               and key not in options and key not in supplied]
    if missing:
        raise EstimatorError(f"estimator {name!r}: its constructor requires {', '.join(map(repr, missing))}: "
                             f"give --option {name}.{missing[0]}=VALUE or estimators: {{{name}: {{{missing[0]}: …}}}} "
                             f"in the configuration")


def _spelled(annotation: Any) -> str:
    """``int``, ``one of 'a', 'b'``, ``float or None``: an annotation in words."""
    origin = typing.get_origin(annotation)
    if origin is Literal:
        return "one of " + ", ".join(map(repr, typing.get_args(annotation)))
    if origin in (Union, types.UnionType):
        return " or ".join(_spelled(arm) for arm in typing.get_args(annotation))
    return "None" if annotation in (None, type(None)) else getattr(annotation, "__name__", str(annotation))


def options_label(label: str, options: Mapping[str, Any] | None) -> str:
    """A table label with its options, keys in order: ``sift(ratio=0.7)``; ``label`` alone without.

    >>> options_label("sift", {"ratio": 0.7, "cross": True})
    'sift(cross=True, ratio=0.7)'
    """
    if not options:
        return label
    return f"{label}({', '.join(f'{key}={options[key]}' for key in sorted(options))})"
