"""Splits of a store as PyTorch-style datasets (SPEC §6, §9); torch is imported by the first item read.

>>> import tempfile, synthcal
>>> tmp = tempfile.TemporaryDirectory()
>>> train = load_split(synthcal.generate_store("intersection-1", tmp.name, profile="smoke"), "train", seed=0)
>>> image, semantic, H = train[0]
>>> image.shape, image.dtype, semantic.dtype, H.shape     # the paper profile's images: (3, 144, 256)
(torch.Size([3, 36, 64]), torch.float32, torch.int64, torch.Size([3, 3]))
>>> tmp.cleanup()

A split is read once, shard by shard in sorted index order, decoded straight into
its arrays (:mod:`synthcal.store.shards`: 50–130× faster than zarr-python's
orthogonal selection, measured by ``benchmarks/zarr_baseline.py``), and held in
memory as NumPy arrays, so items cost no I/O and the object pickles for
``DataLoader(num_workers=…)``.

Items: ``image`` (3, H, W) float32 in [0, 1] (converted per item: the arrays stay
uint8), ``semantic`` (H, W) int64 class ids, ``homography`` (3, 3) float64 mapping
the bird's-eye frame of the sample's *own* scene to the image (SPEC §2).

Estimators use the arrays directly: ``.images`` (K, H, W, 3) uint8, ``.semantics``
(K, H, W) uint8, ``.homographies`` (K, 3, 3) float64, ``.indices`` (K,) int64 pool
indices, ``.store`` (the target store's path) and ``.scene`` (the target's
bird's-eye image, semantic map, palette and classes, read from ``scene/``). A mixed
dictionary also has ``.sources`` (source dataset names), ``.source`` (K,) int64
positions into ``.sources``, ``.source_stores`` and, per source, ``.source_scenes``:
**its homographies map the source scene's frame, not the target's.**
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import zarr

from synthcal.store import array_at, attributes, open_store, read_samples
from synthcal.store.splits import (
    SPLIT_NAMES,
    STORED_SPLITS,
    SplitError,
    dictionary_is_mixed,
    read_mixed_dictionary,
    read_mixed_samples,
    read_split_indices,
)

if TYPE_CHECKING:
    import torch

__all__ = ["StoreScene", "SplitDataset", "load_split", "load_splits", "read_scene"]


@dataclass(frozen=True)
class StoreScene:
    """The bird's-eye scene a store was rendered from (its ``scene/`` arrays).

    Attributes:
        name: scene name.
        image: (Hs, Ws, 3) uint8 RGB.
        semantic: (Hs, Ws) uint8 class ids.
        palette: (4, 3) uint8 display colours.
        classes: class names, index = class id.
        heading_deg, pixels_per_metre: as in the scene.
    """

    name: str
    image: np.ndarray
    semantic: np.ndarray
    palette: np.ndarray
    classes: tuple[str, ...]
    heading_deg: float
    pixels_per_metre: float


def read_scene(store: str | Path, group: zarr.Group | None = None) -> StoreScene:
    """The scene stored in a store (``scene/image``, ``scene/semantic``, attributes).

    ``group``: the store as the caller opened it (:func:`synthcal.store.open_store`),
    which saves opening it and checking its manifest again.
    """
    group = open_store(store) if group is None else group
    attrs = attributes(group)["scene"]
    return StoreScene(
        name=str(attrs["name"]), image=np.asarray(array_at(group, "scene/image")[:]),
        semantic=np.asarray(array_at(group, "scene/semantic")[:]),
        palette=np.asarray(attrs["palette"], np.uint8), classes=tuple(attrs["classes"]),
        heading_deg=float(attrs["heading_deg"]), pixels_per_metre=float(attrs["pixels_per_metre"]),
    )


class SplitDataset:
    """One split held in memory; items are ``(image, semantic, homography)`` tensors.

    A map-style dataset (``len`` and integer indexing), which is all
    ``torch.utils.data.DataLoader`` asks of one. It does not derive from torch's
    ``Dataset`` so that loading a split imports no torch: estimators that use the
    arrays alone (and the harness's process for each run) skip its seconds of import;
    torch is imported by the first item read.

    Attributes:
        images: (K, H, W, 3) uint8.
        semantics: (K, H, W) uint8.
        homographies: (K, 3, 3) float64, bird's-eye (of the sample's scene) → image.
        indices: (K,) int64 pool indices (in the source stores for a mixed dictionary).
        store: the target store.
        split, seed: which split.
        scene: the target store's scene.
        mixed: whether this is a mixed dictionary.
        sources, source, source_stores: a mixed dictionary's provenance (else
            ``()``, None, ``()``).
        pool: whether this is a pool dictionary (:mod:`synthcal.data.pool`: its
            arrays are lazy :class:`synthcal.data.pool.LazyRows`, read on access).

    Example:
        >>> import tempfile, synthcal
        >>> from torch.utils.data import DataLoader
        >>> tmp = tempfile.TemporaryDirectory()
        >>> train = synthcal.load_split(synthcal.generate_store("intersection-1", tmp.name, profile="smoke"), "train")
        >>> images, semantics, H = next(iter(DataLoader(train, batch_size=8)))
        >>> tuple(images.shape), tuple(semantics.shape), tuple(H.shape)
        ((8, 3, 36, 64), (8, 36, 64), (8, 3, 3))
        >>> tmp.cleanup()
    """

    def __init__(
        self,
        arrays: Mapping[str, Any],
        indices: np.ndarray,
        store: Path,
        split: str,
        seed: int,
        scene: StoreScene,
        sources: tuple[str, ...] = (),
        source: np.ndarray | None = None,
        source_stores: tuple[Path, ...] = (),
        pool: bool = False,
    ) -> None:
        self.images = arrays["image"]
        self.semantics = arrays["semantic"]
        self.homographies = arrays["homography"]
        self.indices = indices
        self.store = store
        self.split = split
        self.seed = seed
        self.scene = scene
        self.sources = sources
        self.source = source
        self.source_stores = source_stores
        self.pool = pool

    @property
    def mixed(self) -> bool:
        return bool(self.sources)

    @property
    def source_scenes(self) -> dict[str, StoreScene]:
        """Each source's scene (read on demand): the frame of its templates' homographies."""
        return {name: read_scene(path) for name, path in zip(self.sources, self.source_stores, strict=True)}

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, k: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        import torch

        image = torch.from_numpy(self.images[k]).permute(2, 0, 1).float().div_(255.0)
        semantic = torch.from_numpy(self.semantics[k].astype(np.int64))
        return image, semantic, torch.from_numpy(self.homographies[k].copy())

    def __repr__(self) -> str:
        kind = f"mixed from {', '.join(self.sources)}" if self.mixed else "whole pool" if self.pool else "own pool"
        return f"SplitDataset({self.store.name}, {self.split}, seed {self.seed}, {len(self)} samples, {kind})"


def load_split(
    store: str | Path, split: str, seed: int, mixed: bool | None = None, scene: StoreScene | None = None
) -> SplitDataset:
    """Load one split of a store into memory.

    Args:
        store: the dataset's store ``NAME.zarr``.
        split: ``train``, ``test``, ``dictionary`` or ``validation``.
        seed: the split seed (drawn by ``synthcal split``).
        mixed: for ``dictionary``: True loads the mixed dictionary (templates from
            the source stores beside this one), False the store's own; None (the
            default) the own one, or the mixed one for a dataset without an own
            dictionary (``dictionary_from``, e.g. ``worldcup2014``).
        scene: the store's scene when already read (saves reading it again).

    Returns:
        the split as a :class:`SplitDataset`.

    Raises:
        SplitError: unknown split or seed, ``mixed`` for train/test, a missing
            or changed source store; the message names store, key and value.
    """
    store = Path(store)
    if split not in STORED_SPLITS:
        raise SplitError(f"{store}: unknown split {split!r}; known: {', '.join(STORED_SPLITS)}")
    if mixed and split != "dictionary":
        raise SplitError(f"{store}: mixed=True: only the dictionary can be mixed (split {split!r})")
    group = open_store(store)  # once per call: the manifest check costs a stat per shard file
    mixed = split == "dictionary" and dictionary_is_mixed(group, store, mixed)
    scene = scene or read_scene(store, group)
    if mixed:
        templates = read_mixed_dictionary(store, seed)
        arrays = read_mixed_samples(templates)
        return SplitDataset(arrays, templates.index, store, split, seed, scene,
                            templates.sources, templates.source, templates.stores)
    indices = read_split_indices(store, split, seed, group)
    return SplitDataset(read_samples(group, indices), indices, store, split, seed, scene)


def load_splits(store: str | Path, seed: int, mixed: bool | None = None) -> dict[str, SplitDataset]:
    """``train``, ``test`` and ``dictionary`` of one seed (``mixed`` as in :func:`load_split`)."""
    scene = read_scene(store)
    return {split: load_split(store, split, seed, mixed if split == "dictionary" else False, scene)
            for split in SPLIT_NAMES}
