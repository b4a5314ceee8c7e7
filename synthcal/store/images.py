"""Which RGB images a store holds: every sample's (``images: all``) or the drawn splits' (``images: splits``).

A store generated with ``images: splits`` holds semantic maps, homographies and
cameras for every pool sample, but an RGB image only for the samples that some
drawn split uses (train, test, dictionary of any seed, and the samples a mixed
dictionary takes from this store). Drawing splits renders the missing images
(:mod:`synthcal.generate.images`).

Record (absent from an ``images: all`` store, which stays byte-identical to one
made before the option existed):

* the group attribute ``images``: ``{"mode": "splits", "rendered": <count>,
  "state": "complete" | "rendering"}`` (``rendering`` while images are being
  added; the store's manifest says ``writing`` meanwhile, and the renderer reseals
  it when it finishes — a ``synthcal-store/2`` store's manifest attribute has its
  ``image`` entry rewritten instead, and is not held to it while ``rendering``);
* the array ``image_rendered``: (N,) uint8, 1 where sample ``i``'s image was
  rendered — one chunk, ending in the ``crc32c`` codec like every array. A
  rendered image that happens to be all black is stored as no chunk at all
  (Zarr's fill value), so chunk presence alone could not tell it from a missing one.

Reading the image of a sample that was never rendered raises :class:`ImagesNotRendered`,
whose message gives the command that renders it — never zeros.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import zarr

from synthcal.store.errors import StoreError

__all__ = ["IMAGES_ATTR", "PRESENCE_ARRAY", "ImagesNotRendered", "image_mode", "images_rendering", "rendered_mask",
           "check_rendered", "images_attribute"]

IMAGES_ATTR = "images"
PRESENCE_ARRAY = "image_rendered"


class ImagesNotRendered(StoreError):
    """An ``images: splits`` store asked for images it never rendered."""


def image_mode(attrs: Any) -> str:
    """``"all"`` or ``"splits"`` from a store's attributes (a mapping)."""
    entry = attrs.get(IMAGES_ATTR)
    return str(entry.get("mode", "all")) if isinstance(entry, dict) else "all"


def images_rendering(attrs: Any) -> bool:
    """Whether images were being added to an ``images: splits`` store when its writer stopped (or still is)."""
    entry = attrs.get(IMAGES_ATTR)
    return isinstance(entry, dict) and entry.get("state") == "rendering"


def images_attribute(rendered: int, state: str = "complete") -> dict[str, Any]:
    """The ``images`` attribute of an ``images: splits`` store."""
    return {"mode": "splits", "rendered": int(rendered), "state": state}


def rendered_mask(group: zarr.Group) -> np.ndarray | None:
    """(N,) bool: which samples' images a store holds; None for an ``images: all`` store (all of them)."""
    if image_mode(group.attrs) != "splits":
        return None
    node = group[PRESENCE_ARRAY]
    if not isinstance(node, zarr.Array):
        raise StoreError(f"{group.store_path}/{PRESENCE_ARRAY}: a group where an array is expected")
    return np.asarray(node[:]).astype(bool)


def check_rendered(group: zarr.Group, index: np.ndarray, store: str | Path | None = None) -> None:
    """Raise unless every sample at ``index`` has its image in the store.

    Raises:
        ImagesNotRendered: names how many (and the first few) samples lack their
            image, and the ``synthcal split`` command that renders them.
    """
    mask = rendered_mask(group)
    if mask is None:
        return
    index = np.asarray(index, np.int64)
    missing = np.unique(index[~mask[index]]) if len(index) else index
    if not len(missing):
        return
    root = getattr(group.store_path.store, "root", None)
    where = store if store is not None else Path(root, group.store_path.path) if root is not None else group.store_path
    shown = ", ".join(str(i) for i in missing[:5]) + (", …" if len(missing) > 5 else "")
    raise ImagesNotRendered(
        f"{where}: the images of {len(missing)} sample(s) ({shown}) were never rendered: the store keeps images "
        f"only for drawn splits (images: splits); draw the splits that use them with "
        f"`synthcal split {where} --seeds …`, which renders them (a mixed dictionary's templates: "
        f"`synthcal split` of the store whose dictionary they are)")
