"""Reading the per-seed splits a store holds (SPEC §6); drawing them is :mod:`synthcal.generate.splits`.

Layout (inside the dataset's store)::

    splits/                                   group, attrs {"layout": "synthcal-splits/1"}
    splits/seed-<s>/                          group, attrs = the recipe (below)
    splits/seed-<s>/train                     (n_train,) int64   pool indices, ascending
    splits/seed-<s>/test                      (n_test,)  int64
    splits/seed-<s>/dictionary                (n_dict,)  int64   absent without an own dictionary
    splits/seed-<s>/validation                (n_val,)   int64   absent when its size is 0 or drawn before it existed
    splits/seed-<s>/mixed_dictionary/         group, attrs {"sources", "stores", "source_config_hash",
                                              "homography_frame"}; present when the dataset has sources
    splits/seed-<s>/mixed_dictionary/source   (K,) int64   position in the ``sources`` attribute list
    splits/seed-<s>/mixed_dictionary/index    (K,) int64   pool index in that source's store

A mixed dictionary's source stores are found *beside* the target: ``<target's folder>/<source>.zarr``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zarr

from synthcal.config import DatasetSpec
from synthcal.store.format import StoreError, array_at, attributes, group_at, open_store, read_samples

__all__ = [
    "SPLIT_NAMES",
    "VALIDATION",
    "STORED_SPLITS",
    "LAYOUT_VERSION",
    "SplitError",
    "MixedDictionary",
    "store_spec",
    "dictionary_is_mixed",
    "source_store_path",
    "open_source",
    "drawn_seeds",
    "read_split_indices",
    "pool_dictionary_indices",
    "read_mixed_dictionary",
    "read_mixed_samples",
    "resolve_mixed_dictionary",
]

# The three drawn together (one stream); validation comes after them, from its own.
SPLIT_NAMES = ("train", "test", "dictionary")
VALIDATION = "validation"
STORED_SPLITS = (*SPLIT_NAMES, VALIDATION)
LAYOUT_VERSION = "synthcal-splits/1"


class SplitError(StoreError):
    """A split that cannot be drawn or read; the message names store, key and value."""


def store_spec(group: zarr.Group, path: Path) -> DatasetSpec:
    """The resolved configuration recorded in a store's attributes."""
    try:
        return DatasetSpec.model_validate(group.attrs["config"])
    except (KeyError, ValueError) as exc:
        reason = " ".join(str(exc).split())  # pydantic's messages span lines; an error is one
        raise SplitError(f"{path}: attribute 'config' missing or unreadable ({reason})") from None


def dictionary_is_mixed(group: zarr.Group, path: Path, asked: bool | None = None) -> bool:
    """Whether a store's ``dictionary`` is read as its mixed one: ``asked`` where given, else (None) the
    store's default — mixed where the store draws no dictionary of its own (``dictionary_from``, as
    ``worldcup2014``, whose templates come from the soccer store).

    The one rule the loaders, the harness and the template diagnostics share.
    """
    return bool(asked) if asked is not None else not store_spec(group, path).own_dictionary


def source_store_path(store: Path, source: str) -> Path:
    """Where a mixed-dictionary source is found: beside the target's store."""
    return Path(store).parent / f"{source}.zarr"


def open_source(store: Path, target_attrs: dict, source: str, config_hash: str | None = None) -> zarr.Group:
    """Open a source store and check that its samples can stand in the target's dictionary."""
    path = source_store_path(store, source)
    try:
        group = open_store(path)
    except StoreError as exc:
        raise SplitError(f"{store}: mixed-dictionary source {source!r}: {exc}") from None
    attrs = attributes(group)
    for key in ("image_size",):
        if attrs[key] != target_attrs[key]:
            raise SplitError(f"{store}: mixed-dictionary source {path}: {key} {attrs[key]} differs from the "
                             f"target's {target_attrs[key]}")
    if attrs["scene"]["classes"] != target_attrs["scene"]["classes"]:
        raise SplitError(f"{store}: mixed-dictionary source {path}: scene classes {attrs['scene']['classes']} "
                         f"differ from the target's {target_attrs['scene']['classes']}")
    if config_hash is not None and attrs["config_hash"] != config_hash:
        raise SplitError(f"{store}: mixed-dictionary source {path} was regenerated since the split was drawn "
                         f"(config_hash {attrs['config_hash'][:12]}…, recorded {config_hash[:12]}…); "
                         f"redraw with `synthcal split {store}`")
    return group


def drawn_seeds(group: zarr.Group) -> tuple[int, ...]:
    """The seeds whose splits a store holds."""
    if "splits" not in group:
        return ()
    names = [name for name in group_at(group, "splits").group_keys() if name.startswith("seed-")]
    return tuple(sorted(int(name.removeprefix("seed-")) for name in names))


def _seed_group(group: zarr.Group, store: Path, seed: int) -> zarr.Group:
    key = f"splits/seed-{seed}"
    if key not in group:
        seeds = drawn_seeds(group)
        available = ", ".join(map(str, seeds)) or "none; draw them with `synthcal split STORE`"
        raise SplitError(f"{store}: {key}: no splits drawn for seed {seed!r}; seeds available: {available}")
    return group_at(group, key)


def read_split_indices(store: str | Path, split: str, seed: int, group: zarr.Group | None = None) -> np.ndarray:
    """The pool indices of one of the store's own splits.

    Args:
        store: the store.
        split: ``train``, ``test``, ``dictionary`` or ``validation``.
        seed: the split seed.
        group: ``store`` as the caller opened it (:func:`~synthcal.store.open_store`): saves
            opening it and checking its manifest again.

    Returns:
        (n,) int64 ascending indices into the store's pool.

    Raises:
        SplitError: unknown split or seed, a dataset without an own dictionary, or
            no validation set (drawn before it existed, or of size 0).
    """
    store = Path(store)
    if split not in STORED_SPLITS:
        raise SplitError(f"{store}: unknown split {split!r}; known: {', '.join(STORED_SPLITS)}")
    seed_group = _seed_group(open_store(store) if group is None else group, store, seed)
    if split == VALIDATION and split not in seed_group:
        raise SplitError(f"{store}: splits/seed-{seed}/validation: no validation set (drawn before validation "
                         f"sets existed, or splits.validation is 0): draw it with "
                         f"`synthcal split {store} --validation N`")
    if split not in seed_group:
        raise SplitError(f"{store}: splits/seed-{seed}/{split}: dataset has no own {split} "
                         f"(its dictionary comes from other datasets: load it as the mixed dictionary)")
    return np.asarray(array_at(seed_group, split)[:])


def pool_dictionary_indices(store: str | Path, seed: int, group: zarr.Group | None = None) -> np.ndarray:
    """The pool dictionary of a seed: every pool index in neither its train, test nor validation split.

    The whole stored splits are left out (not a profile's capped prefix of them), so no
    test, train or validation sample is ever a template, whatever the caps (a
    validation image with its own camera in the dictionary would flatter selection).
    ``group``: as in :func:`read_split_indices`.

    Returns:
        (N − n_train − n_test − n_validation,) int64 ascending pool indices.

    Raises:
        SplitError: an unknown seed.
    """
    store = Path(store)
    group = open_store(store) if group is None else group
    keep = np.ones(int(attributes(group)["N"]), bool)
    seed_group = _seed_group(group, store, seed)
    for split in ("train", "test", VALIDATION):
        if split in seed_group:  # validation: absent in splits drawn before it existed
            keep[np.asarray(array_at(seed_group, split)[:])] = False
    return np.flatnonzero(keep).astype(np.int64)


@dataclass(frozen=True)
class MixedDictionary:
    """A mixed dictionary's templates: which source store, which sample.

    Attributes:
        store: the target store.
        sources: source dataset names.
        stores: the source stores (beside the target).
        source_config_hash: the pool each source index refers to.
        source: (K,) int64 positions into ``sources``.
        index: (K,) int64 pool indices in the source stores.
    """

    store: Path
    sources: tuple[str, ...]
    stores: tuple[Path, ...]
    source_config_hash: dict[str, str]
    source: np.ndarray
    index: np.ndarray


def read_mixed_dictionary(store: str | Path, seed: int) -> MixedDictionary:
    """The (source, index) pairs of a seed's mixed dictionary.

    Raises:
        SplitError: unknown seed, or no mixed dictionary drawn.
    """
    store = Path(store)
    seed_group = _seed_group(open_store(store), store, seed)
    key = f"splits/seed-{seed}/mixed_dictionary"
    if "mixed_dictionary" not in seed_group:
        raise SplitError(f"{store}: {key}: no mixed dictionary here (the dataset has no sources, or they were "
                         f"missing when the splits were drawn: generate them beside the store and run "
                         f"`synthcal split {store}`)")
    sub = group_at(seed_group, "mixed_dictionary")
    attrs = attributes(sub)
    sources = tuple(str(source) for source in attrs["sources"])
    return MixedDictionary(
        store=store, sources=sources, stores=tuple(source_store_path(store, s) for s in sources),
        source_config_hash=dict(attrs["source_config_hash"]), source=np.asarray(array_at(sub, "source")[:]),
        index=np.asarray(array_at(sub, "index")[:]),
    )


def read_mixed_samples(mixed: MixedDictionary) -> dict[str, np.ndarray]:
    """Resolve templates to arrays from their source stores.

    Returns:
        ``image`` (K, H, W, 3) uint8, ``semantic`` (K, H, W) uint8,
        ``homography`` (K, 3, 3) float64 in the **source** scene's bird's-eye frame,
        ``source`` and ``index`` (K,) int64.

    Raises:
        SplitError: a source store missing, incompatible, or regenerated since.
    """
    target_attrs = attributes(open_store(mixed.store))
    out: dict[str, np.ndarray] = {}
    for k, name in enumerate(mixed.sources):
        group = open_source(mixed.store, target_attrs, name, mixed.source_config_hash.get(name))
        mask = mixed.source == k
        if not mask.any():  # fewer templates than sources
            continue
        for key, values in read_samples(group, mixed.index[mask]).items():
            if key not in out:
                out[key] = np.empty((len(mixed.index), *values.shape[1:]), values.dtype)
            out[key][mask] = values
    out["source"], out["index"] = mixed.source, mixed.index
    return out


def resolve_mixed_dictionary(store: str | Path, seed: int) -> dict[str, np.ndarray]:
    """One call: a seed's mixed dictionary as arrays (see :func:`read_mixed_samples`)."""
    return read_mixed_samples(read_mixed_dictionary(store, seed))
