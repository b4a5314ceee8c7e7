"""Per-seed train / test / dictionary splits inside a store (SPEC §6).

Layout inside the store: :mod:`synthcal.store.splits` (which reads it).

The three own sets of a seed are disjoint, drawn uniformly without replacement from
the pool with ``SeedSequence(pool_seed, spawn_key=(2, s))`` — a stream independent
of the pool's cameras ``(0,)`` and of the per-sample appearance ``(1, i)``. A dataset
of given poses (``worldcup2014``) has fixed train/test parts, the same for every seed
(less, in train, the seed's validation set: below).

**Validation.** A fourth set, drawn *after* the three from what they leave, with its
own stream ``SeedSequence(pool_seed, spawn_key=(5, s))`` (``(4, i)`` is the grid's):
the three are exactly what they were before validation sets existed, so drawing a
store's splits again adds ``validation`` and changes nothing else. Size 0: none.
A dataset of given poses has nothing left outside its fixed train/test sets, so
its validation set is carved from the given **train** part (World Cup 2014's
``train_val``) with the same stream, and ``train`` keeps the rest; ``test`` stays
the given one. Adding validation to such a store therefore shrinks its train set.

**Mixed dictionaries.** The ``K`` templates (``K`` = the dictionary size) come from
the pools of the source datasets, an equal share from each (the first ``K mod n``
sources give one more), drawn with ``SeedSequence(pool_seed, spawn_key=(3, s))``,
grouped by source and ascending within a source. Source stores are found *beside*
the target: ``<target's folder>/<source>.zarr`` (``stores`` records those relative
paths, ``source_config_hash`` the pool each index refers to). A template's
homography maps **its source scene's** bird's-eye frame to the image — not the
target's scene (``homography_frame`` says so in the store).

**Writing.** Each seed's group is built under ``<store>/.splits-tmp-<random>/`` and
moved into place with ``os.replace``, so ``splits/seed-<s>`` is always whole; the
store's manifest is marked ``writing`` before the first change and resealed from the
files at the end (:func:`synthcal.store.resealing`), so whatever arrays a seed holds
are under it. A
seed whose recorded recipe (pool, sizes, sources) equals the request is left alone,
so redrawing is idempotent; a changed recipe replaces the group (the old one is
moved aside first, then deleted), with a warning (:class:`SplitsResized`) when the
sizes change. One writer per store at a time: drawing holds the
store's lock (:func:`synthcal.store.store_lock`, the one ``generate`` holds), and
sweeps away the scratch folders of a writer that was killed. Index arrays end in
the ``crc32c`` codec, as every array of the store does.

**Images.** In an ``images: splits`` store, drawing then renders the images the
splits use that the store lacks (:mod:`synthcal.generate.images`), still under the
lock, and those a mixed dictionary takes from ``images: splits`` sources, under
each source's lock.

Example
-------
>>> import numpy as np
>>> from synthcal.config import SplitSizes
>>> sets = draw_indices(100, SplitSizes(train=60, test=10, dictionary=20, validation=5), pool_seed=0, split_seed=1)
>>> [len(sets[k]) for k in sets], len(np.unique(np.concatenate(list(sets.values()))))
([60, 10, 20, 5], 95)
"""

from __future__ import annotations

import os
import shutil
import tempfile
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import zarr

from synthcal.config import SplitSizes
from synthcal.generate.images import mixed_uses, render_missing_images
from synthcal.store import CHECKSUMMED_INDEX, image_mode, resealing, store_lock
from synthcal.store.format import open_store
from synthcal.store.splits import (
    LAYOUT_VERSION,
    SPLIT_NAMES,
    VALIDATION,
    SplitError,
    open_source,
    source_store_path,
    store_spec,
)

__all__ = [
    "DrawResult",
    "split_sizes",
    "draw_indices",
    "draw_mixed",
    "draw_splits",
]

_HOMOGRAPHY_FRAME = "source: each template's homography maps its source scene's bird's-eye frame to the image"


def split_sizes(base: SplitSizes, **overrides: int) -> SplitSizes:
    """``base`` with some sizes replaced (``train=``, ``test=``, ``dictionary=``: ≥ 1; ``validation=``: ≥ 0).

    Raises:
        SplitError: an unknown split or a size below its minimum (named ``splits.<name>``).
    """
    for name, value in overrides.items():
        least = 0 if name == VALIDATION else 1
        if name not in (*SPLIT_NAMES, VALIDATION) or value < least:
            raise SplitError(f"splits.{name}: a split size must be an integer ≥ {least} (value {value!r})")
    return SplitSizes(**{**base.model_dump(), **overrides})


def draw_indices(
    pool_size: int,
    sizes: SplitSizes,
    pool_seed: int,
    split_seed: int,
    fixed: dict[str, np.ndarray] | None = None,
    own_dictionary: bool = True,
) -> dict[str, np.ndarray]:
    """Disjoint index sets of one seed.

    Args:
        pool_size: N, the pool's sample count.
        sizes: how many train / test / dictionary samples.
        pool_seed: the store's seed.
        split_seed: the cycle's seed ``s``.
        fixed: given train/test sets (poses datasets; ``sizes.train`` is then the
            given train part, validation included); drawn otherwise.
        own_dictionary: draw a ``dictionary`` from the pool too.

    Returns:
        ``train``, ``test`` (and ``dictionary``, and ``validation`` when its size is
        > 0) as ascending (n,) int64 arrays.

    Raises:
        ValueError: the sizes add up to more than N (the caller names the store).
    """
    names = [name for name in SPLIT_NAMES if name != "dictionary" or own_dictionary]
    fixed = fixed or {}
    drawn_names = [name for name in names if name not in fixed]
    taken = np.concatenate([np.asarray(fixed[n], np.int64) for n in names if n in fixed] or [np.zeros(0, np.int64)])
    free = np.setdiff1d(np.arange(pool_size, dtype=np.int64), taken) if len(taken) else None
    available = pool_size - len(taken)
    counts = [getattr(sizes, name) for name in drawn_names]
    if sum(counts) > available:
        held = f"N = {pool_size}" if not len(taken) else \
            f"only {available} outside the fixed {'/'.join(fixed)} sets (N = {pool_size})"
        raise ValueError(f"{' + '.join(f'{n} {c}' for n, c in zip(drawn_names, counts, strict=True))} = {sum(counts)} "
                         f"samples asked for, but the pool holds {held}")
    rng = np.random.default_rng(np.random.SeedSequence(pool_seed, spawn_key=(2, split_seed)))
    chosen = rng.choice(available, size=sum(counts), replace=False).astype(np.int64)
    if free is not None:
        chosen = free[chosen]
    out = {name: np.sort(np.asarray(fixed[name], np.int64)) for name in names if name in fixed}
    # not strict: with nothing to draw (fixed train/test, no own dictionary) np.split still gives one empty part
    for name, part in zip(drawn_names, np.split(chosen, np.cumsum(counts)[:-1]), strict=False):
        out[name] = np.sort(part)
    sets = {name: out[name] for name in names}
    if not sizes.validation:
        return sets
    if "train" in fixed:  # given poses fill the pool: validation is carved from their train part
        given = sets["train"]
        if sizes.validation >= len(given):
            raise ValueError(f"validation {sizes.validation} samples asked for, but the given train part holds "
                             f"{len(given)} and training needs at least one (set splits.validation, or "
                             f"`synthcal split --validation`)")
        sets[VALIDATION] = _draw_validation(given, sizes.validation, pool_seed, split_seed)
        sets["train"] = np.setdiff1d(given, sets[VALIDATION])
        return sets
    free = np.setdiff1d(np.arange(pool_size, dtype=np.int64), np.concatenate(list(sets.values())))
    if sizes.validation > len(free):
        raise ValueError(f"validation {sizes.validation} samples asked for, but only {len(free)} of N = {pool_size} "
                         f"are left outside {'/'.join(sets)} (set splits.validation, or `synthcal split --validation`)")
    sets[VALIDATION] = _draw_validation(free, sizes.validation, pool_seed, split_seed)
    return sets


def _draw_validation(candidates: np.ndarray, count: int, pool_seed: int, split_seed: int) -> np.ndarray:
    """(count,) ascending int64 pool indices among ``candidates`` (ascending), from validation's own stream."""
    rng = np.random.default_rng(np.random.SeedSequence(pool_seed, spawn_key=(5, split_seed)))
    return np.sort(candidates[rng.choice(len(candidates), size=count, replace=False)])


def draw_mixed(
    source_sizes: Sequence[int], count: int, pool_seed: int, split_seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """A mixed dictionary: an equal share of ``count`` templates from each source.

    Args:
        source_sizes: pool size of each source.
        count: K, the number of templates.
        pool_seed, split_seed: as in :func:`draw_indices` (a separate stream).

    Returns:
        ``source`` (K,) int64 positions into ``source_sizes`` and ``index`` (K,)
        int64 pool indices, grouped by source and ascending within one.

    Raises:
        ValueError: a source's share exceeds its pool (the caller names the store).
    """
    n = len(source_sizes)
    shares = [count // n + (k < count % n) for k in range(n)]
    rng = np.random.default_rng(np.random.SeedSequence(pool_seed, spawn_key=(3, split_seed)))
    sources, indices = [], []
    for k, (share, size) in enumerate(zip(shares, source_sizes, strict=True)):
        if share > size:
            raise ValueError(f"source {k}: its share {share} of the {count} templates exceeds its pool of N = {size}")
        indices.append(np.sort(rng.choice(size, size=share, replace=False)).astype(np.int64))
        sources.append(np.full(share, k, np.int64))
    return np.concatenate(sources), np.concatenate(indices)


@dataclass(frozen=True)
class DrawResult:
    """What :func:`draw_splits` did.

    Attributes:
        store: the target store.
        drawn: seeds written (new, or with a changed recipe).
        unchanged: seeds already there with the same recipe.
        note: why a mixed dictionary was not drawn, or None.
        rendered: images rendered for an ``images: splits`` store (and its
            mixed dictionary's ``images: splits`` sources); 0 otherwise.
    """

    store: Path
    drawn: tuple[int, ...]
    unchanged: tuple[int, ...]
    note: str | None = None
    rendered: int = 0


def _fixed_sets(group: zarr.Group) -> dict[str, np.ndarray]:
    """Given train/test sets of a poses dataset (recorded by the pipeline), else {}."""
    poses = cast("dict[str, Any] | None", group.attrs.get("poses"))  # JSON: see worldcup.pose_attributes
    if not poses:
        return {}
    return {name: np.arange(*poses["partition"][name], dtype=np.int64) for name in ("train", "test")}


def _write_seed(store: Path, seed: int, recipe: dict, sets: dict[str, np.ndarray],
                mixed: tuple[np.ndarray, np.ndarray, dict] | None) -> None:
    """Build ``splits/seed-<s>`` under a temporary name, then move it into place."""
    scratch = Path(tempfile.mkdtemp(prefix=".splits-tmp-", dir=store))
    try:
        built = scratch / f"seed-{seed}"
        group = zarr.create_group(zarr.storage.LocalStore(built), zarr_format=3, attributes=recipe)
        for name, index in sets.items():
            group.create_array(name, data=index, compressors=CHECKSUMMED_INDEX)
        if mixed is not None:
            source, index, attrs = mixed
            sub = group.create_group("mixed_dictionary", attributes=attrs)
            sub.create_array("source", data=source, compressors=CHECKSUMMED_INDEX)
            sub.create_array("index", data=index, compressors=CHECKSUMMED_INDEX)
        target = store / "splits" / f"seed-{seed}"
        if target.exists():
            os.replace(target, scratch / "previous")
        os.replace(built, target)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _ensure_splits_group(store: Path) -> None:
    if not (store / "splits" / "zarr.json").is_file():
        zarr.create_group(zarr.storage.LocalStore(store / "splits"), zarr_format=3,
                          attributes={"layout": LAYOUT_VERSION})


def _mixed_plan(
    store: Path, attrs: dict, sources: Sequence[str], count: int, pool_seed: int, seeds: Sequence[int]
) -> tuple[dict[str, str], dict[int, tuple[np.ndarray, np.ndarray]]]:
    """Source hashes and each seed's (source, index) arrays."""
    groups = [open_source(store, attrs, name) for name in sources]
    sizes = [cast(int, g.attrs["N"]) for g in groups]
    hashes = {name: cast(str, g.attrs["config_hash"]) for name, g in zip(sources, groups, strict=True)}
    try:
        drawn = {seed: draw_mixed(sizes, count, pool_seed, seed) for seed in seeds}
    except ValueError as exc:
        detail = ", ".join(f"{name} N = {size}" for name, size in zip(sources, sizes, strict=True))
        raise SplitError(f"{store}: mixed dictionary of {count} templates from {len(sources)} source(s) "
                         f"({detail}): {exc}") from None
    return hashes, drawn


def draw_splits(
    store: str | Path,
    seeds: Sequence[int] | None = None,
    sizes: SplitSizes | None = None,
    sources: Sequence[str] | None = None,
    mixed: bool | None = None,
) -> DrawResult:
    """Draw (or confirm) the splits of a complete store for several seeds.

    Args:
        store: the target store ``NAME.zarr``.
        seeds: split seeds (default: the store's recorded ``split_seeds``).
        sizes: split sizes (default: the recorded ones). For a poses dataset only
            the dictionary size may differ from the poses' train/test partition.
        sources: mixed-dictionary source datasets (default: the recorded ones).
        mixed: True: the mixed dictionary is required (missing sources are an
            error); False: never drawn; None: drawn when every source store exists.

    Returns:
        which seeds were written and which were already up to date.

    Raises:
        SplitError: a bad seed, sizes larger than the pool, a missing or
            incompatible source store (when required); nothing is written then.
        StoreLocked: another process is writing the store.
    """
    store = Path(store)
    open_store(store, writer=True)  # a missing store is named as such, before any lock file is made beside it
    with store_lock(store), resealing(store) as begin:
        for scratch in store.glob(".splits-tmp-*"):  # a killed drawer's; none is at work under the lock
            shutil.rmtree(scratch, ignore_errors=True)
        return _draw_locked(store, seeds, sizes, sources, mixed, begin)


def _draw_locked(store: Path, seeds: Sequence[int] | None, sizes: SplitSizes | None,
                 sources: Sequence[str] | None, mixed: bool | None, begin: Callable[[], None]) -> DrawResult:
    """:func:`draw_splits`' work, under the store's lock; ``begin`` before the first write (:func:`resealing`)."""
    group = open_store(store, writer=True)
    spec = store_spec(group, store)
    seeds = tuple(spec.split_seeds if seeds is None else seeds)
    sizes = sizes or spec.splits
    sources = tuple(spec.mixed_sources if sources is None else sources)
    attrs: dict[str, Any] = dict(group.attrs)
    pool_size, pool_seed = cast(int, attrs["N"]), cast(int, attrs["seed"])
    fixed = _fixed_sets(group)
    _check_request(store, seeds, sizes, fixed)
    try:
        sets = {seed: draw_indices(pool_size, sizes, pool_seed, seed, fixed, spec.own_dictionary) for seed in seeds}
    except ValueError as exc:
        raise SplitError(f"{store}: splits {sizes.train}/{sizes.test}/{sizes.dictionary}/{sizes.validation} "
                         f"(train/test/dictionary/validation) do not fit: {exc}") from None
    note, hashes, mixed_arrays = _plan_mixed(store, attrs, sources, mixed, sizes.dictionary, seeds)

    drawn, unchanged = [], []
    for seed in seeds:
        has_mixed = seed in mixed_arrays
        recipe = {
            "seed": int(seed), "pool_seed": pool_seed, "pool_config_hash": attrs["config_hash"], "N": pool_size,
            "sizes": {name: len(index) for name, index in sets[seed].items()},
            "fixed": sorted(fixed), "mixed_sources": list(sources) if has_mixed else [],
            "mixed_source_config_hash": hashes if has_mixed else {},
            "mixed_size": len(mixed_arrays[seed][1]) if has_mixed else 0,
        }
        recorded = _recorded_recipe(store, seed)
        if recorded == recipe:
            unchanged.append(seed)
            continue
        _warn_if_resized(store, seed, recorded, recipe)
        begin()
        _ensure_splits_group(store)
        mixed_part = (*mixed_arrays[seed], _mixed_attrs(sources, hashes)) if has_mixed else None
        _write_seed(store, seed, recipe, sets[seed], mixed_part)
        drawn.append(seed)
    return DrawResult(store, tuple(drawn), tuple(unchanged), note, _render_used(store, begin))


def _render_used(store: Path, begin: Callable[[], None]) -> int:
    """Render the images the drawn splits use and an ``images: splits`` store lacks (:mod:`synthcal.generate.images`).

    The store's own splits under its lock (held by the caller, with ``begin`` of its
    :func:`resealing` block); a mixed dictionary's templates in their source stores,
    each under its own lock, each resealed.
    """
    count = render_missing_images(store, begin=begin)
    group = zarr.open_group(zarr.storage.LocalStore(store, read_only=True), mode="r", zarr_format=3)
    for source, indices in mixed_uses(store, group).items():
        if source.resolve() == store.resolve() or not (source / "zarr.json").is_file():
            continue
        if image_mode(zarr.open_group(zarr.storage.LocalStore(source, read_only=True), mode="r").attrs) == "splits":
            with store_lock(source), resealing(source) as begin_source:
                count += render_missing_images(source, indices, begin_source)
    return count


class SplitsResized(UserWarning):
    """A seed's splits were replaced by sets of other sizes (results on the old ones no longer match)."""


def _sizes_text(recipe: dict[str, Any], only: Sequence[str] | None = None, mixed: bool = True) -> str:
    """``train 24, test 8, dictionary 12`` (and, if ``mixed``, the mixed dictionary's size) of a recorded
    recipe (of the splits ``only`` names, if given)."""
    sizes = {k: v for k, v in (recipe.get("sizes") or {}).items() if only is None or k in only}
    if mixed and recipe.get("mixed_size"):
        sizes["mixed dictionary"] = recipe["mixed_size"]
    return ", ".join(f"{name} {size}" for name, size in sizes.items())


def _warn_if_resized(store: Path, seed: int, recorded: dict[str, Any] | None, recipe: dict[str, Any]) -> None:
    """Warn when a seed's existing splits are about to be replaced by sets of other sizes."""
    if recorded is None:
        return
    # a validation set or a mixed dictionary added beside unchanged sets leaves every earlier result valid
    kept, had_mixed = [*(recorded.get("sizes") or {})], bool(recorded.get("mixed_size"))
    before, after = _sizes_text(recorded, kept, had_mixed), _sizes_text(recipe, kept, had_mixed)
    if before != after:
        warnings.warn(SplitsResized(f"{store}: seed {seed}: replacing its splits ({before}) with {after}; results "
                                    f"computed on the old splits no longer match them"), stacklevel=4)


def _check_request(store: Path, seeds: Sequence[int], sizes: SplitSizes, fixed: dict[str, np.ndarray]) -> None:
    """Seeds are integers ≥ 0 and the sizes keep a poses dataset's fixed train/test sets."""
    if any(not isinstance(s, (int, np.integer)) or s < 0 for s in seeds):
        raise SplitError(f"{store}: split seeds must be integers ≥ 0 (value {list(seeds)})")
    for name, index in fixed.items():
        if getattr(sizes, name) != len(index):
            carved = " (validation included: it is carved from it)" if name == "train" else ""
            raise SplitError(f"{store}: splits.{name}: the poses fix {name} at {len(index)} samples{carved} "
                             f"(value {getattr(sizes, name)})")


def _plan_mixed(
    store: Path, attrs: dict[str, Any], sources: tuple[str, ...], mixed: bool | None, count: int,
    seeds: Sequence[int],
) -> tuple[str | None, dict[str, str], dict[int, tuple[np.ndarray, np.ndarray]]]:
    """Whether and what mixed dictionary to draw (see :func:`draw_splits`'s ``mixed``).

    Returns:
        a note when it is left out for missing source stores (else None), the
        sources' config hashes and each seed's (source, index) arrays (both empty
        when none is drawn).

    Raises:
        SplitError: required but without sources, or a source store unusable.
    """
    if sources and mixed is not False:
        missing = [str(source_store_path(store, s)) for s in sources if not source_store_path(store, s).exists()]
        if missing and mixed is None:
            return (f"{store}: mixed dictionary not drawn: source store(s) {', '.join(missing)} missing; "
                    f"generate them, then run `synthcal split {store}`"), {}, {}
        hashes, arrays = _mixed_plan(store, attrs, sources, count, cast(int, attrs["seed"]), seeds)
        return None, hashes, arrays
    if mixed and not sources:
        raise SplitError(f"{store}: dataset {attrs['dataset']!r} has no mixed-dictionary sources "
                         f"(mixed_dictionaries / dictionary_from in datasets.yaml)")
    return None, {}, {}


def _mixed_attrs(sources: tuple[str, ...], hashes: dict[str, str]) -> dict[str, Any]:
    """Attributes of a seed's ``mixed_dictionary`` group."""
    return {
        "sources": list(sources),
        "stores": [f"../{source}.zarr" for source in sources],
        "source_config_hash": hashes,
        "homography_frame": _HOMOGRAPHY_FRAME,
    }


def _recorded_recipe(store: Path, seed: int) -> dict | None:
    path = store / "splits" / f"seed-{seed}"
    if not (path / "zarr.json").is_file():
        return None
    return dict(zarr.open_group(zarr.storage.LocalStore(path, read_only=True), mode="r").attrs)


