"""Rendering the missing RGB images of an ``images: splits`` store (:mod:`synthcal.store.images`).

Called by :func:`synthcal.generate.splits.draw_splits` under the store's lock, after
the seeds are written: every sample some drawn split uses (train, test, dictionary
of every seed; for a mixed dictionary, its templates in their source stores) gets
its image, rendered by :func:`synthcal.generate.pipeline.render_samples` from the
stored homography and the sample's own appearance stream — the bytes a full
render (``images: all``) gives.

Order, so that a killed run resumes: the ``images`` attribute's state becomes
``rendering``; then shard by shard the ``image`` shard file is rewritten whole
(the images it held, read back, plus the new ones; atomically) and then
``image_rendered`` marks the new samples; last, the state returns to ``complete``
and the caller's :func:`synthcal.store.resealing` block reseals the manifest (whose
``begin`` marks it ``writing`` before the first byte changes). A rerun renders what
``image_rendered`` does not mark (at most one shard again) and reseals. Images that no split uses any more (a seed redrawn with other sizes) stay.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import zarr

from synthcal.generate.pipeline import load_scene, render_samples
from synthcal.store import (
    STORED_SPLITS,
    array_at,
    attributes,
    drawn_seeds,
    group_at,
    image_layouts,
    manifest,
    store_spec,
)
from synthcal.store.images import IMAGES_ATTR, PRESENCE_ARRAY, images_attribute, images_rendering, rendered_mask
from synthcal.store.shards import ShardLayout, read_rows, write_shard
from synthcal.store.splits import source_store_path

__all__ = ["used_indices", "mixed_uses", "render_missing_images"]


def used_indices(group: zarr.Group) -> np.ndarray:
    """Ascending pool indices that the store's own splits (every seed) use."""
    parts = [np.zeros(0, np.int64)]
    for seed in drawn_seeds(group):
        seed_group = group_at(group, f"splits/seed-{seed}")
        parts += [np.asarray(array_at(seed_group, name)[:], np.int64) for name in STORED_SPLITS if name in seed_group]
    return np.unique(np.concatenate(parts))


def _config_hash(store: Path) -> str | None:
    """A store's ``config_hash`` attribute (None: no store there)."""
    if not (store / "zarr.json").is_file():
        return None
    value = zarr.open_group(zarr.storage.LocalStore(store, read_only=True), mode="r", zarr_format=3).attrs.get(
        "config_hash")
    return str(value) if value is not None else None


def mixed_uses(store: Path, group: zarr.Group) -> dict[Path, np.ndarray]:
    """Source store → ascending indices that the store's mixed dictionaries (every seed) take from it.

    Only sources present with the pool (``config_hash``) the dictionary was drawn from.
    """
    uses: dict[Path, list[np.ndarray]] = {}
    for seed in drawn_seeds(group):
        seed_group = group_at(group, f"splits/seed-{seed}")
        if "mixed_dictionary" not in seed_group:
            continue
        sub = group_at(seed_group, "mixed_dictionary")
        source = np.asarray(array_at(sub, "source")[:])
        index = np.asarray(array_at(sub, "index")[:], np.int64)
        attrs = attributes(sub)  # JSON: sources (names) and source_config_hash (name → hash)
        for k, name in enumerate(attrs["sources"]):
            path = source_store_path(store, str(name))
            if _config_hash(path) == attrs["source_config_hash"].get(name):
                uses.setdefault(path, []).append(index[source == k])
    return {path: np.unique(np.concatenate(parts)) for path, parts in uses.items()}


def _render_shard(layout: ShardLayout, image: zarr.Array, shard: int, new: np.ndarray, held: np.ndarray,
                  render: Callable[[np.ndarray], np.ndarray]) -> None:
    """Rewrite one ``image`` shard file: the images it held (``held``) read back, plus ``new`` rendered."""
    start = shard * layout.shard_size
    rows = np.arange(start, min(start + layout.shard_size, image.shape[0]))
    samples = np.zeros((len(rows), *layout.sample_shape), np.uint8)
    if len(held):
        samples[held - start] = read_rows(image, held, threads=1)
    samples[new - start] = render(new)
    write_shard(layout, shard, samples)


def render_missing_images(store: str | Path, wanted: np.ndarray | None = None,
                          begin: Callable[[], None] | None = None) -> int:
    """Render the images of ``wanted`` (default: :func:`used_indices`) that the store lacks.

    The caller holds the store's lock and reseals its manifest afterwards
    (:func:`synthcal.store.resealing`, whose ``begin`` is called before anything is
    written). An ``images: all`` store is left alone.

    Returns:
        the number of images rendered.
    """
    store = Path(store)
    group = zarr.open_group(zarr.storage.LocalStore(store), mode="r+", zarr_format=3)
    mask = rendered_mask(group)
    if mask is None:
        return 0
    wanted = used_indices(group) if wanted is None else np.unique(np.asarray(wanted, np.int64))
    missing = wanted[~mask[wanted]]
    if not len(missing) and not images_rendering(group.attrs):
        return 0
    spec = store_spec(group, store)
    if begin is not None:
        begin()
    group.attrs[IMAGES_ATTR] = images_attribute(int(mask.sum()), "rendering")
    image, presence = array_at(group, "image"), array_at(group, PRESENCE_ARRAY)
    homography = array_at(group, "homography")
    layout = image_layouts(store)["image"]
    scene = load_scene(spec)

    def render(indices: np.ndarray) -> np.ndarray:
        return render_samples(scene, read_rows(homography, indices, threads=1), 0, spec, indices=indices)[0]

    size = layout.shard_size
    for shard in np.unique(missing // size).tolist():
        new = missing[missing // size == shard]
        held = np.flatnonzero(mask[shard * size:(shard + 1) * size]) + shard * size
        _render_shard(layout, image, shard, new, held, render)
        mask[new] = True
        presence[:] = mask.astype(np.uint8)
    updates = {IMAGES_ATTR: images_attribute(int(mask.sum()))}
    if isinstance(recorded := group.attrs.get("manifest"), dict):  # synthcal-store/2 lists its image files there
        updates["manifest"] = {**recorded, "image": manifest(store, ("image",))["image"]}
    group.attrs.update(updates)
    return len(missing)
