"""The ``synthcal`` command line: one module, one sub-command per job.

Errors that come from the user's input (configuration, files, stores) are printed
as one clear message with exit status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd
    import zarr

    from synthcal.config import DatasetSpec, LoadedConfig
    from synthcal.generate.splits import DrawResult

__all__ = ["main"]


def _cmd_scenes(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.scenes import BUILTIN_SCENES

    for name, description in BUILTIN_SCENES.items():
        print(f"{name:16s} built in   {description}")
    for name, scene in load_config(args.config).config.scenes.items():
        print(f"{name:16s} user       {scene.image} + {scene.semantic}")


def _cmd_scene(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import load_scene
    from synthcal.generate.scenes import draw_scene
    from synthcal.viz import write_png

    config = load_config(args.config)
    dataset = next((d for d, e in config.config.datasets.items() if e.scene == args.name), None)
    if dataset is not None:
        scene = load_scene(config.resolve(dataset))
    else:
        from synthcal.generate.scenes import build_scene

        scene = build_scene(args.name)
    print(write_png(args.output, draw_scene(scene)))


def _cmd_generate(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import generate_dataset

    config = load_config(args.config)
    specs = [_resolve_with_n(config, name, args.profile, args.n) for name in args.datasets]  # validate all first
    paths = []
    for spec in specs:
        started = time.perf_counter()
        path = generate_dataset(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                                progress=not args.quiet)
        paths.append(path)
        print(f"{path}  {spec.pool_size} samples  {time.perf_counter() - started:.1f} s")
    if args.splits:
        from synthcal.generate.splits import draw_splits

        # After every store is in, so that sources generated in the same run are found.
        for spec, path in zip(specs, paths, strict=True):
            _print_draw(draw_splits(path, spec.split_seeds, spec.splits, spec.mixed_sources))


def _resolve_with_n(config: LoadedConfig, name: str, profile: str | None, n: int | None) -> DatasetSpec:
    """``config.resolve`` with ``--n`` checked here first, so that its errors name the flag
    (the library names the parameter, ``pool_size``)."""
    entry = config.config.datasets.get(name)
    if n is not None and entry is not None:
        if entry.poses is not None:
            raise _UserError(f"{config.path}: datasets.{name}: --n: the poses {entry.poses!r} fix the pool size "
                             f"(value {n})")
        if n < 1:
            raise _UserError(f"--n: the pool size must be ≥ 1 (value {n})")
    return config.resolve(name, profile, n)


def parse_seeds(text: str) -> tuple[int, ...]:
    """``--seeds``: ``"0-4"``, ``"0,2,7"`` or ``"3"`` → sorted distinct seeds.

    Raises:
        SplitError: not such a list, or a negative seed.
    """
    from synthcal.store.splits import SplitError

    seeds: set[int] = set()
    try:
        for part in text.split(","):
            first, _, last = part.strip().partition("-")
            low, high = int(first), int(last or first)
            if high < low:
                raise ValueError
            seeds.update(range(low, high + 1))
    except ValueError:
        raise SplitError(f"--seeds: expected e.g. 0-4 or 0,2,5 with seeds ≥ 0 (value {text!r})") from None
    return tuple(sorted(seeds))


def _print_draw(result: DrawResult) -> None:
    """One line per store drawn by ``split`` / ``generate --splits``."""
    drawn = ", ".join(map(str, result.drawn)) or "none"
    unchanged = f"; unchanged: {', '.join(map(str, result.unchanged))}" if result.unchanged else ""
    print(f"{result.store}  splits drawn for seeds {drawn}{unchanged}")
    if result.note:
        print(f"  note: {result.note}")


def _cmd_split(args: argparse.Namespace) -> None:
    from synthcal.generate.splits import draw_splits, split_sizes
    from synthcal.store import open_store
    from synthcal.store.splits import store_spec

    spec = store_spec(open_store(args.store), args.store)
    overrides = {name: getattr(args, name) for name in ("train", "test", "dictionary")}
    for name, value in overrides.items():  # here, so that the message names the flag
        if value is not None and value < 1:
            raise _UserError(f"--{name}: a split size must be an integer ≥ 1 (value {value!r})")
    sizes = split_sizes(spec.splits, **{k: v for k, v in overrides.items() if v is not None})
    seeds = parse_seeds(args.seeds) if args.seeds else None
    _print_draw(draw_splits(args.store, seeds, sizes))


def _cmd_worldcup_stats(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import load_scene
    from synthcal.generate.worldcup import (
        bird_eye_to_pitch,
        camera_fields,
        convert_homographies,
        in_grid,
        load_worldcup_poses,
    )

    config = load_config(args.config)
    spec = config.resolve("worldcup2014")
    grid = config.config.grids[args.grid]
    scene = load_scene(spec)
    poses = load_worldcup_poses()
    H = convert_homographies(poses.homographies, spec.image_size)
    fields = camera_fields(H, scene, spec.image_size, spec.focal_reference_width)
    inside = in_grid(fields, grid)
    n = len(H)
    print(f"World Cup 2014: {n} real cameras ({', '.join(f'{k} {b - a}' for k, (a, b) in poses.partition.items())}),"
          f" fitted at {spec.image_size[0]} × {spec.image_size[1]}, focal at width {spec.focal_reference_width}")
    print(f"{'':10s}{'min':>9s}{'median':>9s}{'max':>9s}   grid {args.grid!r}")
    fields["x"], fields["y"] = bird_eye_to_pitch(fields["x"], fields["y"])
    fields["z"] = fields["z"] / scene.pixels_per_metre
    for axis in ("pan_deg", "tilt_deg", "focal_px", "roll_deg", "x", "y", "z", "rms_px"):
        values = fields[axis]
        rule = ""
        if axis in inside:
            limits = getattr(grid, axis)
            rule = f"{limits.start:g}..{limits.stop:g}: {inside[axis].sum()} inside"
        label = f"{axis} (m)" if axis in ("x", "y", "z") else axis
        print(f"{label:10s}{values.min():9.1f}{np.median(values):9.1f}{values.max():9.1f}   {rule}")
    print("(x, y: pitch metres, y growing away from the camera; z: height)")
    print(f"inside the {args.grid!r} grid's pan, tilt and focal ranges: {inside['all'].sum()} of {n} "
          f"({100 * inside['all'].mean():.1f} %)")
    if args.montage is not None:
        from synthcal.generate.pipeline import render_samples
        from synthcal.viz import sample_strip, tile, write_png

        # Rendered exactly as in the store (same appearance stream per pool index).
        first, stop = poses.partition["test"]
        strips = []
        for k in np.linspace(first, stop - 1, args.count).round().astype(int):
            image, semantic = render_samples(scene, H[k:k + 1], int(k), spec)
            strips.append(sample_strip(image[0], semantic[0], scene.palette))
        print(f"montage of {args.count} test poses: {write_png(args.montage, tile(strips, columns=2))}")


def _cmd_info(args: argparse.Namespace) -> None:
    from synthcal.store import array_at, attributes, open_store

    group = open_store(args.store, allow_incomplete=True)
    attrs = attributes(group)
    if args.json:
        print(json.dumps(attrs, indent=2))
        return
    scene = attrs["scene"]
    width, height = attrs["image_size"]
    print(f"store        {args.store}  ({'complete' if attrs.get('complete') else 'INCOMPLETE'})")
    print(f"dataset      {attrs['dataset']}  ({attrs['format_version']})")
    print(f"samples      {attrs['N']} at {width} × {height}, {attrs['shard_size']} per shard, seed {attrs['seed']}")
    print(f"scene        {scene['name']}: {', '.join(f'{i} {c}' for i, c in enumerate(scene['classes']))}")
    scene_height, scene_width = array_at(group, "scene/semantic").shape
    print(f"scene size   {scene_width} × {scene_height} px, "
          f"heading {scene['heading_deg']:g}°")
    for axis, values in (attrs["grid"] or {}).items():
        if isinstance(values, dict):
            print(f"grid {axis:<8s} {values['start']:g}..{values['stop']:g} step {values['step']:g}")
    if attrs.get("poses"):
        parts = ", ".join(f"{name} {b - a}" for name, (a, b) in attrs["poses"]["partition"].items())
        print(f"poses        {attrs['poses']['set']}: {parts} (given cameras)")
    print(f"config hash  {attrs['config_hash'][:16]}…")
    print(f"software     {', '.join(f'{k} {v}' for k, v in attrs['software'].items())}")
    _print_splits(group)


def _cmd_verify(args: argparse.Namespace) -> int:
    """Exit 0 when every store is whole, 1 when any file is damaged (each one printed)."""
    from synthcal.store import verify_store

    status = 0
    for store in args.stores:
        report = verify_store(store)
        for note in report.notes:
            print(f"note: {note}")
        if report.ok:
            print(f"OK {store}")
        else:
            status = 1
            print(f"DAMAGED {store}")
            for problem in report.problems:
                print(f"  {problem}")
    return status


def _print_splits(group: zarr.Group) -> None:
    from synthcal.store import array_at, attributes, group_at
    from synthcal.store.splits import drawn_seeds

    for seed in drawn_seeds(group):
        sub = group_at(group, f"splits/seed-{seed}")
        sizes = ", ".join(f"{name} {array_at(sub, name).shape[0]}"
                          for name in ("train", "test", "dictionary") if name in sub)
        mixed = ""
        if "mixed_dictionary" in sub:
            sources = attributes(group_at(sub, "mixed_dictionary"))["sources"]
            mixed = (f", mixed dictionary {array_at(sub, 'mixed_dictionary/index').shape[0]} from "
                     f"{', '.join(sources)}")
        print(f"split seed {seed} {sizes}{mixed}")


def _cmd_show(args: argparse.Namespace) -> None:
    from synthcal.store import attributes, open_store, read_samples
    from synthcal.viz import sample_strip, tile, write_png

    group = open_store(args.store)
    size = attributes(group)["N"]
    count = min(args.n, size)
    index = np.linspace(0, size - 1, count).round().astype(np.int64)
    samples = read_samples(group, index)
    palette = attributes(group)["scene"]["palette"]
    strips = [sample_strip(samples["image"][k], samples["semantic"][k], palette) for k in range(count)]
    print(write_png(args.output, tile(strips, columns=args.columns)))


def _cmd_demo(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import generate_dataset
    from synthcal.store import attributes, open_store, read_samples
    from synthcal.viz import sample_strip, tile, write_png

    config = load_config(args.config)
    out = Path(args.out)
    strips = []
    print(f"synthcal demo: profile {args.profile!r}, {args.workers} workers, output in {out}/")
    for name in config.dataset_names:
        spec = config.resolve(name, args.profile)
        started = time.perf_counter()
        path = generate_dataset(spec, out, workers=args.workers, progress=True)
        group = open_store(path)
        size = sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
        print(f"  {name:16s} {spec.pool_size:6d} samples  {time.perf_counter() - started:6.1f} s  "
              f"{size / spec.pool_size / 1024:6.1f} KiB/sample  {path}")
        samples = read_samples(group, np.arange(2))
        palette = attributes(group)["scene"]["palette"]
        strips += [sample_strip(samples["image"][k], samples["semantic"][k], palette) for k in range(2)]
    montage = write_png(out / "montage.png", tile(strips, columns=2))
    print(f"montage: {montage}  (per scene two samples: image | semantic map | overlay)")
    if args.no_bench:
        return
    _demo_bench(args, config, out)


# The demo's small benchmark: one scene, the two references and the two models
# with true segmentation (the UNet is the costly part on a CPU), a few seeds.
DEMO_DATASET = "intersection-1"
DEMO_ESTIMATORS = ("identity", "template", "baseline", "proposed")
DEMO_SEEDS = "0-4"


def _demo_bench(args: argparse.Namespace, config: LoadedConfig, out: Path) -> None:
    from synthcal.eval.harness import expand_runs, run_sweep
    from synthcal.generate.pipeline import store_path
    from synthcal.generate.splits import draw_splits

    seeds = parse_seeds(DEMO_SEEDS)
    store = store_path(out, DEMO_DATASET)
    _print_draw(draw_splits(store, seeds))
    training = config.training(args.profile)
    print(f"benchmark: {DEMO_DATASET}, seeds {DEMO_SEEDS}, {', '.join(DEMO_ESTIMATORS)}; "
          f"segmentation {training.segmentation}, training step-by-step, loss top-mse, matching top-mse")
    started = time.perf_counter()
    runs = expand_runs(out, [DEMO_DATASET], DEMO_ESTIMATORS, seeds, args.profile, training.settings(),
                       segmentations=(training.segmentation,))
    frame = run_sweep(runs, out / "results", device=args.device)
    print(f"benchmark: {len(runs)} runs in {time.perf_counter() - started:.0f} s; results in {out / 'results'}\n")
    _print_tables(frame, None, "md", False)


def _print_tables(frame: pd.DataFrame, layout: str | None, fmt: str, compare_paper: bool,
                  metric: str = "iou") -> None:
    """Print the tables of a results frame, one per segmentation / profile in it.

    ``layout`` None picks ``models`` for own-dictionary datasets and ``mixed`` for
    mixed ones, each where there are results. ``metric``: the column shown.
    """
    from synthcal.eval.harness import table_runs
    from synthcal.eval.tables import format_table

    if frame.empty:
        raise _UserError("no finished runs in the results folder")
    frame = table_runs(frame)
    for title, part in _split_by(frame, ("segmentation", "profile")):
        mixed = part["dataset"].str.startswith("mixed-")
        layouts = [layout] if layout else [name for name, rows in (("models", ~mixed), ("mixed", mixed)) if rows.any()]
        for name in layouts:
            if title and fmt != "csv":
                print(f"{'%' if fmt == 'latex' else '###'} {title}\n")
            try:
                print(format_table(part, name, fmt, value=metric, compare_paper=compare_paper,
                                   aliases={"soccer": "worldcup2014"}))
            except ValueError as error:
                raise _UserError(f"table {name!r}: {error}") from None


def _split_by(frame: pd.DataFrame, keys: Sequence[str]) -> list[tuple[str, pd.DataFrame]]:
    """Parts of ``frame`` with one value of each key; rows where a key is missing join every part."""
    parts = [("", frame)]
    for key in keys:
        values = sorted(frame[key].dropna().unique())
        if len(values) <= 1:
            continue
        parts = [(f"{title}; {key}: {value}".lstrip("; "), part[(part[key] == value) | part[key].isna()])
                 for title, part in parts for value in values]
    return parts


class _UserError(ValueError):
    """A problem with the user's request, printed without a traceback."""


def _cmd_bench(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.eval.harness import expand_runs, run_sweep

    training = load_config(args.config).training(args.profile)
    segmentations = args.segmentation or [training.segmentation]
    runs = expand_runs(args.data, args.datasets, args.estimator, parse_seeds(args.seeds), args.profile,
                       training.settings(), args.training, args.loss, args.matching, segmentations)
    started = time.perf_counter()
    frame = run_sweep(runs, args.results, device=args.device, scheduler=args.scheduler, progress=not args.quiet,
                      timeout=args.timeout or None)
    ids = {run.id for run in runs}
    frame = frame[frame["run_id"].isin(ids)]
    failed = frame[frame["status"] != "ok"]
    print(f"{len(runs)} runs ({len(failed)} failed) in {time.perf_counter() - started:.0f} s; "
          f"results in {args.results}\n")
    for row in failed.itertuples():
        print(f"  failed: {row.run_id}: {row.error or 'no reason recorded'}")
    _print_tables(frame, None, "md", False)


def _cmd_table(args: argparse.Namespace) -> None:
    from synthcal.eval.harness import collect_results
    from synthcal.eval.metrics import METRICS
    from synthcal.eval.tables import failed_runs

    if args.metric not in METRICS:
        raise _UserError(f"--metric: unknown metric {args.metric!r}; one of {', '.join(METRICS)}")
    if not args.results.is_dir():
        raise _UserError(f"{args.results}: no such results folder")
    frame = collect_results(args.results)
    if frame.empty:
        raise _UserError(f"{args.results}: no finished runs")
    _print_tables(frame, args.layout, args.format, args.compare_paper, args.metric)
    # Failed runs count in the means (IoU 0, completeness 0); say which and why, off stdout for CSV.
    for line in failed_runs(frame):
        if args.format == "csv":
            print(line, file=sys.stderr)
        else:
            print(("% " if args.format == "latex" else "") + line)


def _cmd_plot(args: argparse.Namespace) -> None:
    from synthcal.eval.harness import collect_results
    from synthcal.eval.plots import plot_iou, plot_overlays

    frame = collect_results(args.results)
    if frame.empty:
        raise _UserError(f"{args.results}: no finished runs")
    print(plot_iou(frame, args.output / "iou.png"))
    for dataset in dict.fromkeys(frame["dataset"]):
        print(plot_overlays(args.results, frame, dataset, args.output / f"overlays-{dataset}.png", args.count))


# = synthcal.eval.harness.DEFAULT_TIMEOUT, written out so that parsing imports no torch.
_DEFAULT_TIMEOUT = 21600.0


def _seconds(text: str) -> float:
    """``--timeout``: a number of seconds, 0 or more."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds >= 0")
    return value


def _add_config(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, default=None,
                        help="datasets.yaml to use (default: ./datasets.yaml, else the packaged one)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="synthcal", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("scenes", help="list the scenes")
    _add_config(p)
    p.set_defaults(func=_cmd_scenes)

    p = sub.add_parser("scene", help="draw one scene (bird's-eye RGB and semantic map)")
    p.add_argument("name")
    p.add_argument("-o", "--output", type=Path, required=True)
    _add_config(p)
    p.set_defaults(func=_cmd_scene)

    p = sub.add_parser("generate", help="generate the sharded store of datasets")
    p.add_argument("datasets", nargs="+", metavar="DATASET")
    p.add_argument("--profile", default=None, help="profile of datasets.yaml (smoke, demo, quick, paper)")
    p.add_argument("--out", type=Path, required=True, help="folder receiving DATASET.zarr")
    p.add_argument("--workers", type=int, default=1, help="local worker processes (default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the shards on this Dask scheduler")
    p.add_argument("--n", type=int, default=None, help="pool size (overrides the configuration)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--splits", action="store_true",
                   help="then draw the train/test/dictionary splits of every seed (and mixed dictionaries)")
    _add_config(p)
    p.set_defaults(func=_cmd_generate)

    p = sub.add_parser("split", help="draw the per-seed train/test/dictionary splits inside a store")
    p.add_argument("store", type=Path)
    p.add_argument("--seeds", default=None, help="e.g. 0-4 or 0,2,5 (default: the store's split_seeds)")
    for name in ("train", "test", "dictionary"):
        p.add_argument(f"--{name}", type=int, default=None, metavar="N",
                       help=f"{name} size (default: the store's recorded configuration)")
    p.set_defaults(func=_cmd_split)

    p = sub.add_parser("worldcup-stats", help="the real World Cup 2014 cameras against a camera grid")
    p.add_argument("--grid", default="soccer", help="grid of datasets.yaml (default soccer)")
    p.add_argument("--montage", type=Path, default=None, help="also render test poses into this PNG")
    p.add_argument("--count", type=int, default=12, help="test poses in the montage (default 12)")
    _add_config(p)
    p.set_defaults(func=_cmd_worldcup_stats)

    p = sub.add_parser("info", help="what a store holds (from its attributes)")
    p.add_argument("store", type=Path)
    p.add_argument("--json", action="store_true", help="print the raw attributes")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("verify", help="read stores back whole: manifest, every shard index and chunk checksum, "
                                       "every chunk decodes; exit 1 when any file is damaged")
    p.add_argument("stores", nargs="+", type=Path, metavar="STORE")
    p.set_defaults(func=_cmd_verify)

    p = sub.add_parser("show", help="montage of samples: image | semantic | overlay")
    p.add_argument("store", type=Path)
    p.add_argument("-n", type=int, default=16)
    p.add_argument("-o", "--output", type=Path, required=True)
    p.add_argument("--columns", type=int, default=None)
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("demo", help="generate every built-in dataset at demo size, draw a montage, "
                                     "run a small benchmark on one scene and print its table")
    p.add_argument("--out", type=Path, default=Path("demo_out"))
    p.add_argument("--profile", default="demo")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--device", default="auto", help="torch device of the models (default auto)")
    p.add_argument("--no-bench", action="store_true", help="generate and draw only")
    _add_config(p)
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("bench", help="fit and score estimators over datasets and seeds (resumable)")
    p.add_argument("--data", type=Path, required=True, help="folder holding the stores NAME.zarr")
    p.add_argument("--datasets", nargs="+", required=True, metavar="NAME",
                   help="dataset labels: NAME (its store) or mixed-K / mixed-NAME (a mixed dictionary)")
    p.add_argument("--estimator", nargs="+", required=True, metavar="NAME_OR_PATH",
                   help="bundled name (identity, template, ecc, baseline, proposed), entry point or module:Class")
    p.add_argument("--seeds", default="0-4", help="split seeds, e.g. 0-4 or 0,2 (default 0-4)")
    p.add_argument("--profile", default=None, help="training sizes of datasets.yaml (smoke, demo, quick, paper)")
    p.add_argument("--results", type=Path, required=True, help="results folder (runs/, cache/)")
    from synthcal.config import LOSSES, MATCHINGS, SEGMENTATIONS, TRAININGS  # the vocabularies, defined once

    p.add_argument("--training", nargs="+", default=["step-by-step"], choices=TRAININGS)
    p.add_argument("--loss", nargs="+", default=["top-mse"], choices=LOSSES)
    p.add_argument("--matching", nargs="+", default=["top-mse"], choices=MATCHINGS)
    p.add_argument("--segmentation", nargs="+", default=None, choices=SEGMENTATIONS,
                   help="default: the profile's")
    p.add_argument("--device", default="auto", help="torch device: auto (CUDA when available), cpu, cuda")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the runs on this Dask scheduler")
    p.add_argument("--timeout", type=_seconds, default=_DEFAULT_TIMEOUT, metavar="SECONDS",
                   help="time limit of each run, which runs in a process of its own; one that exceeds it, "
                        "crashes or exits is recorded as failed and the sweep goes on "
                        f"(default {_DEFAULT_TIMEOUT:g} = 6 h; 0: none)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    _add_config(p)
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("table", help="the paper's tables from a results folder")
    p.add_argument("results", type=Path)
    p.add_argument("--layout", choices=["models", "matching", "mixed"], default=None,
                   help="default: models (own dictionaries) and mixed (mixed dictionaries) where present")
    p.add_argument("--format", choices=["md", "latex", "csv"], default="md")
    p.add_argument("--compare-paper", action="store_true",
                   help="add the published figures (for each reading of the paper's IoU: iou, iou_bg, iou_weighted)")
    p.add_argument("--metric", default="iou",
                   help="iou (default; mean over classes 1-3), iou_bg (classes 0-3), iou_weighted (sklearn's "
                        "weighted Jaccard, as the public re-implementation of Sha et al.), iou_part, iou_whole")
    p.set_defaults(func=_cmd_table)

    p = sub.add_parser("plot", help="IoU bars per dataset and estimator, and overlays of test images")
    p.add_argument("results", type=Path)
    p.add_argument("-o", "--output", type=Path, required=True, help="folder receiving the PNGs")
    p.add_argument("--count", type=int, default=3, help="test images per overlay figure (default 3)")
    p.set_defaults(func=_cmd_plot)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``synthcal`` console script."""
    from synthcal.config import ConfigError
    from synthcal.estimators import EstimatorError
    from synthcal.generate.scenes import SceneError
    from synthcal.store import StoreError

    args = build_parser().parse_args(argv)
    default_format = warnings.formatwarning
    warnings.formatwarning = functools.partial(_format_warning, default_format)
    try:
        status = args.func(args)
    except (ConfigError, SceneError, StoreError, EstimatorError, _UserError) as exc:
        print(f"synthcal: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # disk full, permission denied, a folder where a file should be: name the path
        where = ": ".join(str(name) for name in (exc.filename, exc.filename2) if name is not None)
        print(f"synthcal: error: {where + ': ' if where else ''}{exc.strerror or exc}", file=sys.stderr)
        return 2
    finally:
        warnings.formatwarning = default_format
    return status if isinstance(status, int) else 0


def _format_warning(default: Callable[..., str], message: Warning | str, category: type[Warning],
                    *args: Any, **kwargs: Any) -> str:
    """synthcal's own warnings as ``synthcal: warning: …`` (they name their file); others as Python does."""
    if category.__module__.startswith("synthcal"):
        return f"synthcal: warning: {message}\n"
    return default(message, category, *args, **kwargs)


if __name__ == "__main__":
    sys.exit(main())
