"""Property (issue 23 (a)): any YAML document built from the schema's keys, with values of random
types, loads — or raises one ConfigError line of at most 300 characters, never another exception.

Half the documents follow the schema's shape (its models' keys, nested as the models nest,
with maps of named entries where the schema has them; every value either of a plausible kind
for its field or anything at all); the other half are the bundled ``datasets.yaml`` with a few
of its keys given random values or removed, so that validation also gets past the first
error pydantic reports to references and grid sizes.
"""

from __future__ import annotations

import copy
import os
import types
import typing
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from synthcal.config import MAX_MESSAGE, Config, ConfigError, LoadedConfig, load_config, packaged_config_path

NAMES = st.sampled_from(["soccer", "intersection-1", "intersection", "g", "smoke", "d"]) | st.text(max_size=12)
NUMBERS = (st.integers(-10, 2000) | st.integers() | st.floats()
           | st.sampled_from([0, 1, -1, 1e-12, 1e308, -1e308, 16385, 10**30]))
SCALARS = st.none() | st.booleans() | NUMBERS | st.text(max_size=30)
ANYTHING = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=3) | st.dictionaries(NAMES, inner, max_size=2),
                        max_leaves=4)


def _parts(annotation: Any) -> list[Any]:
    """The alternatives of ``X | None`` / ``Annotated[X, …]``, flattened."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return [part for arg in typing.get_args(annotation) for part in _parts(arg)]
    if typing.get_origin(annotation) is typing.Annotated:
        return _parts(typing.get_args(annotation)[0])
    return [annotation]


def value_for(annotation: Any) -> st.SearchStrategy[Any]:
    """A value of a field: of a kind its annotation takes (a nested model's keys included), or anything."""
    kinds: list[st.SearchStrategy[Any]] = [ANYTHING]
    for part in _parts(annotation):
        origin, args = typing.get_origin(part), typing.get_args(part)
        if isinstance(part, type) and issubclass(part, BaseModel):
            kinds.append(shaped(part))
        elif origin is dict and args and isinstance(args[1], type) and issubclass(args[1], BaseModel):
            kinds.append(st.dictionaries(NAMES, shaped(args[1]), max_size=3))
        elif origin is tuple:
            kinds.append(st.lists(NUMBERS | NAMES, min_size=1, max_size=4))
        elif origin is typing.Literal:
            kinds.append(st.sampled_from(args))
        elif part in (int, float):
            kinds.append(NUMBERS)
    return st.one_of(kinds)


def shaped(model: type[BaseModel]) -> st.SearchStrategy[dict[str, Any]]:
    """A mapping with the model's keys: the required ones, some optional ones, now and then an unknown one."""
    fields = model.model_fields
    required = {name: st.deferred(lambda f=field: value_for(f.annotation))
                for name, field in fields.items() if field.is_required()}
    optional = {name: st.deferred(lambda f=field: value_for(f.annotation))
                for name, field in fields.items() if not field.is_required()}
    optional["no_such_key"] = ANYTHING
    return st.fixed_dictionaries(required, optional=optional)


BUNDLED = yaml.safe_load((Path(__file__).resolve().parents[1] / "datasets.yaml").read_text())
REMOVED = object()


def _key_paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a parsed document, inner nodes included."""
    children = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else []
    return [path for key, child in children for path in [(*prefix, key), *_key_paths(child, (*prefix, key))]]


def _changed(document: Any, changes: list[tuple[tuple[Any, ...], Any]]) -> Any:
    document = copy.deepcopy(document)
    for path, value in changes:
        parent = document
        try:
            for key in path[:-1]:
                parent = parent[key]
            if value is REMOVED:
                del parent[path[-1]]
            else:
                parent[path[-1]] = value
        except (KeyError, IndexError, TypeError):  # an earlier change took the path away
            pass
    return document


BUNDLED_CHANGED = st.lists(st.tuples(st.sampled_from(_key_paths(BUNDLED)), ANYTHING | st.just(REMOVED)),
                           min_size=1, max_size=3).map(lambda changes: _changed(BUNDLED, changes))


# The same 200 documents on every run (CI must not fail by chance); SYNTHCAL_EXPLORE=N draws N new ones.
@settings(max_examples=int(os.environ.get("SYNTHCAL_EXPLORE", 200)), deadline=None,
          derandomize="SYNTHCAL_EXPLORE" not in os.environ,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(document=shaped(Config) | BUNDLED_CHANGED)
def test_any_schema_shaped_document_loads_or_is_one_config_error_line(tmp_path_factory, document):
    path = Path(tmp_path_factory.mktemp("config")) / "datasets.yaml"
    path.write_text(yaml.safe_dump(document, allow_unicode=True))
    try:
        assert isinstance(load_config(path), LoadedConfig)
    except ConfigError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) <= MAX_MESSAGE, message
        # The file that set the offending key: the user's, or the packaged one under it (a packaged
        # dataset naming a grid the user's file removed with null).
        assert message.startswith((f"{path}: ", f"{packaged_config_path()}: ")), message
