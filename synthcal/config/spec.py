"""A dataset's resolved configuration (:class:`DatasetSpec`) and its hash.

The resolved configuration is the dataset entry with the file's ``defaults`` filled
in and a *profile* (``smoke``, ``quick``, ``paper``) applied
(:meth:`synthcal.config.load.LoadedConfig.resolve`); its hash is recorded in every
store it produces.
"""

from __future__ import annotations

import hashlib
import json
import zlib
from typing import Any

from synthcal.config.schema import AppearanceConfig, GridConfig, SplitSizes, StrictModel, UserSceneConfig
from synthcal.config.vocabulary import Images

__all__ = ["DatasetSpec"]


class DatasetSpec(StrictModel):
    """Everything that determines a generated store's arrays, and its splits.

    ``grid`` is None for a dataset of given ``poses``. ``mixed_sources`` lists the
    datasets whose pools give the mixed dictionary (empty: none);
    ``own_dictionary`` is False when the dictionary comes only from them
    (``dictionary_from``).

    ``seed`` is the configured seed: the dataset's own ``seed:`` if it has one
    (``seed_from_name`` False: the pool is drawn from it as is), else the file's
    ``defaults.seed``, which :attr:`pool_entropy` combines with the dataset's name
    so that every dataset draws an independent pool (SPEC §6); ``pool_name`` (a
    dataset's ``same_pool_as``), when set, is the name combined instead, so the pool
    is that dataset's.
    ``min_field_fraction`` > 0 redraws cameras whose semantic map has fewer
    non-background pixels than that fraction (:mod:`synthcal.generate.pipeline`).
    """

    name: str
    scene: str
    user_scene: UserSceneConfig | None
    grid: GridConfig | None
    poses: str | None = None
    pool_size: int
    seed: int
    seed_from_name: bool = True
    min_field_fraction: float = 0.0
    image_size: tuple[int, int]
    focal_reference_width: int
    shard_size: int
    supersample: int
    appearance: AppearanceConfig
    splits: SplitSizes
    split_seeds: tuple[int, ...]
    mixed_sources: tuple[str, ...] = ()
    own_dictionary: bool = True
    images: Images = "all"
    pool_name: str | None = None

    def stored_config(self) -> dict[str, Any]:
        """The ``config`` attribute a store records: ``images`` left out when ``all``
        and ``pool_name`` when None (stores of the defaults stay byte-identical to those made before the options)."""
        return self.model_dump(mode="json", exclude=self._unset_options())

    def _unset_options(self) -> set[str]:
        """Options left out of the stored config and the hash at their defaults (older stores keep theirs)."""
        unset = {"images"} if self.images == "all" else set()
        return unset | ({"pool_name"} if self.pool_name is None else set())

    def config_hash(self) -> str:
        """SHA-256 of the canonical JSON of what determines the pool's arrays.

        Split sizes, seeds and dictionary sources are left out: splits are drawn
        later, inside the store, and changing them must not invalidate a generated
        pool. ``poses`` is left out when unset, so grid datasets keep their hash;
        ``images`` when ``all`` and ``pool_name`` when None, so default stores keep theirs.
        A store records the hash of the spec whose relative grid is made absolute
        at the scene's anchor (``synthcal.generate.pipeline.anchored_spec``).
        """
        exclude = {"splits", "split_seeds", "mixed_sources", "own_dictionary"}
        if self.poses is None:
            exclude.add("poses")
        exclude |= self._unset_options()
        pool = self.model_dump(mode="json", exclude=exclude)
        text = json.dumps(pool, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def pool_entropy(self) -> int | tuple[int, int]:
        """The ``numpy.random.SeedSequence`` entropy of the pool's random streams.

        ``(seed, zlib.crc32(name.encode()))`` (``name``: :attr:`pool_name` when set) — stable across runs, machines and
        Python versions (unlike ``hash``) — or, for a dataset with its own
        ``seed:``, that seed as is. The cameras are drawn with
        ``SeedSequence(pool_entropy, spawn_key=(0,))`` and sample ``i``'s
        appearance with ``spawn_key=(1, i)``.
        """
        name = self.name if self.pool_name is None else self.pool_name
        return (self.seed, zlib.crc32(name.encode())) if self.seed_from_name else self.seed

    def pool_seed_attributes(self) -> dict[str, Any]:
        """How the pool's seed was derived, as recorded in the store's ``pool_seed`` attribute."""
        entropy = self.pool_entropy
        rule = ("numpy.random.SeedSequence([seed, zlib.crc32(dataset.encode())])" if self.seed_from_name
                else "numpy.random.SeedSequence(seed): the dataset's own seed, as is")
        if self.pool_name is not None:
            rule = rule.replace("dataset.encode()", f"{self.pool_name!r}.encode()") + " (same_pool_as)"
        return {"seed": self.seed, "entropy": list(entropy) if isinstance(entropy, tuple) else entropy,
                "rule": rule, "from_name": self.seed_from_name}
