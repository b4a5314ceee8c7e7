"""YAML as hostile input: :func:`read_yaml` parses a file within limits.

``yaml.safe_load`` runs no code, but it trusts the document's shape: 5,000 nested
brackets end in a ``RecursionError``, and a "billion laughs" document (aliases of
aliases) expands to gigabytes. Here the node graph is composed first, with its
nesting bounded while it is built, and measured before any Python object is made:

* the file is at most :data:`MAX_FILE_BYTES`;
* values nest at most :data:`MAX_DEPTH` levels, aliases followed;
* the document expands to at most :data:`MAX_VALUES` values, aliases followed
  (anchors and merge keys stay usable, a bomb is refused before it is expanded);
* a mapping repeats no key (YAML says keys are unique; PyYAML keeps the later one).

Every refusal is a :class:`~synthcal.config.vocabulary.ConfigError` of one line
naming the file, the key path and the line.
"""

from __future__ import annotations

import copy
import functools
from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from synthcal.config.vocabulary import ConfigError, brief

__all__ = ["MAX_FILE_BYTES", "MAX_DEPTH", "MAX_VALUES", "read_yaml"]

MAX_FILE_BYTES = 10 * 2**20
MAX_DEPTH = 64
MAX_VALUES = 100_000

_MERGE_TAG = "tag:yaml.org,2002:merge"


class _Refused(Exception):
    """A limit the document breaks: what, where (a key path) and on which line (None: ``what`` says)."""

    def __init__(self, what: str, where: str, line: int | None) -> None:
        super().__init__(what)
        self.what, self.where, self.line = what, where, line


def _label(index: Node | int | None) -> str:
    """A key path element: a mapping value's key, a sequence item's position."""
    if isinstance(index, ScalarNode):
        return brief(str(index.value), 40)
    return "?" if index is None else str(index)


def _key_path(parts: list[str]) -> str:
    """``a.b.c`` of a (possibly 64 deep) path, its middle elided so that it stays short."""
    path = ".".join(parts)
    return path if len(parts) <= 8 else ".".join([*parts[:3], "…", *parts[-4:]])


class _LimitedLoader(yaml.SafeLoader):
    """A ``SafeLoader`` that bounds nesting while it composes and refuses duplicate keys."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._path: list[str] = []
        self.paths: dict[int, str] = {}  # id(mapping node) → its key path, for duplicate-key messages

    def compose_node(self, parent: Node | None, index: Node | int | None) -> Node:
        if parent is not None:
            self._path.append(_label(index))
        try:
            if len(self._path) > MAX_DEPTH:  # composing recurses: refuse before Python's stack runs out
                raise _Refused(f"values nest more than {MAX_DEPTH} levels deep", _key_path(self._path),
                               self.peek_event().start_mark.line + 1)
            node: Node = super().compose_node(parent, index)
            if isinstance(node, MappingNode):
                self.paths.setdefault(id(node), _key_path(self._path))
            return node
        finally:
            if parent is not None:
                self._path.pop()

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG or not isinstance(key_node, ScalarNode):
                continue  # merged keys may be overridden; unhashable keys are PyYAML's own error
            key, line = self.construct_object(key_node), key_node.start_mark.line + 1
            if key in seen:
                where = ".".join(filter(None, [self.paths.get(id(node), ""), brief(str(key), 40)]))
                raise _Refused(f"duplicate key on lines {seen[key]} and {line}", where, None)
            seen[key] = line
        return super().construct_mapping(node, deep)


def _children(node: Node) -> list[Node]:
    if isinstance(node, SequenceNode):
        return list(node.value)
    if isinstance(node, MappingNode):
        return [child for pair in node.value for child in pair]
    return []


def _check_expansion(root: Node) -> None:
    """Refuse a graph that expands past :data:`MAX_VALUES` values or :data:`MAX_DEPTH` levels, or
    holds a cycle (an anchor aliased inside itself), counting each alias as the copy it stands for.

    Linear in the composed graph: each node's expanded size and depth are computed once.
    """
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        key = id(node)
        if children_done:
            children = _children(node)
            size[key] = 1 + sum(size[id(child)] for child in children)
            depth[key] = 1 + max((depth[id(child)] for child in children), default=0)
            open_nodes.discard(key)
            if size[key] > MAX_VALUES or depth[key] > MAX_DEPTH + 1:
                limit = (f"more than {MAX_VALUES} values" if size[key] > MAX_VALUES
                         else f"values nested more than {MAX_DEPTH} levels deep")
                raise _Refused(f"aliases expand the document to {limit}", "", node.start_mark.line + 1)
            continue
        if key in size:
            continue
        if key in open_nodes:  # still being expanded: the node contains itself
            raise _Refused("an alias refers to a value that contains it", "", node.start_mark.line + 1)
        open_nodes.add(key)
        stack.append((node, True))
        stack.extend((child, False) for child in _children(node))


def _read_text(path: Path) -> str:
    try:
        with path.open("rb") as file:
            data = file.read(MAX_FILE_BYTES + 1)  # never more, whatever the file is (a FIFO, /dev/zero)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the configuration ({exc.strerror})") from None
    if len(data) > MAX_FILE_BYTES:
        raise ConfigError(f"{path}: larger than {MAX_FILE_BYTES // 2**20} MiB; not a configuration file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start})") from None


def _yaml_error(exc: yaml.YAMLError) -> str:
    """A YAML error as one line: what PyYAML found and where."""
    if isinstance(exc, yaml.MarkedYAMLError):
        what = " ".join(filter(None, [exc.context, exc.problem])) or "syntax error"
        mark = exc.problem_mark or exc.context_mark
        return f"{what} (line {mark.line + 1}, column {mark.column + 1})" if mark else what
    return " ".join(str(exc).split())


def read_yaml(path: Path) -> Any:
    """The one document of a YAML file, as plain Python objects, within the module's limits.

    Raises:
        ConfigError: unreadable, too large, not UTF-8, not YAML, or over a limit;
            one line naming the file (and the key path and line where there is one).
    """
    text = _read_text(path)
    try:
        # A copy: callers merge layers into what they get, and the cached parse must stay as read.
        return copy.deepcopy(_document(text))
    except _Refused as refused:
        where = f" {refused.where}:" if refused.where else ""
        line = f" (line {refused.line})" if refused.line is not None else ""
        raise ConfigError(f"{path}:{where} {refused.what}{line}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {_yaml_error(exc)}") from None
    except ValueError as exc:  # a scalar Python refuses to convert, e.g. an integer of 5,000 digits
        raise ConfigError(f"{path}: not valid YAML: {brief(str(exc), 120)}") from None


@functools.lru_cache(maxsize=8)
def _document(text: str) -> Any:
    """The parsed document of ``text``, cached by text: every load reads the packaged file under the user's,
    and PyYAML's pure-Python loader takes ~0.1 s over it. Refusals raise (and are not cached)."""
    loader = _LimitedLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expansion(node)
        return loader.construct_document(node)
    finally:
        loader.dispose()
