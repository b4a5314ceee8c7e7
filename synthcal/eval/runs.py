"""What a run is and which runs a sweep has (SPEC §8, §9).

A *run* is (dataset, estimator, training, loss, matching, segmentation, seed,
profile, the profile's training settings and split sizes, device): :class:`Run`.
:func:`expand_runs` turns a sweep's values into its runs; executing them is
:mod:`synthcal.eval.harness`, one estimator in a process of its own
:mod:`synthcal.eval.isolation`.

Datasets
--------
A dataset label names a store ``<data>/<label>.zarr`` (its own dictionary, or the
mixed one for a dataset without its own, e.g. ``worldcup2014``), or
``mixed-<k>`` / ``mixed-<name>``: target ``intersection-<k>`` / ``<name>`` with
its mixed dictionary (SPEC §6), labelled as in the paper's tables.

Axes
----
An axis applies to an estimator when its constructor takes a keyword of that name
(``training``, ``loss``, ``matching``); ``segmentation`` applies when the
estimator also has ``predict_semantic``. Axes that do not apply collapse: an
``identity`` run is one run per (dataset, seed), its keys recorded as None.
Constructors that take them also get ``settings`` (the profile's
:class:`synthcal.config.TrainingSettings`), ``device``, ``cache_dir``
(``RESULTS/cache``), ``seed`` (the split seed) and ``progress``. ``device`` is
resolved when the runs are expanded (``auto``: ``cuda`` where this process sees
CUDA, else ``cpu``) and recorded only for estimators that take it.

Dictionaries
------------
``Run.dictionary`` is ``split`` (the seed's drawn dictionary: the store's own, or
the mixed one) or ``pool``: every pool sample outside the seed's stored train and
test sets (:func:`synthcal.store.splits.pool_dictionary_indices`), handed to ``fit``
as a lazy :func:`synthcal.data.load_pool_dictionary` and never capped by
``limits``. A mixed dictionary has no pool dictionary: :func:`expand_runs` refuses
one. ``pool`` is in the run's hash and id; ``split`` is left out of the hash, so
runs recorded before the field existed keep their ids. Tables label pool runs
``NAME (pool)``.

Split sizes
-----------
``limits`` (a profile's ``splits:``) caps what a run uses of the seed's stored
splits: the first ``train`` / ``test`` / ``dictionary`` entries of each (the
splits hold ascending pool indices of a pool drawn in random camera order, so a
prefix is a random subset, the same one for every estimator and seed run). A
mixed dictionary is cut round-robin over its sources, so that each source keeps
an equal share. Train and test of a dataset of given poses (``worldcup2014``) are
never cut: they are the poses' own partition (less the validation set carved from
train, whose remaining size then stands in ``limits``, so that runs on train sets
from before and after the carving have different ids). A split smaller than its cap is used
whole. :func:`split_sizes` says what a run will use; :func:`plan_lines` says it
for a whole sweep, with each training's budget (:func:`training_budget`).

Run ids
-------
``run-id`` (:attr:`Run.id`, the run's folder ``RESULTS/runs/<run-id>``) is
``<dataset>_<model>[_<training>_<loss>_<matching>_<segmentation>]_s<seed>_<hash>``,
the hash over the whole resolved run but the store's path (its config hash
stands for its content): every setting that changes the result is in it —
the profile's training settings, the split sizes it caps (``limits``), the
device and what the estimator is (``code``: a hash of its source, or of the
bundled models' code; :mod:`synthcal.estimators.version`), so that an edited
plug-in is run again rather than its old results reused. The device is in it because a result depends on it: floating-point
reductions differ between CPU and GPU kernels, so the trained weights differ,
and a run asked of a device that cannot run it (``cuda`` without CUDA) fails;
under the old identity, which left the device out, that failure was reused by a
rerun on the CPU. The time limit, the progress bars and the scheduler are not in
it: they decide whether a run ends, never what an ended run scores.

Options
-------
An estimator's constructor options (:mod:`synthcal.estimators.options`: the
configuration's ``estimators:``, ``--estimator 'NAME?key=value'``, ``--option``)
are :attr:`Run.options`: checked against the constructor by :func:`expand_runs`
before any run, in the hash when set (two option sets, two runs), in the label
(``sift(ratio=0.7)``, written ``sift-ratio0.7`` in the run id) and in
``run.json``.
"""

from __future__ import annotations

import hashlib
import inspect
import itertools
import json
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from synthcal.config import DICTIONARIES, Dictionary, Loss, Matching, Segmentation, Training
from synthcal.estimators import resolve_estimator
from synthcal.estimators.options import (
    HARNESS_KEYWORDS,
    EstimatorSpec,
    check_options,
    options_label,
    parse_estimator_spec,
)
from synthcal.estimators.version import estimator_version
from synthcal.store import array_at, group_at, open_store
from synthcal.store.splits import (
    VALIDATION,
    SplitError,
    dictionary_is_mixed,
    drawn_seeds,
    pool_dictionary_indices,
    read_mixed_dictionary,
    read_split_indices,
    store_spec,
)

__all__ = ["AXES", "Run", "dataset_store", "estimator_label", "resolve_device", "check_device", "expand_runs",
           "split_sizes", "trained_images", "plan_lines", "prefix_positions", "training_budget", "chosen_text", "constructor_parameters", "table_label"]

# Run fields an estimator may take as constructor keywords (values: synthcal.config).
AXES = ("training", "loss", "matching", "segmentation")
# Run fields that do not change the result, left out of the run's hash.
_NOT_HASHED = ("store",)
# Run fields added after the first results were recorded: left out of the hash while None.
_HASHED_WHEN_SET = ("device", "limits", "options")
# An options label's punctuation in a run id (a folder name a shell takes unquoted): sift(ratio=0.7) → sift-ratio0.7.
_ID_PUNCTUATION = str.maketrans({"/": "-", ":": "-", "(": "-", ")": None, "=": None, ",": None, " ": None})
# Run fields added later with a default: left out of the hash at that default (the runs recorded
# before them were exactly those runs).
_HASHED_UNLESS = {"dictionary": "split"}


@dataclass(frozen=True)
class Run:
    """One (dataset, estimator, axes, seed, profile) evaluation.

    Attributes:
        dataset: table label (``intersection-1``, ``mixed-4``, ``worldcup2014``).
        store: the target store's path.
        mixed: load the mixed dictionary (None: the store's default).
        store_hash: the store's ``config_hash`` (a regenerated store is a new run).
        estimator: the name or dotted path as given.
        model: table label (the estimator's ``label`` or its name).
        seed: split seed.
        profile: the training profile's name (None: defaults).
        training, loss, matching, segmentation: axes, None where they do not apply.
        settings: the profile's training settings (only for estimators taking them).
        device: torch device name, resolved (``cpu``, ``cuda``; only for estimators
            taking one, else None).
        limits: the most ``train`` / ``test`` / ``dictionary`` samples used of the
            stored splits (module docstring, "Split sizes"); None: all.
        dictionary: ``split`` (the seed's dictionary split, or the mixed one) or
            ``pool`` (every pool sample outside the seed's train and test sets;
            module docstring, "Dictionaries").
        code: what the estimator is, its code version
            (:func:`synthcal.estimators.version.estimator_version`): an edited
            plug-in or bundled model is a new run.
        options: the estimator's constructor options (module docstring,
            "Options"); None: none.
    """

    dataset: str
    store: str
    mixed: bool | None
    store_hash: str
    estimator: str
    model: str
    seed: int
    profile: str | None = None
    training: Training | None = None
    loss: Loss | None = None
    matching: Matching | None = None
    segmentation: Segmentation | None = None
    settings: dict[str, Any] | None = field(default=None, hash=False)
    device: str | None = None
    limits: dict[str, int] | None = field(default=None, hash=False)
    dictionary: Dictionary = "split"
    code: str = ""
    options: dict[str, Any] | None = field(default=None, hash=False)

    @property
    def id(self) -> str:
        """Folder name: readable keys, then a hash of the whole run."""
        # Fields added later hash only when set, so that the runs they do not concern keep their ids.
        record = {k: v for k, v in asdict(self).items()
                  if k not in _NOT_HASHED and not (k in _HASHED_WHEN_SET and v is None)
                  and not (k in _HASHED_UNLESS and v == _HASHED_UNLESS[k])}
        h = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()[:10]
        pool = ["pool"] if self.dictionary == "pool" else []
        keys = [self.dataset, self.model, *[getattr(self, a) for a in AXES if getattr(self, a)], *pool,
                f"s{self.seed}", h]
        return "_".join(k.translate(_ID_PUNCTUATION) for k in keys)


def dataset_store(data_dir: str | Path, label: str) -> tuple[Path, bool | None]:
    """``(store, mixed)`` of a dataset label (module docstring)."""
    data_dir = Path(data_dir)
    if label.startswith("mixed-"):
        target = label.removeprefix("mixed-")
        if target.isdigit():
            target = f"intersection-{target}"
        return data_dir / f"{target}.zarr", True
    return data_dir / f"{label}.zarr", None


def constructor_parameters(cls: Any) -> set[str]:
    """Keyword names the estimator's constructor takes (none if it cannot be inspected)."""
    try:
        return set(inspect.signature(cls).parameters)
    except (TypeError, ValueError):
        return set()


def estimator_label(name: str, cls: Any, settings: dict[str, Any] | None = None) -> str:
    """Table label: the class's ``variant_label(settings)`` where it has one (a variant such as a
    batch-norm ablation labels its own row), else its ``label``, else the short name, else the class name."""
    variant = getattr(cls, "variant_label", None)
    if callable(variant):
        return str(variant(settings))
    label = getattr(cls, "label", None)
    if isinstance(label, str):
        return label
    return name.rpartition(":")[2].rpartition(".")[2] if ":" in name else name


def resolve_device(name: str) -> str:
    """The device a run gets: ``auto`` → ``cuda`` where this process sees CUDA, else ``cpu``; others as given."""
    if name != "auto":
        return name
    import torch

    return "cuda" if torch.cuda.is_available() else "cpu"


def check_device(name: str) -> None:
    """Refuse a device name torch does not know, or CUDA where there is none.

    Raises:
        ValueError: naming the device and why.
    """
    import torch

    try:
        device = torch.device(resolve_device(name))
    except RuntimeError as error:
        raise ValueError(f"--device: not a torch device: {error} (value {name!r})") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"--device: CUDA is not available on this machine (value {name!r}); "
                         f"use --device cpu or auto")


def _store_limits(store: Path, group: Any, limits: dict[str, int] | None) -> dict[str, int] | None:
    """The caps that apply to a store: all of them, but not train/test of a dataset of given poses,
    nor a validation size of 0 (sizes without a validation set keep their runs' ids). A poses
    store whose splits carve validation from its train part gets its train size instead
    (:func:`_carved_train`)."""
    limits = {k: v for k, v in (limits or {}).items() if k != "validation" or v}
    if store_spec(group, store).poses is not None:
        limits = {k: v for k, v in limits.items() if k not in ("train", "test")} | _carved_train(group)
    return dict(sorted(limits.items())) or None


def _carved_train(group: Any) -> dict[str, int]:
    """``{"train": n}`` when a poses store's splits hold a validation set, else ``{}``.

    Validation is carved from the given train part, so such runs train on fewer samples
    than the runs recorded before the store had one: the size in their ids keeps those
    from being reused for them. Every seed carves the same number.
    """
    for seed in drawn_seeds(group):
        sub = group_at(group, f"splits/seed-{seed}")
        if VALIDATION in sub:
            return {"train": int(array_at(sub, "train").shape[0])}
    return {}


def expand_runs(
    data_dir: str | Path,
    datasets: Sequence[str],
    estimators: Sequence[str | EstimatorSpec],
    seeds: Sequence[int],
    profile: str | None = None,
    settings: dict[str, Any] | None = None,
    trainings: Sequence[Training] = ("step-by-step",),
    losses: Sequence[Loss] = ("top-mse",),
    matchings: Sequence[Matching] = ("top-mse",),
    segmentations: Sequence[Segmentation] = ("unet",),
    device: str = "auto",
    limits: dict[str, int] | None = None,
    dictionary: Dictionary | dict[str, Dictionary] = "split",
) -> list[Run]:
    """The sweep grid, with axes collapsed where they do not apply.

    Checks every store and seed first, so that a typo stops the sweep before any
    training.

    Args:
        device: torch device name (``auto`` resolved here, :func:`resolve_device`).
        limits: a profile's split sizes, capping the stored splits (module
            docstring, "Split sizes"); None: the splits as stored.
        dictionary: ``split`` or ``pool`` for every dataset, or per dataset label
            (labels not in the dict: ``split``); module docstring, "Dictionaries".
        estimators: names or dotted paths, ``NAME?key=value&…`` or
            :class:`EstimatorSpec` (with options; module docstring, "Options").
        others: the sweep's values (module docstring).

    Raises:
        SplitError: a missing store, a seed whose splits are not drawn, or the pool
            dictionary asked of a dataset with a mixed dictionary.
        EstimatorError: an estimator that cannot be resolved, or options its
            constructor does not take (or a required parameter they leave out).
    """
    specs = [parse_estimator_spec(e) if isinstance(e, str) else e for e in estimators]
    values: dict[str, Sequence[str]] = {"training": trainings, "loss": losses, "matching": matchings,
                                        "segmentation": segmentations}
    shared: dict[str, Any] = {"seeds": seeds, "profile": profile, "settings": settings,
                              "device": resolve_device(device)}
    runs: dict[str, Run] = {}
    for label in datasets:
        store, mixed = dataset_store(data_dir, label)
        if not store.is_dir():
            raise SplitError(f"{store}: no such store (dataset {label!r}); generate it with `synthcal generate`")
        group = open_store(store)
        missing = sorted(set(seeds) - set(drawn_seeds(group)))
        if missing:
            raise SplitError(f"{store}: splits not drawn for seed(s) {', '.join(map(str, missing))}; run "
                             f"`synthcal split {store} --seeds {','.join(map(str, missing))}`")
        base = {"dataset": label, "store": str(store), "mixed": mixed, "store_hash": str(group.attrs["config_hash"]),
                "limits": _store_limits(store, group, limits),
                "dictionary": _dataset_dictionary(label, store, mixed, dictionary)}
        for spec in specs:
            for run in _estimator_runs(spec, base, values, **shared):
                runs.setdefault(run.id, run)
    return list(runs.values())


def _dataset_dictionary(label: str, store: Path, mixed: bool | None,
                        dictionary: Dictionary | dict[str, Dictionary]) -> Dictionary:
    """The dictionary a dataset label's runs search; refuses ``pool`` where the dictionary is mixed.

    Raises:
        SplitError: ``pool`` for a ``mixed-*`` label or a dataset without an own pool dictionary.
    """
    value = dictionary.get(label, "split") if isinstance(dictionary, dict) else dictionary
    if value not in DICTIONARIES:
        raise SplitError(f"--dictionary: unknown dictionary {value!r} (dataset {label!r}); "
                         f"one of {', '.join(DICTIONARIES)}")
    if value == "pool" and (mixed or dictionary_is_mixed(open_store(store), store)):
        raise SplitError(f"{store}: dictionary pool: dataset {label!r} uses a mixed dictionary (templates from "
                         f"other datasets' pools); the pool dictionary is a store's own pool outside the seed's "
                         f"train and test sets: bench {label!r} with --dictionary split, or the target's own "
                         f"label with --dictionary pool")
    return value


def _estimator_runs(spec: EstimatorSpec, base: dict[str, Any], values: dict[str, Sequence[str]],
                    seeds: Sequence[int], profile: str | None, settings: dict[str, Any] | None,
                    device: str) -> list[Run]:
    """One estimator's runs on one dataset: its applicable axes × seeds."""
    name = spec.name
    cls = resolve_estimator(name)
    params = constructor_parameters(cls)
    code = estimator_version(cls)
    applies = {a: (hasattr(cls, "predict_semantic") if a == "segmentation" else a in params) for a in AXES}
    # What the child process passes (synthcal.eval.isolation._options) satisfies required parameters.
    check_options(name, cls, spec.options, frozenset(params & set(HARNESS_KEYWORDS)))
    options = dict(sorted(spec.options.items())) or None
    grid: list[Sequence[str | None]] = [values[a] if applies[a] else [None] for a in AXES]
    runs = []
    taken = settings if "settings" in params else None
    for seed, combo in itertools.product(seeds, itertools.product(*grid)):
        axes: dict[str, Any] = dict(zip(AXES, combo, strict=True))
        runs.append(Run(**base, estimator=name, model=options_label(estimator_label(name, cls, taken), options),
                        seed=int(seed), profile=profile, settings=taken,
                        device=device if "device" in params else None, code=code, options=options, **axes))
    return runs


def prefix_positions(n: int, cap: int | None, source: np.ndarray | None = None) -> np.ndarray:
    """Positions kept of a split of ``n`` entries under a cap (module docstring, "Split sizes").

    Args:
        n: the split's length.
        cap: the most entries kept (None: all).
        source: a mixed dictionary's (n,) source of each entry: kept round-robin
            over the sources, first entries of each first.

    Returns:
        Ascending positions, ``min(n, cap)`` of them.

    >>> prefix_positions(5, 3).tolist()
    [0, 1, 2]
    >>> prefix_positions(6, 3, np.array([0, 0, 0, 1, 1, 1])).tolist()
    [0, 1, 3]
    """
    if cap is None or cap >= n:
        return np.arange(n)
    if source is None:
        return np.arange(cap)
    source = np.asarray(source)
    rank = np.empty(n, np.int64)
    for value in np.unique(source):
        where = np.flatnonzero(source == value)
        rank[where] = np.arange(len(where))
    order = np.lexsort((source, rank))  # by rank within its source, then by source
    return np.sort(order[:cap])


def _mixed_dictionary(run: Run) -> bool:
    """Whether the run's dictionary is a mixed one (as :func:`synthcal.data.load_split` decides)."""
    if run.mixed is not None:
        return run.mixed
    return dictionary_is_mixed(open_store(run.store), Path(run.store))


def split_sizes(run: Run) -> dict[str, tuple[int, int]]:
    """What the run uses of each split: ``{split: (used, stored)}``, from the indices alone.

    Raises:
        SplitError: a split or mixed dictionary that is not drawn.
    """
    sizes: dict[str, tuple[int, int]] = {}
    for split in ("train", "test", "dictionary"):
        if split == "dictionary" and run.dictionary == "pool":  # never capped: the whole pool is the point
            stored = len(pool_dictionary_indices(run.store, run.seed))
            sizes[split] = (stored, stored)
            continue
        if split == "dictionary" and _mixed_dictionary(run):
            stored = len(read_mixed_dictionary(run.store, run.seed).index)
        else:
            stored = len(read_split_indices(run.store, split, run.seed))
        cap = (run.limits or {}).get(split)
        sizes[split] = (stored if cap is None else min(cap, stored), stored)
    return sizes


def trained_images(settings: dict[str, Any] | None, train: int | None) -> int | None:
    """How many train images a bundled model trains on: the train split's ``train`` samples used, under
    the settings' ``max_train``; None for an estimator without training settings or an unknown size.

    >>> trained_images({"max_train": 1500}, 3000), trained_images({}, 167), trained_images(None, 3000)
    (1500, 167, None)
    """
    if settings is None or train is None:
        return None
    cap = settings.get("max_train")
    return min(train, cap) if cap else train


def _span(values: Iterable[int]) -> str:
    """``128`` or ``120–128`` (several seeds with different sizes)."""
    values = sorted(set(values))
    return f"{values[0]:,}" if len(values) == 1 else f"{values[0]:,}–{values[-1]:,}"


def plan_lines(runs: Sequence[Run]) -> list[str]:
    """What a sweep will train and test on, for the console before it starts.

    One line per dataset (the samples of each split used, of those stored, over
    the runs' seeds; what the bundled models train on under ``max_train``), then
    one per training kind of the bundled models (:func:`training_budget`).

    Raises:
        SplitError: a split that is not drawn.
    """
    datasets: dict[str, dict[int, dict[str, tuple[int, int]]]] = {}
    for run in runs:
        seeds = datasets.setdefault(table_label(asdict(run)), {})
        if run.seed not in seeds:
            seeds[run.seed] = split_sizes(run)
    settings = next((run.settings for run in runs if run.settings), None)
    cap = (settings or {}).get("max_train")
    lines = []
    for dataset, seeds in datasets.items():
        parts = [f"{split} {_span(s[split][0] for s in seeds.values())} "
                 f"of {_span(s[split][1] for s in seeds.values())}" for split in ("train", "test", "dictionary")]
        line = f"  {dataset} (seeds {', '.join(map(str, seeds))}): {', '.join(parts)}"
        if settings is not None:
            used = (trained_images(settings, s["train"][0]) or 0 for s in seeds.values())
            line += f"; the bundled models train on {_span(used)}" + (f" (max_train {cap:,})" if cap else "")
        lines.append(line)
    kinds = dict.fromkeys((run.training, run.segmentation) for run in runs if run.settings is not None)
    for training, segmentation in kinds:
        budget = training_budget({"run": {"training": training, "segmentation": segmentation, "settings": settings}})
        if budget:
            batch = (settings or {}).get("batch_size")
            lines.append(f"  training ({segmentation or 'no'} segmentation): {budget}; batch {batch}")
    return lines


def table_label(run: dict[str, Any]) -> str:
    """A run's dataset label in tables: ``NAME (pool)`` for a pool-dictionary run, so that it
    sits in a row of its own beside the same dataset's split-dictionary runs."""
    return f"{run['dataset']} (pool)" if run.get("dictionary") == "pool" else str(run["dataset"])


def training_budget(record: dict[str, Any]) -> str | None:
    """What a run of a bundled model was trained with, in words (None: no training settings).

    From the record's resolved settings: the epochs of the stages its training
    trains (the UNet's only under ``segmentation: unet``), the train images used
    (``max_train`` of the split's size, where the record has it), the working
    resolution and, where the settings carry them, ``stn_template`` and
    ``class_reduction``.

    >>> training_budget({"run": {"training": "end-to-end", "segmentation": "unet",
    ...                          "settings": {"end_to_end_epochs": 24, "work_size": [128, 72]}}})
    'end-to-end 24 epochs; at 128 × 72'
    """
    run = record.get("run", {})
    settings = run.get("settings")
    if not isinstance(settings, dict) or run.get("training") is None:
        return None
    if run["training"] == "end-to-end":
        parts = [f"end-to-end {settings.get('end_to_end_epochs')} epochs"]
    else:
        stages = ([("UNet", "unet_epochs")] if run.get("segmentation") == "unet" else []) + \
                 [("Siamese", "siamese_epochs"), ("STN", "stn_epochs")]
        parts = ["step-by-step " + ", ".join(f"{name} {settings.get(key)}" for name, key in stages) + " epochs"]
    train = trained_images(settings, (record.get("sizes") or {}).get("train"))
    if train is not None:
        parts.append(f"{train} train images")
    if settings.get("work_size"):
        width, height = settings["work_size"]
        parts.append(f"at {width} × {height}")
    parts += [f"{key.replace('_', ' ')} {settings[key]}" for key in ("stn_template", "class_reduction")
              if settings.get(key) is not None]
    if settings.get("patience") is not None:
        parts.append(f"best STN epoch on validation, patience {settings['patience']}")
    if settings.get("select"):
        rates = ", ".join(f"{rate:g}" for rate in settings["select"]["learning_rate"])
        parts.append(f"learning rate chosen on validation from {rates}")
    if settings.get("unet_learning_rate") is not None:
        parts.append(f"UNet at learning rate {settings['unet_learning_rate']:g}")
    if settings.get("selection_score") == "iou":
        parts.append("fits ranked by validation iou")
    return "; ".join(parts)


def chosen_text(record: dict[str, Any]) -> str | None:
    """What the run's selection chose on the validation split, in words (None: no selection).

    >>> chosen_text({"selection": {"chosen": {"learning_rate": 0.0003, "unet_epochs": 9, "stn_epochs": 12}}})
    'lr 0.0003, UNet 9 epochs, STN 12 epochs'
    """
    chosen = (record.get("selection") or {}).get("chosen")
    if not isinstance(chosen, dict):
        return None
    words = {"learning_rate": "lr {:g}", "unet_epochs": "UNet {} epochs", "stn_epochs": "STN {} epochs"}
    return ", ".join(words.get(key, key + " {}").format(value) for key, value in chosen.items())

