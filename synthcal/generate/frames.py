"""``synthcal import``: a folder of real annotated frames → a store like any other (SPEC §4, *Real frames*).

Layouts
-------
* ``wc14``, the World Cup 2014 release: ``train_val/`` and ``test/``, each with
  ``N.jpg`` and ``N.homographyMatrix`` (a 3 × 3 text matrix: pitch **yards** → pixels
  of that frame; the bundled ``synthcal/data/wc14`` annotations are the same
  matrices); ``N_grass_gt.mat`` and other files are ignored. Scene ``soccer`` only.
* ``plain``: ``NAME.jpg`` or ``NAME.png`` beside ``NAME.homography.txt``, a 3 × 3 text
  matrix mapping a **bird's-eye pixel of the scene** to a pixel of that frame, at the
  frame's own resolution (any sign and scale). Other files are ignored.

Frames are ordered by name (numbers numerically), a frame's matrix is composed into
the scene's bird's-eye frame and the store's image size::

    H = S · M · A

``A`` the soccer scene's bird's-eye pixel → yard map for ``wc14``
(:func:`~synthcal.generate.worldcup.bird_eye_to_yards`, the ``worldcup2014``
conversion), the identity for ``plain``; ``S`` the frame → image scaling with the
pixel-centre rule (:func:`~synthcal.generate.worldcup.frame_scaling`, anisotropic
when the frame's aspect ratio differs); then the depth sign and the camera scale
(:func:`~synthcal.generate.worldcup.camera_scaled`). The ``image`` is the frame
resized to the image size (``cv2.INTER_AREA`` when shrinking, else bilinear; no
photometric change), the ``semantic`` map is the scene rendered through ``H``
(:func:`~synthcal.generate.render.render_semantic`, cheirality-masked), the camera
fields are fitted to ``H`` as for ``worldcup2014`` (they describe the camera; ``H``
is the truth), ``grid_index`` −1.

Splits: the train/test sets are fixed, the same for every seed, as for given poses:
``train_val/`` → train, ``test/`` → test; for ``plain``, a share of the frames drawn
once with ``SeedSequence(pool_entropy, spawn_key=(5,))`` is the test set. The store
holds the train frames first, then the test frames (attribute ``poses``: partition,
image names, per-file digests). The dictionary comes from synthetic pools
(``dictionary_from``), beside the store, when ``synthcal split`` draws the splits.

Bad input (a matrix that is unreadable, not 3 × 3, non-finite or singular; an image
that does not decode; a frame without its matrix or a matrix without its frame) is
refused in one line naming up to 10 files, before anything is written. The same
folder and settings give the same store, byte for byte: its ``config_hash`` covers
the settings and every input file's SHA-256.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from synthcal.config import (
    BUILTIN_SCENE_NAMES,
    AppearanceConfig,
    ConfigError,
    DatasetSpec,
    LoadedConfig,
    SplitSizes,
    check_dataset_name,
)
from synthcal.generate.pipeline import foreground_attribute, load_scene, seal_store, store_attributes, store_path
from synthcal.generate.render import render_semantic
from synthcal.generate.worldcup import bird_eye_to_yards, camera_fields, camera_scaled, frame_scaling
from synthcal.store import CAMERA_FIELDS, create_store, image_layouts, store_lock, write_samples
from synthcal.store.format import open_group
from synthcal.utils.atomic import remove_temporaries

__all__ = ["LAYOUTS", "FrameError", "Frame", "FrameSet", "read_frames", "frame_homographies", "frame_images",
           "frames_spec", "with_frames", "import_frames"]

LAYOUTS = ("wc14", "plain")
_WC14_PARTS = (("train", "train_val"), ("test", "test"))
_WC14_MATRIX = ".homographyMatrix"
_PLAIN_MATRIX = ".homography.txt"
_PLAIN_IMAGES = (".jpg", ".png")
_NAMED = 10  # offending files named in the error line
_SINGULAR = 1e-12  # smallest / largest singular value below which a matrix is singular


class FrameError(ConfigError):
    """A folder of frames that cannot be imported; the one-line message names the files."""


@dataclass(frozen=True)
class Frame:
    """One annotated frame.

    Attributes:
        image: the frame's image file.
        matrix: (3, 3) float64 annotation as read (``wc14``: yards → frame
            pixels; ``plain``: bird's-eye pixels → frame pixels).
        size: ``(width, height)`` of the frame.
        digest: SHA-256 of the image file's bytes, then the matrix file's.
    """

    image: Path
    matrix: np.ndarray
    size: tuple[int, int]
    digest: str


@dataclass(frozen=True)
class FrameSet:
    """A folder's frames in store order: train first, then test.

    Attributes:
        folder: the folder.
        layout: ``wc14`` or ``plain``.
        frames: the frames.
        partition: ``{"train": (0, n), "test": (n, N)}`` half-open ranges.
    """

    folder: Path
    layout: str
    frames: tuple[Frame, ...]
    partition: dict[str, tuple[int, int]]

    def attribute(self) -> dict:
        """The store's ``poses`` attribute (what ``split``, ``bench`` and ``info`` read: ``set``, ``partition``)."""
        return {
            "set": f"frames ({self.layout})",
            "partition": {part: list(bounds) for part, bounds in self.partition.items()},
            "image_names": [frame.image.relative_to(self.folder).as_posix() for frame in self.frames],
            "frame_sizes": [list(frame.size) for frame in self.frames],
            "digests": [frame.digest for frame in self.frames],
            "source": f"imported from folder {self.folder.name!r}, layout {self.layout!r}",
        }

    def digest(self) -> str:
        """SHA-256 of every frame's name and digest, in store order."""
        text = json.dumps([[name, frame.digest] for name, frame in
                           zip(self.attribute()["image_names"], self.frames, strict=True)])
        return hashlib.sha256(text.encode()).hexdigest()


def _natural_key(path: Path) -> tuple:
    """Names with numbers in numeric order: ``2.jpg`` before ``10.jpg``."""
    return tuple((0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", path.name))


def _pairs(folder: Path, layout: str) -> tuple[dict[str, list[tuple[Path, Path]]], list[str]]:
    """Image ↔ matrix files of each part (``all`` for ``plain``), and the unpaired ones as problems."""
    parts = _WC14_PARTS if layout == "wc14" else (("all", ""),)
    suffix = _WC14_MATRIX if layout == "wc14" else _PLAIN_MATRIX
    images = (".jpg",) if layout == "wc14" else _PLAIN_IMAGES
    pairs: dict[str, list[tuple[Path, Path]]] = {}
    problems = []
    for part, sub in parts:
        where = folder / sub
        if not where.is_dir():
            raise FrameError(f"{where}: no such folder (layout {layout!r} needs "
                             f"{' and '.join(s + '/' for _, s in parts)} in {folder})")
        files = sorted((p for p in where.iterdir() if p.is_file()), key=_natural_key)
        frames = {p.name[: -len(p.suffix)]: p for p in files if p.suffix.lower() in images}
        matrices = {p.name[: -len(suffix)]: p for p in files if p.name.endswith(suffix)}
        for stem in sorted(frames.keys() - matrices.keys()):
            problems.append(f"{frames[stem]} (no {stem}{suffix})")
        for stem in sorted(matrices.keys() - frames.keys()):
            problems.append(f"{matrices[stem]} (no image {stem}{'|'.join(images)})")
        pairs[part] = [(frames[s], matrices[s]) for s in sorted(frames.keys() & matrices.keys(),
                                                                  key=lambda s: _natural_key(Path(s)))]
        if not pairs[part] and not problems:
            raise FrameError(f"{where}: no frames (image with its {suffix} matrix) in layout {layout!r}")
    return pairs, problems


def _read_matrix(path: Path) -> tuple[np.ndarray | None, str]:
    """A 3 × 3 text matrix, or None and why not."""
    try:
        with warnings.catch_warnings():  # an empty file: numpy warns, then the shape check names it
            warnings.simplefilter("ignore", UserWarning)
            matrix = np.loadtxt(path, dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as exc:
        return None, f"unreadable matrix: {' '.join(str(exc).split()).split(';')[0][:80]}"
    if matrix.size == 0:
        return None, "empty matrix file"
    if matrix.shape != (3, 3):
        return None, f"a {' × '.join(map(str, matrix.shape))} matrix, expected 3 × 3"
    if not np.isfinite(matrix).all():
        return None, "non-finite matrix"
    singular = np.linalg.svd(matrix, compute_uv=False)
    if not singular[-1] > _SINGULAR * singular[0]:
        return None, "singular matrix"
    return matrix, ""


def _read_frame(image: Path, matrix_file: Path) -> tuple[Frame | None, list[str]]:
    """One frame checked whole (its image decoded), or the problems it has."""
    matrix, why = _read_matrix(matrix_file)
    problems = [f"{matrix_file} ({why})"] if matrix is None else []
    pixels = cv2.imread(str(image), cv2.IMREAD_COLOR)
    if pixels is None:
        problems.append(f"{image} (unreadable image)")
    if problems or matrix is None or pixels is None:
        return None, problems
    digest = hashlib.sha256(image.read_bytes() + b"\0" + matrix_file.read_bytes()).hexdigest()
    return Frame(image, matrix, (pixels.shape[1], pixels.shape[0]), digest), []


def read_frames(folder: str | Path, layout: str, test_fraction: float = 0.2,
                entropy: int | tuple[int, ...] = 0) -> FrameSet:
    """Read and check every frame of a folder (module docstring, *Layouts*).

    Args:
        folder: the folder.
        layout: ``wc14`` or ``plain``.
        test_fraction: ``plain``: share of the frames in the test set (at least one
            frame in each set).
        entropy: ``plain``: the ``SeedSequence`` entropy the test set is drawn with.

    Raises:
        FrameError: an unknown layout, a missing folder, no frames, or bad files
            (one line naming up to 10 of them).
    """
    folder = Path(folder)
    if layout not in LAYOUTS:
        raise FrameError(f"--layout: unknown layout {layout!r}; known: {', '.join(LAYOUTS)}")
    if not folder.is_dir():
        raise FrameError(f"{folder}: no such folder of frames")
    pairs, problems = _pairs(folder, layout)
    parts: dict[str, list[Frame]] = {}
    for part, files in pairs.items():
        parts[part] = []
        for image, matrix in files:
            frame, bad = _read_frame(image, matrix)
            problems += bad
            if frame is not None:
                parts[part].append(frame)
    if problems:
        more = f"; and {len(problems) - _NAMED} more" if len(problems) > _NAMED else ""
        raise FrameError(f"{folder}: {len(problems)} bad frame file(s): {'; '.join(problems[:_NAMED])}{more}")
    if layout == "plain":
        parts = _draw_test(parts["all"], test_fraction, entropy, folder)
    frames = (*parts["train"], *parts["test"])
    n_train = len(parts["train"])
    return FrameSet(folder, layout, frames, {"train": (0, n_train), "test": (n_train, len(frames))})


def _draw_test(frames: list[Frame], fraction: float, entropy: int | tuple[int, ...],
               folder: Path) -> dict[str, list[Frame]]:
    """The fixed train/test sets of a ``plain`` folder, each in name order."""
    if len(frames) < 2:
        raise FrameError(f"{folder}: {len(frames)} frame(s); a train and a test set need at least 2")
    if not 0 < fraction < 1:
        raise FrameError(f"--test-fraction: a share strictly between 0 and 1 (value {fraction!r})")
    count = min(max(round(fraction * len(frames)), 1), len(frames) - 1)
    rng = np.random.default_rng(np.random.SeedSequence(entropy, spawn_key=(5,)))
    test = set(rng.choice(len(frames), size=count, replace=False).tolist())
    return {"train": [f for k, f in enumerate(frames) if k not in test],
            "test": [f for k, f in enumerate(frames) if k in test]}


def frame_homographies(frames: FrameSet, image_size: tuple[int, int]) -> np.ndarray:
    """(N, 3, 3) float64 bird's-eye → image homographies at ``image_size`` (module docstring, ``H = S · M · A``)."""
    ground = bird_eye_to_yards() if frames.layout == "wc14" else np.eye(3)
    H = np.stack([frame_scaling(image_size, frame.size) @ frame.matrix @ ground for frame in frames.frames])
    return camera_scaled(H, image_size)


def frame_images(frames: FrameSet, image_size: tuple[int, int], start: int, stop: int) -> np.ndarray:
    """(stop − start, H, W, 3) uint8 RGB: frames ``start:stop`` resized to ``image_size``."""
    out = np.empty((stop - start, image_size[1], image_size[0], 3), np.uint8)
    for k, frame in enumerate(frames.frames[start:stop]):
        pixels = cv2.imread(str(frame.image), cv2.IMREAD_COLOR)
        if pixels is None:  # read_frames decoded it: it changed since
            raise FrameError(f"{frame.image}: unreadable image")
        shrink = image_size[0] <= frame.size[0] and image_size[1] <= frame.size[1]
        resized = cv2.resize(pixels, image_size, interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR)
        out[k] = cv2.cvtColor(resized, cv2.COLOR_BGR2RGB)
    return out


def frames_spec(config: LoadedConfig, name: str, scene: str, layout: str, profile: str | None = None,
                sources: tuple[str, ...] | None = None) -> DatasetSpec:
    """The resolved configuration of an import, before its frames are known (pool size 0).

    Image size, shard size and seeds come from the file's defaults and the profile, as
    for ``generate``; no appearance change is applied to real frames (recorded as
    zeros). The dictionary comes from ``sources`` (default: every grid dataset of the
    scene in the file), ``own_dictionary`` False, as the ``worldcup2014`` dataset's.

    Raises:
        ConfigError: a bad name, an unknown scene, profile or source, ``wc14`` on
            another scene than ``soccer``, or no source to take the dictionary from.
    """
    cfg = config.config
    check_dataset_name(name, "--name: ")
    if scene not in cfg.scenes and scene not in BUILTIN_SCENE_NAMES:
        raise FrameError(f"--scene: unknown scene {scene!r}; known: {', '.join((*BUILTIN_SCENE_NAMES, *cfg.scenes))}")
    if layout == "wc14" and scene != "soccer":
        raise FrameError(f"--scene: the wc14 layout's matrices map pitch yards, drawn by the 'soccer' scene "
                         f"(value {scene!r})")
    grids = [d for d, entry in cfg.datasets.items() if entry.grid is not None]
    if sources is None:
        sources = tuple(d for d in grids if cfg.datasets[d].scene == scene)
        if not sources:
            raise FrameError(f"--dictionary-from: no grid dataset of scene {scene!r} in {config.path} to take the "
                             f"dictionary from; name one")
    for source in sources:
        if source not in grids or source == name:
            raise FrameError(f"--dictionary-from: {source!r} is not a grid dataset of {config.path} other than "
                             f"--name (known: {', '.join(grids)})")
    prof, defaults = config.profile(profile), cfg.defaults
    return DatasetSpec(
        name=name, scene=scene, user_scene=cfg.scenes.get(scene), grid=None, poses=f"frames ({layout})",
        pool_size=0, seed=defaults.seed, image_size=prof.image_size or defaults.image_size,
        focal_reference_width=defaults.focal_reference_width, shard_size=prof.shard_size or defaults.shard_size,
        supersample=1, appearance=AppearanceConfig(brightness=0.0, contrast=0.0, blur_sigma=0.0, noise_sigma=0.0),
        splits=prof.splits or defaults.splits, split_seeds=defaults.split_seeds, mixed_sources=sources,
        own_dictionary=False,
    )


def with_frames(spec: DatasetSpec, frames: FrameSet, config: LoadedConfig, profile: str | None = None,
                dictionary: int | None = None) -> DatasetSpec:
    """``spec`` with the frames' pool and fixed train/test sizes.

    Args:
        dictionary: templates per seed (default: the profile's or defaults' dictionary
            size, at most the sources' pools together).
    """
    if dictionary is None:
        pools = sum(config.resolve(source, profile).pool_size for source in spec.mixed_sources)
        dictionary = min(spec.splits.dictionary, pools)
    if dictionary < 1:
        raise FrameError(f"--dictionary: a split size must be an integer ≥ 1 (value {dictionary})")
    sizes = {part: stop - start for part, (start, stop) in frames.partition.items()}
    return spec.model_copy(update={"pool_size": len(frames.frames),
                                   "splits": SplitSizes(**sizes, dictionary=dictionary)})


def import_frames(frames: FrameSet, spec: DatasetSpec, out_dir: str | Path) -> tuple[Path, bool]:
    """Write the store of checked frames (``spec``: :func:`with_frames` of :func:`frames_spec`).

    Returns:
        the store's path, and False when an identical store was already there.

    Raises:
        FrameError: a store of that name made from other frames or settings.
        StoreLocked: another process writes the store.
    """
    final = store_path(Path(out_dir), spec.name)
    scene = load_scene(spec)
    config_hash = hashlib.sha256(f"{spec.config_hash()} {frames.digest()}".encode()).hexdigest()
    final.parent.mkdir(parents=True, exist_ok=True)
    with store_lock(final):
        if final.exists():
            recorded = open_group(final).attrs.get("config_hash")
            if recorded != config_hash:
                raise FrameError(f"{final}: exists and was made from other frames or settings (config_hash "
                                 f"{str(recorded)[:12]}…); delete it or choose another --name or --out")
            return final, False
        H = frame_homographies(frames, spec.image_size)
        fitted = camera_fields(H, scene, spec.image_size, spec.focal_reference_width)
        camera = {name: fitted[name] for name in CAMERA_FIELDS}
        camera["grid_index"] = np.full(len(H), -1, np.int64)
        attrs = {**store_attributes(spec, scene, frames.attribute()), "config_hash": config_hash}
        partial = final.with_name(final.name + ".partial")
        shutil.rmtree(partial, ignore_errors=True)  # a killed import's: imports do not resume
        try:
            create_store(partial, attrs, spec.image_size, spec.shard_size, H, camera, scene.image, scene.semantic)
            counts = _write_samples(partial, frames, spec, scene.semantic, H)
            remove_temporaries(partial)
            seal_store(partial, final, foreground_attribute(counts, spec.image_size))
        except BaseException:  # a bad image, Ctrl-C, disk full: leave nothing behind
            shutil.rmtree(partial, ignore_errors=True)
            raise
    return final, True


def _write_samples(partial: Path, frames: FrameSet, spec: DatasetSpec, scene_semantic: np.ndarray,
                   homographies: np.ndarray) -> np.ndarray:
    """Images and semantic maps, shard by shard; returns each sample's non-background pixel count."""
    layouts = image_layouts(partial)
    counts = []
    for shard, start in enumerate(range(0, len(homographies), spec.shard_size)):
        stop = min(start + spec.shard_size, len(homographies))
        images = frame_images(frames, spec.image_size, start, stop)
        semantics = np.stack([render_semantic(scene_semantic, H, spec.image_size) for H in homographies[start:stop]])
        write_samples(layouts, shard, images, semantics)
        counts.append(np.count_nonzero(semantics.reshape(len(semantics), -1), axis=1))
    return np.concatenate(counts)
