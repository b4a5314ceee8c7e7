"""A user's ``datasets.yaml`` layered over the packaged one: :func:`merge_layers`, :func:`show_layered`.

The rules (README "Layered configuration"), applied to the raw YAML before validation:

* a key set in a later layer wins over the same key of an earlier one;
* mappings merge key by key, at every depth (a profile's ``training:`` too);
* lists and scalars replace whole (``split_seeds: [0]`` is one seed, not six);
* ``null`` over a key an earlier layer set removes it: a packaged dataset, grid or
  profile disappears, and a removed setting falls back to its built-in default
  (every optional key of the schema defaults to ``null``, so this is the same as
  not setting it). ``null`` where no earlier layer set the key is a plain value.

Each key path remembers the file it came from (its *origin*), so an error names the
file that set the bad key, relative scene paths are resolved against their own
file's folder, and ``synthcal config show`` prints where each value came from.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

__all__ = ["KeyPath", "Origins", "STARTER", "merge_layers", "origin_of", "show_layered"]

KeyPath = tuple[str, ...]
Origins = dict[KeyPath, Path]


def merge_layers(layers: Sequence[tuple[Path, Mapping[Any, Any]]]) -> tuple[dict[Any, Any], Origins]:
    """The layers merged in order (later wins), and the file each key path came from.

    Args:
        layers: (file, its top-level mapping as read), the packaged file first.

    Returns:
        The merged mapping (the inputs are not modified) and, for every key path of it
        (mappings included: the last file that set or merged into them), its file.
    """
    merged: dict[Any, Any] = {}
    origins: Origins = {}
    for path, layer in layers:
        _merge_into(merged, layer, path, origins, ())
    return merged, origins


def _merge_into(target: dict[Any, Any], layer: Mapping[Any, Any], origin: Path, origins: Origins,
                prefix: KeyPath) -> None:
    for key, value in layer.items():
        where = (*prefix, str(key))
        if key in target and (value is None or not (isinstance(value, dict) and isinstance(target[key], dict))):
            del target[key]  # removed, or replaced whole: nothing of the earlier value stays
            _forget(origins, where)
            if value is None:
                continue
        if isinstance(value, dict) and isinstance(target.get(key), dict):
            origins[where] = origin
            _merge_into(target[key], value, origin, origins, where)
        else:
            target[key] = copy.deepcopy(value)  # YAML aliases share objects; a later merge must not write through
            _mark(origins, where, value, origin)


def _forget(origins: Origins, where: KeyPath) -> None:
    for key in [k for k in origins if k[:len(where)] == where]:
        del origins[key]


def _mark(origins: Origins, where: KeyPath, value: Any, origin: Path) -> None:
    origins[where] = origin
    if isinstance(value, dict):
        for key, item in value.items():
            _mark(origins, (*where, str(key)), item, origin)


def origin_of(origins: Origins, keys: Sequence[object], default: Path) -> Path:
    """The file that set ``keys`` or, where it set nothing there, its nearest enclosing mapping
    (a missing key is reported against the file of the mapping that lacks it); ``default``
    when no layer set even the top-level key."""
    parts = tuple(str(key) for key in keys)
    for end in range(len(parts), 0, -1):
        if parts[:end] in origins:
            return origins[parts[:end]]
    return default


def _flow(value: Any) -> str:
    """A value in YAML flow style on one line (``[256, 144]``, ``'0'``, ``null``)."""
    text = yaml.safe_dump(value, default_flow_style=True, width=2**31, allow_unicode=True, sort_keys=False)
    return text.removesuffix("\n").removesuffix("\n...").strip()


def show_layered(merged: Mapping[Any, Any], origins: Origins, label: Callable[[Path], str]) -> str:
    """The merged configuration as YAML in block style, each leaf followed by ``# <its origin>``.

    Args:
        merged: what :func:`merge_layers` returned.
        origins: its origins.
        label: how a file is named in the comments (``packaged`` for the packaged file).

    Returns:
        YAML text that reads back as ``merged``.
    """
    lines: list[str] = []

    def walk(mapping: Mapping[Any, Any], prefix: KeyPath, indent: str) -> None:
        for key, value in mapping.items():
            where = (*prefix, str(key))
            comment = f"  # {label(origin_of(origins, where, Path('?')))}"
            if isinstance(value, dict) and value:
                lines.append(f"{indent}{_flow(key)}:")
                walk(value, where, indent + "  ")
            else:
                lines.append(f"{indent}{_flow(key)}: {_flow(value)}{comment}")

    walk(merged, (), "")
    return "\n".join(lines) + "\n"


STARTER = """\
# A synthcal configuration, layered over the packaged one (`synthcal config show`
# prints the result, each value with the file it came from). Set only what differs:
# the packaged grids (intersection, soccer), defaults, datasets and profiles
# (smoke, demo, quick, paper) apply unless set here. Mappings merge key by key,
# lists replace whole, and `null` removes a packaged entry. README: "Layered
# configuration". Use it with `--config THIS_FILE`, or name it ./datasets.yaml.
version: 1

# Your own scenes: two PNGs (paths relative to this file), or an OpenStreetMap
# extract (`synthcal osm` prints the entry).
scenes: {}
#   my-crossing:
#     image: scenes/my-crossing.png
#     semantic: scenes/my-crossing-labels.png

# Datasets are listed alongside the packaged ones (intersection-1..5, soccer,
# worldcup2014); `intersection-2: null` would remove one.
datasets:
  my-intersection: {scene: intersection-2, grid: intersection, pool_size: 10000, seed: 7}

# A profile's keys merge into the packaged profile of the same name:
# profiles:
#   quick:
#     max_pool_size: 2000
#     training: {stn_epochs: 12}
"""
