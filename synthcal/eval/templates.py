"""Which template a retrieval picked, and how far its pose is from the test image's: mixed-dictionary diagnostics.

``retrieved``, ``template`` and ``oracle-template`` return a dictionary
template's own homography bit for bit (:mod:`synthcal.estimators.diagnostic`),
and every run stores its per-image estimates (``metrics.csv``, ``h00`` … ``h22``).
So the template each picked is found again without the estimators' help
(:func:`identify_templates`): the dictionary template whose homography equals
the estimate (both scaled to unit norm, sign fixed; :data:`TOLERANCE`). Poses
come from the stores (``camera/pan_deg``): the test image's from the target
store at its pool index, a template's from the store it was drawn from (a mixed
dictionary's source store) — each pan as its own store records it. A run searched
the dictionary the loaders give it (:func:`synthcal.data.load_split`): the mixed one
for a ``mixed-*`` label, and for a store without an own dictionary
(``worldcup2014``, whose templates are the soccer store's).

Two templates per test image define the diagnostics:

* the *best-looking* one — the template of lowest true matching score, what a
  perfect Siamese retrieves: ``oracle-template``'s pick;
* the *best-pose* one — the template whose homography, used as the estimate,
  reprojects the ground the image sees nearest to where it is (``reproj_px``
  on an 8 × 5 grid of the image's ground pixels; an image that sees no ground
  has none): :func:`best_pose_templates`.

Per dataset, seed, settings and picker (``retrieved``, ``template`` and
``oracle-template``; :func:`template_diagnostics`):

* ``best_pose``: the share of test images where the picker's template is the
  best-pose one — for ``oracle-template``, "how often the best-looking template
  is the best-pose one";
* ``pan_error``: the median over test images of the absolute pan difference
  (degrees, wrapped to [0, 180]) between the picker's template and the test
  image; ``best_pan_error`` the same for the best-pose template.

Seeds are summarised by their mean (``best_pose``) and the median of the
per-seed medians (pan errors). A run whose estimates are not templates (none
identified), or whose store cannot be read, is left out.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from synthcal.eval.tables import MISSING, wrap_caption

__all__ = ["RETRIEVERS", "ORACLE", "TOLERANCE", "identify_templates", "best_pose_templates", "pan_error_deg",
           "template_diagnostics",
           "format_diagnostics", "oracle_cells", "diagnostics_text"]

RETRIEVERS = ("retrieved", "template")
ORACLE = "oracle-template"
# Largest difference of unit-norm homographies taken as the same template (CSV round-trips floats exactly;
# this allows for a rewrite at lower precision, far below any two distinct cameras' difference).
TOLERANCE = 1e-7
_H_COLUMNS = [f"h{i}{j}" for i in range(3) for j in range(3)]


def _unit(homographies: np.ndarray) -> np.ndarray:
    """(N, 3, 3) → (N, 9) at unit Frobenius norm, the sign making the largest-magnitude entry positive."""
    flat = np.asarray(homographies, np.float64).reshape(-1, 9)
    with np.errstate(invalid="ignore", divide="ignore"):
        flat = flat / np.linalg.norm(flat, axis=1, keepdims=True)
    sign = np.sign(flat[np.arange(len(flat)), np.nanargmax(np.abs(np.nan_to_num(flat)), axis=1)])
    return flat * np.where(sign == 0, 1.0, sign)[:, None]


def identify_templates(estimates: np.ndarray, dictionary: np.ndarray, tolerance: float = TOLERANCE) -> np.ndarray:
    """The dictionary template each estimate is (up to scale), -1 where none is.

    Args:
        estimates: (N, 3, 3) estimated homographies (NaN rows: no estimate).
        dictionary: (K, 3, 3) the dictionary's homographies.
        tolerance: largest distance of the unit-norm homographies counted as equal.

    Returns:
        (N,) int64 positions into ``dictionary`` (-1: not a template).
    """
    a, b = _unit(estimates), _unit(dictionary)
    out = np.full(len(a), -1, np.int64)
    for start in range(0, len(a), 256):  # (256, K) distances at a time
        d = np.linalg.norm(a[start:start + 256, None, :] - b[None, :, :], axis=-1)
        nearest = np.nanargmin(np.nan_to_num(d, nan=np.inf), axis=1)
        found = d[np.arange(len(nearest)), nearest] <= tolerance
        out[start:start + 256] = np.where(found, nearest, -1)
    return out


def _image_grid(image_size: tuple[int, int], columns: int = 8, rows: int = 5) -> np.ndarray:
    """(3, P) homogeneous pixel centres of a ``columns`` × ``rows`` grid spread over the image."""
    width, height = image_size
    u, v = np.meshgrid((np.arange(columns) + 0.5) * width / columns - 0.5,
                       (np.arange(rows) + 0.5) * height / rows - 0.5)
    return np.stack([u.ravel(), v.ravel(), np.ones(u.size)])


def best_pose_templates(truths: np.ndarray, dictionary: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Per test image, the template whose homography reprojects the image's ground nearest to where it is.

    The ground points are those of an 8 × 5 grid of image pixels that the true
    homography sends in front of the camera (the sky and the horizon have none);
    each template sends them back into the image, and its distance is the mean
    image-pixel distance to the pixels they came from — ``reproj_px`` on that grid.
    A template that puts any of them behind its camera is never best.

    Args:
        truths: (N, 3, 3) the test images' true homographies, bird's-eye → image, depth sign kept.
        dictionary: (K, 3, 3) the templates' homographies, the same convention.
        image_size: ``(width, height)`` of the images.

    Returns:
        (N,) int64 positions into ``dictionary`` of least distance; -1 where the true view sees no
        grid pixel's ground or no template keeps them in front of its camera.

    >>> import numpy as np
    >>> shift = lambda dx: np.array([[1.0, 0, dx], [0, 1, 0], [0, 0, 1]])
    >>> best_pose_templates(np.stack([shift(3.0)]), np.stack([shift(0.0), shift(2.5), shift(9.0)]), (4, 4))
    array([1])
    """
    pixels = _image_grid(image_size)  # (3, P)
    truths, templates = np.asarray(truths, np.float64), np.asarray(dictionary, np.float64)
    ground = np.linalg.solve(truths, np.broadcast_to(pixels, (len(truths), *pixels.shape)))  # (N, 3, P)
    seen = ground[:, 2] > 0  # in front of the true camera (depth sign kept, SPEC §2)
    ground = ground / np.where(seen, ground[:, 2], np.nan)[:, None]
    out = np.full(len(truths), -1, np.int64)
    for start in range(0, len(truths), 16):  # (16, K, 3, P) reprojections at a time
        back = np.einsum("kij,njp->nkip", templates, ground[start:start + 16])
        in_front = (back[:, :, 2] > 0) | np.isnan(back[:, :, 2])
        # a depth of 0 or NaN (a pixel the truth sends to the sky) is ruled out below, not an error here
        with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # images that see no ground: all-NaN rows
            moved = back[:, :, :2] / back[:, :, 2:3] - pixels[None, None, :2]
            mean = np.nanmean(np.hypot(moved[:, :, 0], moved[:, :, 1]), axis=-1)
        mean[~in_front.all(axis=-1) | np.isnan(mean)] = np.inf
        nearest = np.argmin(mean, axis=1)
        out[start:start + 16] = np.where(np.isfinite(mean[np.arange(len(mean)), nearest]), nearest, -1)
    return out


def pan_error_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Absolute pan differences in degrees, wrapped to [0, 180]."""
    return np.abs((np.asarray(a, np.float64) - np.asarray(b, np.float64) + 180.0) % 360.0 - 180.0)


class _Stores:
    """One call's view of the stores its runs name: each opened once, and of its ``homography`` and
    ``camera/pan_deg`` only the rows the runs ask for, each read once.

    Reading whole arrays through Zarr (one inner chunk per sample, each through its codec pipeline) was most
    of a diagnostics table's time; :func:`~synthcal.store.read_rows` reads just the rows, checksums checked.
    Kept per call, not per process: a store regenerated between two calls is read afresh.
    """

    def __init__(self) -> None:
        self._groups: dict[str, Any] = {}
        self._rows: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}  # values, which rows are read
        self._dictionaries: dict[tuple[str, int, bool], tuple[np.ndarray, np.ndarray]] = {}
        # (store, seed, mixed dictionary, the test images' pool indices) → their best-pose templates: every
        # picker's runs of one seed share them, and computing them is most of the diagnostics' time.
        self.best_poses: dict[tuple[str, int, bool, bytes], np.ndarray] = {}

    def group(self, store: str) -> Any:
        """The store as :func:`~synthcal.store.open_store` opens it (manifest checked), once per call."""
        from synthcal.store import open_store

        if store not in self._groups:
            self._groups[store] = open_store(store)
        return self._groups[store]

    def rows(self, store: str, name: str, index: np.ndarray) -> np.ndarray:
        """``name``'s rows at ``index`` as float64, (K, ...) in ``index``'s order; rows not read yet are read.

        Raises:
            IndexError: an index past the array's end.
        """
        from synthcal.store import array_at
        from synthcal.store.shards import read_rows

        key = (store, name)
        if key not in self._rows:
            shape = array_at(self.group(store), name).shape
            self._rows[key] = np.empty(shape, np.float64), np.zeros(shape[0], bool)
        values, read = self._rows[key]
        index = np.asarray(index)  # not cast: a float index (a NaN in metrics.csv) raises IndexError, as before
        missing = np.unique(index[~read[index]])
        if len(missing):
            values[missing] = read_rows(array_at(self.group(store), name), missing)
            read[missing] = True
        return values[index]

    def image_size(self, store: str) -> tuple[int, int]:
        """The store's ``image_size`` attribute."""
        size: Any = self.group(store).attrs["image_size"]
        return int(size[0]), int(size[1])

    def reads_mixed(self, run: Mapping[str, Any], store: str) -> bool:
        """Whether a run searched a mixed dictionary: its ``mixed`` as recorded, else (None: the store's
        default) the loaders' rule (:func:`synthcal.data.load_split`) — mixed where the store has no own
        dictionary, as ``worldcup2014``, whose templates come from the soccer store."""
        from synthcal.store.splits import dictionary_is_mixed

        if str(run["dataset"]).startswith("mixed-"):
            return True
        return dictionary_is_mixed(self.group(store), Path(store), run.get("mixed"))

    def dictionary(self, store: str, seed: int, mixed: bool) -> tuple[np.ndarray, np.ndarray]:
        """A seed's dictionary: (K, 3, 3) homographies and (K,) pans, each from the store it was drawn from."""
        from synthcal.store import read_mixed_dictionary, read_split_indices

        key = (store, seed, mixed)
        if key not in self._dictionaries:
            if mixed:
                templates = read_mixed_dictionary(store, seed)
                homographies, pans = np.empty((len(templates.index), 3, 3)), np.empty(len(templates.index))
                for k, source in enumerate(templates.stores):
                    mask = templates.source == k
                    homographies[mask] = self.rows(str(source), "homography", templates.index[mask])
                    pans[mask] = self.rows(str(source), "camera/pan_deg", templates.index[mask])
            else:
                index = read_split_indices(store, "dictionary", seed, group=self.group(store))
                homographies, pans = self.rows(store, "homography", index), self.rows(store, "camera/pan_deg", index)
            self._dictionaries[key] = homographies, pans
        return self._dictionaries[key]


def _store_path(recorded: str, results: Path) -> str:
    """A run's store: as recorded, else relative to the results folder's parent.

    bench records the store path it was given, often relative to where it ran, beside
    its results folder; ``synthcal table`` may run anywhere.
    """
    path = Path(recorded)
    if path.is_absolute() or (path / "zarr.json").is_file():
        return str(path)
    beside = results.parent / path
    return str(beside if (beside / "zarr.json").is_file() else path)


def _picks(results: Path, run_id: str, record: Mapping[str, Any], stores: _Stores) -> pd.DataFrame | None:
    """Per test image of a run: its pool index, the template picked and the best-pose one (-1: none), and their
    pan errors. ``stores`` keeps what was read and the best-pose templates for the next run of the same store."""
    run = record["run"]
    try:
        per_image = pd.read_csv(results / "runs" / run_id / "metrics.csv", usecols=["pool_index", *_H_COLUMNS])
        store = _store_path(str(run["store"]), results)
        mixed = stores.reads_mixed(run, store)
        homographies, pans = stores.dictionary(store, int(run["seed"]), mixed)
        pool_index = per_image["pool_index"].to_numpy()
        test_pans = stores.rows(store, "camera/pan_deg", pool_index)
        key = (store, int(run["seed"]), mixed, pool_index.astype(np.int64).tobytes())
        if key not in stores.best_poses:
            stores.best_poses[key] = best_pose_templates(stores.rows(store, "homography", pool_index), homographies,
                                                         stores.image_size(store))
        best = stores.best_poses[key]
    except (OSError, ValueError, KeyError, IndexError):  # StoreError is a ValueError
        return None
    picked = identify_templates(per_image[_H_COLUMNS].to_numpy().reshape(-1, 3, 3), homographies)
    if (picked < 0).all():
        return None
    error = np.where(picked >= 0, pan_error_deg(pans[np.maximum(picked, 0)], test_pans), np.nan)
    best_error = np.where(best >= 0, pan_error_deg(pans[np.maximum(best, 0)], test_pans), np.nan)
    return pd.DataFrame({"pool_index": per_image["pool_index"], "picked": picked, "pan_error": error,
                         "best": best, "best_pan_error": best_error})


def template_diagnostics(frame: pd.DataFrame, results: str | Path, mixed_only: bool = True) -> pd.DataFrame:
    """How often each picker's template is the best-pose one, and its pan errors (module docstring).

    Args:
        frame: per-run results (:func:`synthcal.eval.harness.collect_results`: ``run_id``, ``dataset``,
            ``model``, ``seed``, ``matching_score``, ``segmentation``, ``profile``).
        results: the results folder (records, ``metrics.csv``; the stores they name).
        mixed_only: only mixed-dictionary datasets (``mixed-*``).

    Returns:
        One row per dataset, matching score, segmentation, profile and picker (``retrieved``, ``template``,
        ``oracle-template``): ``seeds`` (with a template identified), ``best_pose`` (percent of the test
        images with a best-pose template), ``pan_error`` and ``best_pan_error`` (degrees). Empty where
        nothing applies.
    """
    from synthcal.eval.harness import read_record

    results = Path(results)
    keys = ["dataset", "matching_score", "segmentation", "profile"]
    pickers = [*RETRIEVERS, ORACLE]
    runs = frame[frame["model"].isin(pickers)].drop_duplicates("run_id")
    if mixed_only:
        runs = runs[runs["dataset"].astype(str).str.startswith("mixed-")]
    columns = [*keys, "model", "seeds", "best_pose", "pan_error", "best_pan_error"]
    if runs.empty:
        return pd.DataFrame(columns=columns)
    # a key a run lacks (NaN: e.g. a matching score for a model without one) is a value too, not a crash
    runs = runs.assign(_key=runs[keys].astype(object).fillna("–").astype(str).agg(" / ".join, axis=1))
    rows: list[dict[str, Any]] = []
    stores = _Stores()
    for (key, model), group in runs.groupby(["_key", "model"], sort=False):
        per_seed = []
        for run_id in group["run_id"]:
            record = read_record(results / "runs" / str(run_id) / "run.json")
            picks = None if record is None else _picks(results, str(run_id), record, stores)
            if picks is None:
                continue
            both = picks[(picks["picked"] >= 0) & (picks["best"] >= 0)]
            share = 100.0 * float((both["picked"] == both["best"]).mean()) if len(both) else np.nan
            per_seed.append((share, float(np.nanmedian(picks["pan_error"])),
                             float(np.nanmedian(picks["best_pan_error"]))))
        if per_seed:
            values = np.array(per_seed, dtype=float)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns stay NaN
                summary = (np.nanmean(values[:, 0]), np.nanmedian(values[:, 1]), np.nanmedian(values[:, 2]))
            rows.append({**dict(zip(keys, key.split(" / "), strict=True)), "model": model, "seeds": len(per_seed),
                         "best_pose": summary[0], "pan_error": summary[1], "best_pan_error": summary[2]})
    order = {name: k for k, name in enumerate(pickers)}
    out = pd.DataFrame(rows, columns=columns)
    return out.sort_values(["dataset", "model"], key=lambda c: c.map(order) if c.name == "model" else c,
                           kind="stable", ignore_index=True)


def format_diagnostics(diagnostics: pd.DataFrame, oracle_cells: Mapping[str, str], fmt: str = "md") -> str:
    """The diagnostics as lines under a mixed table ("" if there are none).

    Args:
        diagnostics: :func:`template_diagnostics`.
        oracle_cells: dataset label → the ``oracle-template`` cell as shown (mean ± std) in the table's reading.
        fmt: ``md``, ``latex`` (lines as comments) or ``csv`` (nothing: the CSV holds one table).
    """
    if diagnostics.empty or fmt == "csv":
        return ""
    lines = []
    for row in diagnostics.to_dict("records"):
        def shown(value: float, unit: str) -> str:
            return MISSING if pd.isna(value) else f"{value:.1f}{unit}"
        which = ("the best-looking template (lowest true matching score)" if row["model"] == ORACLE
                 else f"the template `{row['model']}` picked")
        lines.append(f"Template diagnostics, {row['dataset']} ({row['model']}, matching {row['matching_score']}, "
                     f"segmentation {row['segmentation']}, {row['seeds']} seeds): {which} is the best-pose one "
                     f"(its ground reprojected nearest the truth) for {shown(row['best_pose'], ' %')} of "
                     f"test images; median pan error of {which} "
                     f"{shown(row['pan_error'], '°')}, of the best-pose template {shown(row['best_pan_error'], '°')}"
                     + (f"; {ORACLE} row: {oracle_cells.get(str(row['dataset']), MISSING)}." if row["model"] == ORACLE
                        else "."))
    return "\n".join(wrap_caption(line, fmt) for line in lines) + "\n"


def oracle_cells(frame: pd.DataFrame, value: str) -> dict[str, str]:
    """Dataset label → its ``oracle-template`` row in ``value`` as tables show it (``mean ± std``, per matching
    score where there are several), for :func:`format_diagnostics`."""
    from synthcal.eval.tables import aggregate

    oracle = frame[frame["model"] == ORACLE].drop_duplicates(["dataset", "matching_score", "seed"])
    if oracle.empty:
        return {}
    cells = aggregate(oracle, value)
    out: dict[str, list[str]] = {}
    for row in cells.to_dict("records"):
        spread = "" if pd.isna(row["std"]) else f" ± {row['std']:.2f}"
        out.setdefault(str(row["dataset"]), []).append(
            f"{row['mean']:.2f}{spread} {value} (matching {row['matching_score']}, {row['n_seeds']} seeds)")
    return {dataset: "; ".join(texts) for dataset, texts in out.items()}


def diagnostics_text(frame: pd.DataFrame, results: str | Path | None, value: str, fmt: str) -> str:
    """:func:`format_diagnostics` of the frame's mixed-dictionary runs ("" without a results folder or any)."""
    if results is None or fmt == "csv" or "run_id" not in frame:
        return ""
    return format_diagnostics(template_diagnostics(frame, results), oracle_cells(frame, value), fmt)
