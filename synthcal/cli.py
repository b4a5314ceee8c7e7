"""The ``synthcal`` command line: one module, one sub-command per job.

Errors that come from the user's input (configuration, files, stores) are printed
as one clear message with exit status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from synthcal.config.vocabulary import DEFAULT_READING, DESCRIPTIONS, METRICS

if TYPE_CHECKING:
    import pandas as pd
    import zarr

    from synthcal.config import DatasetSpec, LoadedConfig
    from synthcal.eval.runs import Run
    from synthcal.generate.splits import DrawResult

__all__ = ["main"]


def _cmd_scenes(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.scenes import BUILTIN_SCENES

    user = load_config(args.config).config.scenes
    width = max(16, *map(len, BUILTIN_SCENES), *map(len, user))
    for name, description in BUILTIN_SCENES.items():
        print(f"{name:{width}s} built in   {description}")
    for name, scene in user.items():
        if scene.osm is not None:
            lat, lon = scene.osm.center
            print(f"{name:{width}s} osm        {scene.osm.file} around ({lat}, {lon}), © OpenStreetMap contributors")
        else:
            print(f"{name:{width}s} user       {scene.image} + {scene.semantic}")


def _parse_pair(text: str, what: str) -> tuple[float, float]:
    """``"52.1,5.2"`` → (52.1, 5.2); argparse reports a ValueError as a bad value of the option."""
    try:
        first, second = (float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, two numbers separated by a comma (value {text!r})") \
            from None
    return first, second


def _cmd_osm(args: argparse.Namespace) -> None:
    import cv2

    from synthcal.scenes.osm import build_osm_scene
    from synthcal.utils.atomic import atomic_write

    scene = build_osm_scene(args.file, args.center, args.size, args.ppm, name=args.name, seed=args.seed)
    pictures = {"image.png": scene.image[..., ::-1], "semantic.png": scene.semantic}
    args.out.mkdir(parents=True, exist_ok=True)  # only once the scene is built: a bad input writes nothing
    for filename, array in pictures.items():
        ok, encoded = cv2.imencode(".png", array)
        if not ok:
            raise OSError(f"{args.out / filename}: could not encode the PNG")
        with atomic_write(args.out / filename) as tmp:
            tmp.write_bytes(encoded.tobytes())
    height, width = scene.semantic.shape
    lat, lon = args.center
    # A path in a YAML file is read relative to that file's folder, wherever the command runs.
    file = Path(os.path.relpath(args.file.absolute(), args.yaml.absolute().parent)).as_posix()
    print(f"# wrote {args.out / 'image.png'} and {args.out / 'semantic.png'} ({width} × {height} px, classes "
          f"{', '.join(f'{i} {c}' for i, c in enumerate(scene.classes))}); map data "
          f"© OpenStreetMap contributors, ODbL")
    print(f"# A datasets.yaml layered over the packaged one, for {args.yaml} (`file:` is relative to its folder): "
          "save it there, or paste its entries under scenes: and datasets: of yours.")
    print(f"scenes:\n  {scene.name}:\n    osm: {{file: {json.dumps(file)}, center: [{lat}, {lon}], "
          f"size_m: [{args.size[0]:g}, {args.size[1]:g}], pixels_per_metre: {args.ppm:g}, seed: {args.seed}}}")
    print(f"datasets:\n  {scene.name}: {{scene: {scene.name}, grid: intersection, pool_size: 200000}}")


def _cmd_osm_junctions(args: argparse.Namespace) -> None:
    from synthcal.scenes.osm.junctions import datasets_snippet, find_junctions, mix_name, rank, write_csv
    from synthcal.utils.atomic import atomic_write

    if args.datasets < 0:
        raise _UserError(f"--datasets: K must be ≥ 0 (value {args.datasets})")
    if args.mix_for and not args.datasets:
        raise _UserError(f"--mix-for {args.mix_for}: needs --datasets K, the junctions its dictionary draws on")
    junctions = find_junctions(args.file, args.bbox, args.legs)
    if args.like:
        junctions = rank(junctions, args.like)
    with atomic_write(args.csv) as tmp:
        write_csv(junctions, tmp)
    print(f"{args.csv}: {len(junctions)} junctions{' most like ' + args.like + ' first' if args.like else ''}")
    if args.datasets:
        yaml_path = args.yaml or args.csv.with_suffix(".datasets.yaml")
        top = junctions[: args.datasets]
        text = datasets_snippet(top, args.file, yaml_path.parent, mix_for=args.mix_for, align_to=args.like)
        with atomic_write(yaml_path) as tmp:
            tmp.write_text(text, encoding="utf-8")
        mixes = (f"{args.mix_for}'s mixed dictionary (bench label mixed-{mix_name(args.mix_for, len(top))})"
                 if args.mix_for else "mixed dictionaries")
        print(f"{yaml_path}: scenes, datasets and {mixes} of the first {len(top)}")


def _cmd_datasets(args: argparse.Namespace) -> None:
    from synthcal.config import load_config

    config = load_config(args.config)
    mixed = config.config.mixed_dictionaries
    labels = {target: f"mixed-{short}" if (short := target.removeprefix("intersection-")).isdigit()
              else f"mixed-{target}" for target in mixed}
    width = max(16, *map(len, config.dataset_names), *map(len, labels.values()))
    print(f"{'DATASET':{width}s} generate and bench ({'profile ' + repr(args.profile) if args.profile else 'no profile'})")
    for name in config.dataset_names:
        print(f"{name:{width}s} {_describe_dataset(config, name, args.profile)}")
    if mixed:
        print(f"\n{'LABEL':{width}s} bench only: a dataset's own train/test sets with a mixed dictionary")
    for target, sources in mixed.items():
        pool = config.config.datasets[target].same_pool_as
        owner = f"{target}'s (= {pool}'s)" if pool else f"{target}'s"
        print(f"{labels[target]:{width}s} {owner} train/test sets; templates from {', '.join(sources)}")


def _cmd_config_show(args: argparse.Namespace) -> None:
    from synthcal.config import load_config, packaged_config_path, show_layered

    config = load_config(args.config)
    packaged = config.layers[0]

    def label(path: Path) -> str:
        return "packaged" if path == packaged else str(path)

    print(f"# {' + '.join(label(p) for p in config.layers)} (packaged: {packaged_config_path()}); "
          "each value's comment names the file it came from")
    print(show_layered(config.raw, config.origins, label), end="")


def _cmd_config_init(args: argparse.Namespace) -> None:
    from synthcal.config import STARTER

    try:
        with args.path.open("x", encoding="utf-8") as file:  # "x": never overwrite, even if it appears meanwhile
            file.write(STARTER)
    except FileExistsError:
        raise _UserError(f"{args.path}: exists; `synthcal config init` never overwrites a file "
                         "(give another path, or remove it)") from None
    print(f"wrote {args.path}: a starter layered over the packaged configuration; "
          f"`synthcal config show --config {args.path}` prints the result")


def _describe_dataset(config: LoadedConfig, name: str, profile: str | None) -> str:
    """One line on a dataset: its scene, its cameras and pool size, where its dictionary comes from."""
    entry = config.config.datasets[name]
    spec = config.resolve(name, profile)
    kind = "user scene" if entry.scene in config.config.scenes else "scene"
    if entry.poses is not None:
        cameras = f"the {spec.pool_size} real cameras of {entry.poses!r} (fixed train/test sets)"
    else:
        cameras = f"{spec.pool_size:,} samples from grid {entry.grid!r}"
    source = f"; dictionary from {', '.join(spec.mixed_sources)}" if not spec.own_dictionary else ""
    if entry.same_pool_as is not None:
        source = f"; {entry.same_pool_as}'s pool and splits (same_pool_as)"
    return f"{kind} {entry.scene!r}, {cameras} at {spec.image_size[0]} × {spec.image_size[1]}{source}"


def _cmd_scene(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import load_scene
    from synthcal.scenes import draw_scene

    config = load_config(args.config)
    dataset = next((d for d, e in config.config.datasets.items() if e.scene == args.name), None)
    if dataset is not None:
        scene = load_scene(config.resolve(dataset))
    else:
        from synthcal.scenes import build_scene

        scene = build_scene(args.name)
    print(write_picture(args.output, draw_scene(scene)))


def _cmd_generate(args: argparse.Namespace) -> int:
    """Exit 0, or 1 when the user declines the preview's question (nothing written)."""
    from synthcal.config import load_config
    from synthcal.generate.pipeline import generate_dataset, store_path

    _check_folder(args.out, "--out")
    config = load_config(args.config)
    specs = [_resolve_with_n(config, name, args.profile, args.n) for name in args.datasets]  # validate all first
    if not _preview_generation(specs, args):
        print("synthcal: nothing generated", file=sys.stderr)
        return 1
    paths = []
    for spec in specs:
        complete = store_path(args.out, spec.name).exists()
        started = time.perf_counter()
        path = generate_dataset(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                                progress=_progress(args), max_memory=args.max_memory)
        paths.append(path)
        took = "already complete" if complete else f"{time.perf_counter() - started:.1f} s"
        print(f"{path}  {spec.pool_size} samples  {took}")
    if args.splits:
        from synthcal.generate.splits import draw_splits

        # After every store is in, so that sources generated in the same run are found.
        for spec, path in zip(specs, paths, strict=True):
            _print_draw(draw_splits(path, spec.split_seeds, spec.splits, spec.mixed_sources))
    return 0


# Above these, a run asks before it starts (on a terminal, without --yes).
CONFIRM_BYTES = 5e9
CONFIRM_SECONDS = 600.0


def _preview_generation(specs: Sequence[DatasetSpec], args: argparse.Namespace) -> bool:
    """One line per store to generate (samples, disk, time here, measured); whether to go on.

    Off a terminal or with ``--yes`` nothing is asked, so nothing is measured either
    (8 samples rendered cost ~0.2 s per store): the line gives the samples only.
    """
    from synthcal.generate.pipeline import store_path
    from synthcal.generate.preview import estimate_generation

    workers = 1 if args.scheduler else args.workers
    where = "on the cluster: unknown; here with 1 worker" if args.scheduler else \
        f"here with {workers} worker{'s' if workers > 1 else ''}"
    asking = _can_ask(args)
    total_bytes = total_seconds = 0.0
    for spec in specs:
        if store_path(args.out, spec.name).exists():  # reported as already complete afterwards
            continue
        if not asking:
            print(f"{spec.name}: {spec.pool_size:,} samples {where} (disk and time not estimated: "
                  "nothing to ask with --yes or off a terminal)", flush=True)
            continue
        estimate = estimate_generation(spec, args.out, workers)
        resumed = f" ({estimate.remaining:,} still to render)" if estimate.remaining < estimate.samples else ""
        print(f"{spec.name}: {estimate.samples:,} samples{resumed}, about {_size(estimate.bytes)} on disk, "
              f"about {_duration(estimate.seconds)} {where} (measured on {min(8, estimate.samples)} samples)",
              flush=True)
        total_bytes += estimate.bytes
        total_seconds += estimate.seconds
    if total_bytes <= CONFIRM_BYTES and total_seconds <= CONFIRM_SECONDS:
        return True
    return _confirm(args, f"generate about {_size(total_bytes)} in about {_duration(total_seconds)}?")


def _size(count: float) -> str:
    """Bytes in words: ``14.2 GB``, ``310 MB``, ``12 kB`` (decimal units, as disks are sold)."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6)):
        if count >= scale:
            return f"{count / scale:.1f} {unit}"
    return f"{count / 1e3:.0f} kB"


def _duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``3.5 h``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _can_ask(args: argparse.Namespace) -> bool:
    """Whether a question can be asked: no ``--yes``, standard input and error on a terminal."""
    from synthcal.utils.progress import interactive

    return not args.yes and interactive(sys.stdin) and interactive(sys.stderr)


def _confirm(args: argparse.Namespace, question: str) -> bool:
    """Ask ``question`` on a terminal (standard input and error both); off one, or with ``--yes``, go on."""
    if not _can_ask(args):
        return True
    print(f"{question} [y/N] (--yes skips this question) ", end="", file=sys.stderr, flush=True)
    try:
        answer = input()
    except EOFError:
        answer = ""
    return answer.strip().lower() in ("y", "yes")


def _check_folder(path: Path, flag: str) -> None:
    """Refuse a file where a folder is expected, before anything is written."""
    if path.exists() and not path.is_dir():
        raise _UserError(f"{flag} {path}: a file of that name exists; {flag} names a folder")


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
    rendered = f"; {result.rendered} image(s) rendered" if result.rendered else ""
    print(f"{result.store}  splits drawn for seeds {drawn}{unchanged}{rendered}")
    if result.note:
        print(f"  note: {result.note}")


def _cmd_split(args: argparse.Namespace) -> None:
    from synthcal.generate.splits import draw_splits, split_sizes
    from synthcal.store import open_store
    from synthcal.store.splits import store_spec

    spec = store_spec(open_store(args.store, writer=True), args.store)  # a writer: it reseals a killed one's work
    overrides = {name: getattr(args, name) for name in ("train", "test", "dictionary", "validation")}
    for name, value in overrides.items():  # here, so that the message names the flag
        least = 0 if name == "validation" else 1
        if value is not None and value < least:
            raise _UserError(f"--{name}: a split size must be an integer ≥ {least} (value {value!r})")
    sizes = split_sizes(spec.splits, **{k: v for k, v in overrides.items() if v is not None})
    seeds = parse_seeds(args.seeds) if args.seeds else None
    _print_draw(draw_splits(args.store, seeds, sizes))


def _cmd_import(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.frames import frames_spec, import_frames, read_frames, with_frames

    config = load_config(args.config)
    name = args.name or args.folder.resolve().name
    spec = frames_spec(config, name, args.scene, args.layout, args.profile,
                       tuple(args.dictionary_from) if args.dictionary_from else None)
    frames = read_frames(args.folder, args.layout, args.test_fraction, spec.pool_entropy)
    spec = with_frames(spec, frames, config, args.profile, args.dictionary)
    path, written = import_frames(frames, spec, args.out)
    parts = ", ".join(f"{part} {stop - start}" for part, (start, stop) in frames.partition.items())
    print(f"{path}  {len(frames.frames)} frames ({parts}) at {spec.image_size[0]} × {spec.image_size[1]}"
          f"{'' if written else ', already imported'}; dictionary from {', '.join(spec.mixed_sources)}: "
          f"generate them into {args.out}, then run `synthcal split {path}`")


def _cmd_worldcup_stats(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import load_scene
    from synthcal.generate.worldcup import montage_poses, real_camera_lines, real_cameras

    config = load_config(args.config)
    spec = config.resolve("worldcup2014")
    grid = config.config.grids[args.grid]
    scene = load_scene(spec)
    cameras = real_cameras(spec, scene, grid)
    print("\n".join(real_camera_lines(cameras, spec, args.grid, grid)))
    if args.montage is not None:
        from synthcal.generate.pipeline import render_samples
        from synthcal.viz import sample_strip, tile

        # Rendered exactly as in the store (same appearance stream per pool index).
        strips = []
        for k in montage_poses(cameras.poses, args.count):
            image, semantic = render_samples(scene, cameras.homographies[k:k + 1], int(k), spec)
            strips.append(sample_strip(image[0], semantic[0], scene.palette))
        print(f"montage of {args.count} test poses: {write_picture(args.montage, tile(strips, columns=2))}")


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
    if isinstance(images := attrs.get("images"), dict):  # images: splits (absent: every image stored)
        print(f"images       splits: {images.get('rendered')} of {attrs['N']} rendered"
              f"{' (rendering unfinished: rerun `synthcal split`)' if images.get('state') == 'rendering' else ''}")
    else:
        print("images       all")
    print(f"scene        {scene['name']}: {', '.join(f'{i} {c}' for i, c in enumerate(scene['classes']))}")
    scene_height, scene_width = array_at(group, "scene/semantic").shape
    print(f"scene size   {scene_width} × {scene_height} px, "
          f"heading {scene['heading_deg']:g}°")
    if isinstance(source := scene.get("source"), dict):
        _print_scene_source(source)
    for axis, values in (attrs["grid"] or {}).items():
        if isinstance(values, dict):
            print(f"grid {axis:<8s} {values['start']:g}..{values['stop']:g} step {values['step']:g}")
    if attrs.get("poses"):
        parts = ", ".join(f"{name} {b - a}" for name, (a, b) in attrs["poses"]["partition"].items())
        print(f"poses        {attrs['poses']['set']}: {parts} (given cameras)")
    _print_pool(attrs)
    print(f"config hash  {attrs['config_hash'][:16]}…")
    print(f"software     {', '.join(f'{k} {v}' for k, v in attrs['software'].items())}")
    _print_splits(group)


def _print_scene_source(source: dict) -> None:
    """``info``'s lines on where a scene came from (an OpenStreetMap extract): file, window, licence."""
    if source.get("kind") == "openstreetmap":
        lat, lon = source["center"]
        width, height = source["size_m"]
        print(f"scene source OpenStreetMap {source['file']} (sha256 {source['sha256'][:12]}…) around ({lat}, {lon}), "
              f"{width:g} × {height:g} m" + (f", turned {source['rotation_deg']:g}° (rotation_deg)"
                                          if source.get("rotation_deg") else ""))
    print(f"licence      {source.get('licence', 'not recorded')}; {source.get('attribution', 'no attribution recorded')}")


def _print_pool(attrs: dict) -> None:
    """``info``'s lines on the pool's seed and its empty samples (all-background semantic maps)."""
    if "pool_seed" in attrs:
        pool_seed = attrs["pool_seed"]
        print(f"pool seed    entropy {pool_seed['entropy']}: {pool_seed['rule']}")
    foreground = attrs.get("foreground")
    if foreground is None:
        print("empty maps   not recorded (store made before synthcal counted them, or incomplete)")
        return
    empty, n = foreground["empty_samples"], attrs["N"]
    threshold = (attrs.get("config") or {}).get("min_field_fraction") or 0.0
    redraw = f"; min_field_fraction {threshold:g}: cameras below it redrawn" if threshold else ""
    print(f"empty maps   {empty} of {n} ({100 * empty / max(n, 1):.1f} %) all background; non-background share "
          f"mean {100 * foreground['mean_fraction']:.1f} %, min {100 * foreground['min_fraction']:.1f} %{redraw}")


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
                          for name in ("train", "test", "dictionary", "validation") if name in sub)
        mixed = ""
        if "mixed_dictionary" in sub:
            sources = attributes(group_at(sub, "mixed_dictionary"))["sources"]
            mixed = (f", mixed dictionary {array_at(sub, 'mixed_dictionary/index').shape[0]} from "
                     f"{', '.join(sources)}")
        print(f"split seed {seed} {sizes}{mixed}")


def _cmd_show(args: argparse.Namespace) -> None:
    from synthcal.store import attributes, open_store, read_samples
    from synthcal.viz import sample_montage

    group = open_store(args.store)
    size = attributes(group)["N"]
    count = min(args.n, size)
    index = np.linspace(0, size - 1, count).round().astype(np.int64)
    samples = read_samples(group, index)
    scene = attributes(group)["scene"]
    montage = sample_montage(samples["image"], samples["semantic"], scene["palette"], scene["classes"], args.columns)
    print(write_picture(args.output, montage.picture))


def _cmd_demo(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import generate_dataset
    from synthcal.viz import labelled_rows, write_png

    demo_started = time.perf_counter()
    _check_folder(args.out, "--out")
    config = load_config(args.config)
    out = Path(args.out)
    rows = []
    print(f"synthcal demo: profile {args.profile!r}, {args.workers} workers, output in {out}/")
    for name in config.dataset_names:
        spec = config.resolve(name, args.profile)
        started = time.perf_counter()
        path = generate_dataset(spec, out, workers=args.workers)  # a progress bar on a terminal
        size = sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
        print(f"  {name:16s} {spec.pool_size:6d} samples  {time.perf_counter() - started:6.1f} s  "
              f"{size / spec.pool_size / 1024:6.1f} KiB/sample  {path}")
        rows.append((name, demo_examples(path)))
    montage = write_png(out / "montage.png", labelled_rows(rows))
    print(f"montage: {montage}  (per dataset two samples with labelled ground: image | semantic map | overlay)")
    if not args.no_bench:
        _demo_bench(args, config, out)
    print(f"demo: {time.perf_counter() - demo_started:.0f} s in all, {args.workers} workers")


def demo_examples(store: Path, count: int = 2) -> list[np.ndarray]:
    """``count`` sample strips of a store for the demo montage, chosen among its first 64 for labelled ground."""
    from synthcal.store import attributes, open_store, read_samples
    from synthcal.viz import non_empty_examples, sample_strip

    group = open_store(store)
    first = read_samples(group, np.arange(min(64, attributes(group)["N"])))
    palette = attributes(group)["scene"]["palette"]
    return [sample_strip(first["image"][k], first["semantic"][k], palette)
            for k in non_empty_examples(first["semantic"], count)]


# The demo's small benchmark: one scene, the two references and the two models
# with true segmentation (the UNet is the costly part on a CPU), a few seeds.
DEMO_DATASET = "intersection-1"
DEMO_ESTIMATORS = ("identity", "template", "baseline", "proposed")
DEMO_SEEDS = "0-4"


def _demo_bench(args: argparse.Namespace, config: LoadedConfig, out: Path) -> None:
    from synthcal.eval.harness import expand_runs, run_sweep
    from synthcal.eval.tables import counted
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
    frame = run_sweep(runs, out / "results", device=args.device, progress=_progress(args), workers=args.workers)
    print(f"benchmark: {counted(len(runs), 'run')} in {time.perf_counter() - started:.0f} s; "
          f"results in {out / 'results'}\n")
    _print_tables(frame, None, "md", False, results=out / "results")




def _print_tables(frame: pd.DataFrame, layout: str | None, fmt: str, compare_paper: bool,
                  metric: str = DEFAULT_READING, results: Path | None = None) -> None:
    """Print :func:`synthcal.eval.report.results_tables`."""
    from synthcal.eval.report import ReportError, results_tables

    try:
        for block in results_tables(frame, layout, fmt, compare_paper, metric, results):
            print(block)
    except ReportError as error:
        raise _UserError(str(error)) from None


def _print_paired(frame: pd.DataFrame, sides: Sequence[str], fmt: str, metric: str, results: Path,
                  against: Path | None = None, between: Sequence[str] | None = None) -> None:
    """Print :func:`synthcal.eval.report.paired_report` (``against``: side B's results folder), or with
    ``between`` :func:`synthcal.eval.report.contrast_report`."""
    from synthcal.eval.report import ReportError, contrast_report, finished_runs, paired_report

    try:
        other = None if against is None else finished_runs(against)
    except ReportError as error:
        raise _UserError(f"--against {error}") from None
    try:
        text = (paired_report(frame, sides, fmt, metric, results, other, against) if between is None
                else contrast_report(frame, sides, between, fmt, metric, results, other, against))
    except ReportError as error:
        message = str(error)  # a --between error names its option itself
        raise _UserError(message if message.startswith("--between") else f"--paired: {message}") from None
    print(text.rstrip("\n"))


class _UserError(ValueError):
    """A problem with the user's request, printed without a traceback."""


def _cmd_bench(args: argparse.Namespace) -> int:
    """Exit 0 when every run is ok, 1 when any failed (each printed with its reason), 130 on Ctrl-C."""
    from synthcal.config import load_config
    from synthcal.estimators.options import merge_options
    from synthcal.eval.harness import (
        check_device,
        check_results_cache,
        expand_runs,
        is_finished,
        plan_lines,
        run_sweep,
    )
    from synthcal.eval.reproduction import missed_class_runs, tied_selection_runs
    from synthcal.eval.tables import counted

    _check_folder(args.results, "--results")
    try:
        check_results_cache(args.results)
    except ValueError as error:
        raise _UserError(f"--results: {error}") from None
    config = load_config(args.config)
    training = config.training(args.profile)
    if args.scheduler is None:  # a cluster's workers may have devices this machine lacks
        try:
            check_device(args.device)
        except ValueError as error:
            raise _UserError(str(error)) from None
    segmentations = args.segmentation or [training.segmentation]
    # --stn-template / --class-reduction / --select / --patience / --selection-score override the profile's
    settings = training.settings()
    settings.update({key: value for key in ("stn_template", "class_reduction", "select", "patience", "selection_score")
                     if (value := getattr(args, key)) is not None})
    _check_training_settings(settings)
    dictionary = args.dictionary or {label: config.dictionary(label, args.profile) for label in args.datasets}
    estimators = merge_options(args.estimator, config.config.estimators, args.option)
    runs = expand_runs(args.data, args.datasets, estimators, parse_seeds(args.seeds), args.profile,
                       settings, args.training, args.loss, args.matching, segmentations,
                       device=args.device, limits=config.split_caps(args.profile), dictionary=dictionary)
    todo = runs if args.rerun else [run for run in runs if not is_finished(args.results, run)]
    print(f"bench: {counted(len(runs), 'run')}: {len(runs) - len(todo)} reused, {len(todo)} to run; "
          f"profile {args.profile or 'none (built-in training defaults)'}; using per seed:")
    print("\n".join(plan_lines(runs)), flush=True)
    if args.scheduler is None:
        to_run = {run.id for run in todo}
        from synthcal.eval.harness import recorded_machine

        reused = [run for run in runs if run.id not in to_run]
        recorded = recorded_machine(args.results, reused, "torch_threads", "cpu_capability")
        _warn_thread_counts(recorded["torch_threads"], len(reused), args.workers, args.threads)
        _warn_cpu_capability(recorded["cpu_capability"], len(reused))
    if not _preview_bench(todo, args):
        print("synthcal: no run started", file=sys.stderr)
        return 1
    started = time.perf_counter()
    try:
        frame = run_sweep(runs, args.results, scheduler=args.scheduler, progress=_progress(args),
                          timeout=args.timeout or None, rerun=args.rerun, workers=args.workers,
                          threads=args.threads)
    except KeyboardInterrupt:  # the running run's process is already killed; finished runs stay
        print(f"synthcal: interrupted; finished runs are kept in {args.results}: run the same command again "
              f"to resume", file=sys.stderr)
        return 130
    ids = {run.id for run in runs}
    frame = frame[frame["run_id"].isin(ids)]
    failed = frame[frame["status"] != "ok"]
    print(f"{counted(len(runs), 'run')} ({len(failed)} failed) in {time.perf_counter() - started:.0f} s; "
          f"results in {args.results}\n")
    _print_tables(frame, None, "md", False, results=args.results)
    for row in failed.itertuples():
        print(f"failed: {row.run_id}: {row.error or 'no reason recorded'}")
    for line in missed_class_runs(args.results, frame) + tied_selection_runs(args.results, frame):
        print(line)
    if len(failed):
        print(f"{len(failed)} run(s) failed; fix the cause and run the same command again: failed runs are run "
              f"again, finished ones kept")
    return 1 if len(failed) else 0


def _warn_thread_counts(recorded: Mapping[int | str, int], reused: int, workers: int, fixed: int | None) -> None:
    """One line when some of the ``reused`` runs trained at another torch thread count than this sweep's runs get
    (``recorded``: how many runs recorded each count).

    The thread count orders torch's sums; over a training the rounding can move the epoch
    validation keeps, so such figures need not agree to the digit (docs/benchmark.md).
    """
    from synthcal.eval.harness import run_threads

    threads = run_threads(workers, fixed)
    other = {count: n for count, n in recorded.items() if count != threads}
    if other:
        listed = ", ".join(f"{n} at {count}" for count, n in sorted(other.items()))
        print(f"bench: {sum(other.values())} of the {reused} reused runs trained at another torch thread "
              f"count ({listed}) than this sweep's runs get ({threads}, "
              f"{f'--threads {fixed}' if fixed else f'--workers {workers}'}): their figures compare to the new "
              f"ones only up to the thread count's rounding (docs/benchmark.md); --threads sets it", flush=True)


def _warn_cpu_capability(recorded: Mapping[int | str, int], reused: int) -> None:
    """One line when some of the ``reused`` runs trained on another CPU instruction set than this machine's torch
    uses (``recorded``: how many runs recorded each).

    The proposed STN's self-attention is one of torch's own kernels, whose rounding follows
    the instruction set (benchmarks/README.md, ``run_capability.py``).
    """
    if not recorded:
        return  # torch is not imported for nothing
    import torch

    own = str(torch.backends.cpu.get_cpu_capability())
    other = {str(name): n for name, n in recorded.items() if name != own}
    if other:
        listed = ", ".join(f"{n} on {name}" for name, n in sorted(other.items()))
        print(f"bench: {sum(other.values())} of the {reused} reused runs trained on another CPU instruction "
              f"set ({listed}) than this machine's torch uses ({own}): the proposed model's figures compare to "
              f"the new ones only up to its rounding (benchmarks/README.md, run_capability.py)", flush=True)


def _preview_bench(todo: Sequence[Run], args: argparse.Namespace) -> bool:
    """One line: the runs to do × their estimated minutes, from the recorded times of finished runs
    (:func:`synthcal.eval.harness.estimate_seconds`: those alike in estimator, training, segmentation,
    device, train images and dataset, else in all but the dataset, else in all but the dataset and the
    train images scaled to the run's, else the estimator's), naming the estimators timed by runs on other
    train sizes; whether to go on."""
    from statistics import mean

    from synthcal.eval.harness import estimate_seconds, recorded_seconds, split_sizes, trained_images

    if not todo:
        return True
    seconds = recorded_seconds(args.results) if args.results.is_dir() else {}
    by_estimator: dict[str, list[float]] = {}
    unknown: dict[str, None] = {}  # an estimator with no finished run at all (ordered, once each)
    scaled: dict[str, None] = {}  # an estimator timed by its runs on other train sizes
    train_sizes: dict[tuple[str, int, str], int] = {}  # the train samples used, per store, seed and limits
    for run in todo:
        train = None
        if run.settings is not None:
            where = (run.store, run.seed, str(run.limits))
            if where not in train_sizes:
                train_sizes[where] = split_sizes(run)["train"][0]
            train = train_sizes[where]
        expected, basis = estimate_seconds(run, seconds, trained_images(run.settings, train))
        if expected is None:
            unknown[run.estimator] = None
        else:
            by_estimator.setdefault(run.estimator, []).append(expected)
        if basis == "other train sizes":
            scaled[run.estimator] = None
    workers = 1 if args.scheduler else args.workers
    if unknown:
        print(f"estimated time: unknown (no finished run of {', '.join(unknown)} in {args.results} to time by)")
        return True
    parts = [f"{len(values)} × {_duration(mean(values))} ({name})" for name, values in by_estimator.items()]
    total = sum(sum(values) for values in by_estimator.values()) / workers
    scaling = f"; {', '.join(scaled)} scaled from runs on other train sizes" if scaled else ""
    print(f"estimated time: {' + '.join(parts)}"
          f"{f' over {workers} workers' if workers > 1 else ''} ≈ {_duration(total)} "
          f"(from the recorded times of finished runs{scaling})", flush=True)
    return total <= CONFIRM_SECONDS or _confirm(args, f"run {len(todo)} runs for about {_duration(total)}?")


def _cmd_table(args: argparse.Namespace) -> None:
    from synthcal.eval.report import ReportError, finished_runs
    from synthcal.eval.reproduction import missed_class_runs, tied_selection_runs
    from synthcal.eval.tables import failed_runs

    try:
        frame = finished_runs(args.results)
    except ReportError as error:
        raise _UserError(str(error)) from None
    if args.between and not args.paired:
        raise _UserError("--between needs --paired A B: it compares A − B between two values of another key (e.g. "
                         "--paired segmentation=ground-truth segmentation=unet --between proposed sha2020)")
    if args.against and not args.paired:
        raise _UserError("--against needs --paired A B: A is read from RESULTS, B from the other folder (e.g. "
                         "--paired segmentation=unet segmentation=unet)")
    if args.paired:
        _print_paired(frame, args.paired, args.format, args.metric, args.results, args.against, args.between)
    else:
        _print_tables(frame, args.layout, args.format, args.compare_paper, args.metric, args.results)
    # Failed runs count in the means (IoU 0, completeness 0); say which and why, off stdout for CSV; so too
    # runs whose UNet lost a class (their pipeline lacks it) and runs whose validation tied every candidate.
    for line in failed_runs(frame) + missed_class_runs(args.results, frame) + tied_selection_runs(args.results, frame):
        if args.format == "csv":
            print(line, file=sys.stderr)
        else:
            print(("% " if args.format == "latex" else "") + line)


def _cmd_segmentation(args: argparse.Namespace) -> None:
    from synthcal.api import segmentation_quality
    from synthcal.eval.harness import collect_results
    from synthcal.eval.segmentation import format_quality
    from synthcal.store import StoreError

    try:
        quality = segmentation_quality(args.results, args.data, device=args.device)
    except (FileNotFoundError, ValueError, StoreError) as error:
        raise _UserError(str(error)) from None
    results = None if args.format == "csv" else collect_results(args.results)
    print(format_quality(quality, results, args.format, args.metric), end="")


def _cmd_plot(args: argparse.Namespace) -> None:
    from synthcal.eval.plots import plot_iou, plot_overlays
    from synthcal.eval.report import ReportError, finished_runs, one_label, run_folders

    try:
        frame = one_label(finished_runs(args.results))
    except ReportError as error:
        raise _UserError(str(error)) from None
    if run_folders(args.results) is None:
        raise _UserError(f"{args.results}: a runs archive; plot reads each run's estimates: give the results folder")
    print(plot_iou(frame, args.output / "iou.png", args.metric))
    for dataset in dict.fromkeys(frame["dataset"]):
        print(plot_overlays(args.results, frame, dataset, args.output / f"overlays-{dataset}.png", args.count,
                            value=args.metric))


# = synthcal.eval.isolation.DEFAULT_TIMEOUT, written out so that parsing imports no torch.
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


def _check_training_settings(settings: dict[str, Any]) -> None:
    """The profile's training settings with the command line's overrides, checked before any run starts."""
    from pydantic import ValidationError

    from synthcal.config import TrainingSettings

    try:
        TrainingSettings(**settings)
    except ValidationError as error:
        reasons = "; ".join(str(item["msg"]).removeprefix("Value error, ") for item in error.errors())
        raise _UserError(f"bench: the training settings (the profile's, with the options given): {reasons}") from None


def _select_grid(text: str) -> dict[str, list[float]]:
    """``--select``: ``learning_rate=1e-4,3e-4,1e-3`` → ``{"learning_rate": [...]}`` (a :class:`SelectGrid`)."""
    from synthcal.config import SelectGrid

    name, _, values = text.partition("=")
    try:
        return SelectGrid.model_validate({name.strip(): [float(v) for v in values.split(",")]}).model_dump()
    except ValueError:  # pydantic's ValidationError too
        raise argparse.ArgumentTypeError(f"{text!r} is not learning_rate=RATE,RATE,... (rates > 0)") from None


def _positive_int(text: str) -> int:
    """``--workers``, ``-n``, ``--columns``, ``--count``: an integer ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer ≥ 1 (value {text!r})")
    return value


_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def _byte_size(text: str) -> int:
    """``--max-memory``: bytes, or a number with K, M, G or T (powers of 1024; ``8G``, ``1.5GiB``)."""
    number = text.strip().upper().removesuffix("IB").removesuffix("B")
    unit = number[-1:] if number[-1:] in _UNITS else ""
    try:
        value = float(number.removesuffix(unit)) * _UNITS[unit]
    except ValueError:
        value = 0.0
    if not 1 <= value < 2**63:  # also refuses nan and inf
        raise argparse.ArgumentTypeError(f"must be a size such as 8G or 512M (value {text!r})")
    return int(value)


# Picture formats of ``-o`` / ``--montage``: suffix → OpenCV's encoder.
_PICTURES = {".png": ".png", ".jpg": ".jpg", ".jpeg": ".jpg"}
_JPEG_QUALITY = 95


def _picture_path(text: str) -> Path:
    """``-o`` of ``scene`` / ``show``, ``--montage``: a path ending in .png, .jpg or .jpeg."""
    path = Path(text)
    if path.suffix.lower() not in _PICTURES:
        raise argparse.ArgumentTypeError(f"{text!r}: unknown picture format {path.suffix or '(no suffix)'!r}; "
                                         f"name a {', '.join(_PICTURES)} file")
    return path


def write_picture(path: Path, rgb: np.ndarray) -> Path:
    """Write an RGB picture as PNG or JPEG (by the suffix), atomically; returns ``path``."""
    import cv2

    from synthcal.utils.atomic import atomic_write

    extension = _PICTURES[path.suffix.lower()]
    params = [cv2.IMWRITE_JPEG_QUALITY, _JPEG_QUALITY] if extension == ".jpg" else []
    ok, data = cv2.imencode(extension, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), params)
    if not ok:
        raise _UserError(f"{path}: could not encode the picture")
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        tmp.write_bytes(data.tobytes())
    return path


def _progress(args: argparse.Namespace) -> bool:
    """Progress bars: on a terminal, unless ``--quiet``."""
    from synthcal.utils.progress import show_progress

    return not getattr(args, "quiet", False) and show_progress()


def _add_yes(parser: argparse.ArgumentParser, when: str) -> None:
    parser.add_argument("--yes", "-y", action="store_true",
                        help=f"do not ask before a large run ({when}; asked only on a terminal)")


# The demo's workers: its 20 runs gain little beyond this, and each holds its data in memory.
_MAX_DEMO_WORKERS = 8


def default_workers() -> int:
    """The demo's worker processes: this machine's cores (those this process may use), at most
    :data:`_MAX_DEMO_WORKERS`."""
    from synthcal.utils.dispatch import usable_cores

    return min(usable_cores(), _MAX_DEMO_WORKERS)


def _add_config(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, default=None,
                        help="datasets.yaml to use, layered over the packaged one (default: ./datasets.yaml if "
                             "present, else the packaged one alone)")


def _add_scenes(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("scenes", help="list the scenes")
    _add_config(p)
    p.set_defaults(func=_cmd_scenes)


def _add_scene(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("scene", help="draw one scene (bird's-eye RGB and semantic map)")
    p.add_argument("name", help="a scene name (see `synthcal scenes`)")
    p.add_argument("-o", "--output", type=_picture_path, required=True, help="picture to write (.png, .jpg)")
    _add_config(p)
    p.set_defaults(func=_cmd_scene)


def _add_osm(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("osm", help="build a scene from an OpenStreetMap extract around a centre: writes image.png "
                                    "and semantic.png (class ids) and prints a datasets.yaml with its entry")
    p.add_argument("file", type=Path, help=".osm, .osm.pbf or .osm.bz2 extract")
    p.add_argument("--center", type=functools.partial(_parse_pair, what="LAT,LON"), required=True,
                   metavar="LAT,LON", help="scene centre in WGS84 degrees")
    p.add_argument("--size", type=functools.partial(_parse_pair, what="WIDTH,HEIGHT"), default=(130.0, 190.0),
                   metavar="W,H", help="window in metres (default 130,190)")
    p.add_argument("--ppm", type=float, default=10.0, help="pixels per metre (default 10)")
    p.add_argument("--seed", type=int, default=0, help="seed of the RGB (cars, roofs, trees, textures)")
    p.add_argument("--name", default=None, help="scene name (default: the file name)")
    p.add_argument("-o", "--out", type=Path, required=True, help="folder receiving image.png and semantic.png")
    p.add_argument("--yaml", type=Path, default=Path("datasets.yaml"), metavar="PATH",
                   help="the datasets.yaml the printed entry is for: its osm file path is written relative to "
                        "this file's folder (default ./datasets.yaml); the file is not read or written")
    p.set_defaults(func=_cmd_osm)


def _add_osm_junctions(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from synthcal.config.vocabulary import BUILTIN_LAYOUT_NAMES

    p = sub.add_parser("osm-junctions", help="list the road junctions of an OpenStreetMap extract as CSV (node, "
                                              "position, legs, bearings, road classes, cycleways)")
    p.add_argument("file", type=Path, help=".osm, .osm.pbf or .osm.bz2 extract")
    p.add_argument("--bbox", type=_parse_bbox, default=None, metavar="W,S,E,N",
                   help="only junctions inside this box (WGS84 degrees: west, south, east, north)")
    p.add_argument("--legs", type=int, default=None, help="only junctions with exactly this many road legs")
    p.add_argument("--like", choices=BUILTIN_LAYOUT_NAMES,
                   help="rank by likeness to a built-in intersection: leg count, then leg bearings")
    p.add_argument("--csv", type=Path, required=True, help="the catalogue to write")
    p.add_argument("--datasets", type=int, default=0, metavar="K",
                   help="also write a datasets.yaml snippet: the first K junctions as OSM scenes, datasets and "
                        "mixed dictionaries; with --like or --mix-for each scene turned (rotation_deg) so its "
                        "legs lie along that intersection's")
    p.add_argument("--mix-for", choices=BUILTIN_LAYOUT_NAMES, default=None, metavar="INTERSECTION",
                   help="the snippet's mixed dictionary is instead this built-in intersection's, drawn from the K "
                        "junctions, through a second store osmK-<k> (bench label mixed-osmK-<k>)")
    p.add_argument("--yaml", type=Path, default=None, help="where the snippet goes (default: CSV.datasets.yaml)")
    p.set_defaults(func=_cmd_osm_junctions)


def _parse_bbox(text: str) -> tuple[float, float, float, float]:
    """``"W,S,E,N"`` degrees → a box; argparse reports a ValueError as a bad value of the option."""
    try:
        west, south, east, north = (float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected W,S,E,N, four numbers separated by commas (value {text!r})") \
            from None
    if not (west < east and south < north):
        raise argparse.ArgumentTypeError(f"expected W,S,E,N with west < east and south < north (value {text!r})")
    return west, south, east, north


def _add_datasets(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("datasets", help="list every dataset name generate and bench accept, one line each")
    p.add_argument("--profile", default=None, help="show the pool sizes under this profile of datasets.yaml")
    _add_config(p)
    p.set_defaults(func=_cmd_datasets)


def _add_config_cmd(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("config", help="the configuration: a user's datasets.yaml layered over the packaged one")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION", help="show or init")
    show = actions.add_parser("show", help="print the merged configuration as YAML, each value with its origin "
                                           "(packaged, or the user's file)")
    _add_config(show)
    show.set_defaults(func=_cmd_config_show)
    init = actions.add_parser("init", help="write a minimal commented starter (never overwrites)")
    init.add_argument("path", nargs="?", type=Path, default=Path("datasets.yaml"),
                      help="the file to write (default ./datasets.yaml)")
    init.set_defaults(func=_cmd_config_init)


def _add_generate(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("generate", help="generate the sharded store of datasets")
    p.add_argument("datasets", nargs="+", metavar="DATASET", help="dataset names (see `synthcal datasets`)")
    p.add_argument("--profile", default=None, help="profile of datasets.yaml (smoke, demo, quick, paper)")
    p.add_argument("--out", type=Path, required=True, help="folder receiving DATASET.zarr")
    p.add_argument("--workers", type=_positive_int, default=1, help="local worker processes (default 1)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the shards on this Dask scheduler (tcp://host:port; it must answer within 5 s)")
    p.add_argument("-n", "--n", type=int, default=None, help="pool size (overrides the configuration)")
    p.add_argument("--max-memory", type=_byte_size, default=None, metavar="SIZE",
                   help="refuse a run estimated to need more memory, e.g. 8G (default: this machine's memory)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--splits", action="store_true",
                   help="then draw the train/test/dictionary splits of every seed (and mixed dictionaries)")
    _add_yes(p, f"above {CONFIRM_BYTES / 1e9:g} GB or {CONFIRM_SECONDS / 60:g} min")
    _add_config(p)
    p.set_defaults(func=_cmd_generate)


def _add_split(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("split", help="draw the per-seed train/test/dictionary/validation splits inside a store")
    p.add_argument("store", type=Path, help="the store, e.g. work/data/intersection-1.zarr")
    p.add_argument("--seeds", default=None, help="e.g. 0-4 or 0,2,5 (default: the store's split_seeds)")
    for name in ("train", "test", "dictionary", "validation"):
        p.add_argument(f"--{name}", type=int, default=None, metavar="N",
                       help=f"{name} size (default: the store's recorded configuration)")
    p.set_defaults(func=_cmd_split)


def _share(text: str) -> float:
    """``--test-fraction``: a number strictly between 0 and 1."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be a share strictly between 0 and 1 (value {text!r})")
    return value


def _add_import(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("import", help="a folder of real frames with annotated homographies as a store: the frame "
                                       "as image, the annotation in the scene's frame, the scene's semantic view")
    p.add_argument("folder", type=Path, help="the folder of frames")
    p.add_argument("--layout", required=True, choices=["wc14", "plain"],
                   help="wc14: train_val/ and test/ with N.jpg + N.homographyMatrix (pitch yards → pixels); "
                        "plain: NAME.jpg|png + NAME.homography.txt (bird's-eye px → pixels of the frame)")
    p.add_argument("--scene", required=True, help="the scene the annotations refer to (wc14: soccer)")
    p.add_argument("--out", type=Path, required=True, help="folder receiving NAME.zarr")
    p.add_argument("--name", default=None, help="dataset name (default: the folder's name)")
    p.add_argument("--profile", default=None, help="profile of datasets.yaml giving the image and shard sizes")
    p.add_argument("--dictionary-from", nargs="+", default=None, metavar="DATASET",
                   help="grid datasets whose pools give the dictionary (default: those of the scene)")
    p.add_argument("--dictionary", type=_positive_int, default=None, metavar="N",
                   help="templates per seed (default: the profile's dictionary size, at most the pools')")
    p.add_argument("--test-fraction", type=_share, default=0.2,
                   help="plain: share of the frames drawn once as the fixed test set (default 0.2)")
    _add_config(p)
    p.set_defaults(func=_cmd_import)


def _add_worldcup_stats(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("worldcup-stats", help="the real World Cup 2014 cameras against a camera grid")
    p.add_argument("--grid", default="soccer", help="grid of datasets.yaml (default soccer)")
    p.add_argument("--montage", type=_picture_path, default=None,
                   help="also render test poses into this picture (.png, .jpg)")
    p.add_argument("--count", type=_positive_int, default=12, help="test poses in the montage (default 12)")
    _add_config(p)
    p.set_defaults(func=_cmd_worldcup_stats)


def _add_info(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("info", help="what a store holds (from its attributes)")
    p.add_argument("store", type=Path, help="the store, NAME.zarr (or an unfinished NAME.zarr.partial)")
    p.add_argument("--json", action="store_true", help="print the raw attributes")
    p.set_defaults(func=_cmd_info)


def _add_verify(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("verify", help="read stores back whole: manifest, every shard index and chunk checksum, "
                                       "every chunk decodes; exit 1 when any file is damaged")
    p.add_argument("stores", nargs="+", type=Path, metavar="STORE", help="the stores to check")
    p.set_defaults(func=_cmd_verify)


def _add_show(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("show", help="montage of samples: image | semantic | overlay")
    p.add_argument("store", type=Path, help="the store, NAME.zarr")
    p.add_argument("-n", "--n", type=_positive_int, default=16,
                   help="samples shown, evenly spaced in the pool (default 16)")
    p.add_argument("-o", "--output", type=_picture_path, required=True, help="picture to write (.png, .jpg)")
    p.add_argument("--columns", type=_positive_int, default=None, help="samples per row (default: about square)")
    p.set_defaults(func=_cmd_show)


def _add_demo(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("demo", help="generate every built-in dataset at demo size, draw a montage, "
                                     "run a small benchmark on one scene and print its table")
    p.add_argument("--out", type=Path, default=Path("work/demo"), help="output folder (default work/demo)")
    p.add_argument("--profile", default="demo", help="profile of datasets.yaml (default demo)")
    p.add_argument("--workers", type=_positive_int, default=default_workers(),
                   help=f"local worker processes: generation, and runs side by side (default {default_workers()}: "
                        f"this machine's cores, at most {_MAX_DEMO_WORKERS})")
    p.add_argument("--device", default="auto", help="torch device of the models (default auto)")
    p.add_argument("--no-bench", action="store_true", help="generate and draw only")
    _add_config(p)
    p.set_defaults(func=_cmd_demo)


def _add_bench(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("bench", help="fit and score estimators over datasets and seeds (resumable)")
    p.add_argument("--data", type=Path, required=True, help="folder holding the stores NAME.zarr")
    p.add_argument("--datasets", nargs="+", required=True, metavar="NAME",
                   help="dataset labels: NAME (its store) or mixed-K / mixed-NAME (a mixed dictionary)")
    p.add_argument("--estimator", nargs="+", required=True, metavar="NAME_OR_PATH",
                   help="bundled name (identity, template, ecc, baseline, proposed), entry point or module:Class; "
                        "'NAME?key=value&key=value' gives its constructor options")
    p.add_argument("--option", action="append", default=[], metavar="NAME.KEY=VALUE",
                   help="a constructor option of every --estimator entry NAME (repeatable; VALUE a YAML scalar: "
                        "0.7, 3, true, fast); wins over the ?key=value of the entry and the configuration's "
                        "estimators: section")
    p.add_argument("--seeds", default="0-4", help="split seeds, e.g. 0-4 or 0,2 (default 0-4)")
    p.add_argument("--profile", default=None, help="training sizes of datasets.yaml (smoke, demo, quick, paper)")
    p.add_argument("--results", type=Path, required=True, help="results folder (runs/, cache/)")
    from synthcal.config import LOSSES, MATCHINGS, SEGMENTATIONS, TRAININGS  # the vocabularies, defined once

    p.add_argument("--training", nargs="+", default=["step-by-step"], choices=TRAININGS,
                   help="how the bundled models train (default step-by-step)")
    p.add_argument("--loss", nargs="+", default=["top-mse"], choices=LOSSES,
                   help="warp losses of the bundled models (default top-mse)")
    p.add_argument("--matching", nargs="+", default=["top-mse"], choices=MATCHINGS,
                   help="template matching score of the bundled models (default top-mse)")
    p.add_argument("--segmentation", nargs="+", default=None, choices=SEGMENTATIONS,
                   help="default: the profile's")
    from synthcal.config import CLASS_REDUCTIONS, SELECTION_SCORES, STN_TEMPLATES

    p.add_argument("--stn-template", default=None, choices=STN_TEMPLATES,
                   help="the template the bundled STNs read in training: retrieved (the Siamese's nearest, as at "
                        "test time) or ground-truth (lowest matching score); default: the profile's (retrieved)")
    p.add_argument("--select", type=_select_grid, default=None, metavar="learning_rate=R1,R2,...",
                   help="train each model at every rate and keep the best on the validation split "
                        "(default: the profile's training.select, else its one learning_rate)")
    p.add_argument("--patience", type=_positive_int, default=None, metavar="EPOCHS",
                   help="keep the STN's best epoch on the validation split; stop after EPOCHS without a better "
                        "one (default: the profile's training.patience, else every epoch)")
    p.add_argument("--selection-score", default=None, choices=SELECTION_SCORES,
                   help="what ranks the fits on the validation split for --patience and --select: warp-loss (the run's "
                        "own L_warp of the estimates) or iou (1 - their mean iou, the tables' reading, at the working "
                        "resolution); default: the profile's training.selection_score, else warp-loss")
    p.add_argument("--class-reduction", default=None, choices=CLASS_REDUCTIONS,
                   help="how MSE, Top-MSE and the matching scores reduce over the class channels: sum (squared "
                        "distance of per-pixel class vectors) or mean (that / 4); default: the profile's (sum)")
    from synthcal.config import DICTIONARIES

    p.add_argument("--dictionary", default=None, choices=DICTIONARIES,
                   help="what the estimators search: split (the seed's drawn dictionary) or pool (every pool sample "
                        "outside the seed's train, test and validation sets; not for mixed dictionaries); default: the "
                        "profile's or dataset's dictionary: in datasets.yaml, else split")
    p.add_argument("--device", default="auto", help="torch device: auto (CUDA when available), cpu, cuda")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the runs on this Dask scheduler")
    p.add_argument("--timeout", type=_seconds, default=_DEFAULT_TIMEOUT, metavar="SECONDS",
                   help="time limit of each run, which runs in a process of its own; one that exceeds it, "
                        "crashes or exits is recorded as failed and the sweep goes on "
                        f"(default {_DEFAULT_TIMEOUT:g} = 6 h; 0: none)")
    p.add_argument("--rerun", action="store_true",
                   help="run every run again, finished ones too (default: reuse the finished runs of the same "
                        "dataset, settings and estimator code)")
    p.add_argument("--workers", type=_positive_int, default=1,
                   help="runs executed side by side, this machine's cores shared among them unless --threads "
                        "is given (default 1)")
    p.add_argument("--threads", type=_positive_int, default=None, metavar="N",
                   help="torch threads of each run, whatever --workers (default: cores // WORKERS, at most "
                        "OMP_NUM_THREADS if set; on a --scheduler cluster, torch's default); the thread count "
                        "orders torch's sums, so a trained model's figures move with it: fix it (the "
                        "reproduction sweeps: --threads 1) for figures that --workers does not change "
                        "(docs/benchmark.md)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    _add_yes(p, f"above {CONFIRM_SECONDS / 60:g} min")
    _add_config(p)
    p.set_defaults(func=_cmd_bench)


def _add_table(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("table", help="the paper's tables from a results folder")
    p.add_argument("results", type=Path,
                   help="the results folder of `synthcal bench`, or its runs archive (a .csv written by "
                        "`--layout runs --format csv`: every table but diagnostics, no bootstrap interval)")
    p.add_argument("--layout", choices=["models", "matching", "mixed", "report", "diagnostics", "runs"],
                   default=None,
                   help="default: models (own dictionaries) and mixed (mixed dictionaries) where present; report: "
                        "one row per cell with its paired difference against sha2020, its 95 %% CI, the paper's "
                        "figures, what validation chose, the time per run and a verdict (docs/reproduction.md); "
                        "diagnostics: which template retrieved / template / oracle-template picked against the "
                        "best-pose one, and pan errors, for every dataset; runs: one row per run (with --format "
                        "csv, the runs archive: what outlives the folder, e.g. in git)")
    p.add_argument("--format", choices=["md", "latex", "csv"], default="md", help="table format (default md)")
    p.add_argument("--compare-paper", action="store_true",
                   help="add the published figures (for each reading of the paper's IoU: iou, iou_bg, iou_weighted)")
    p.add_argument("--metric", default=DEFAULT_READING, choices=METRICS, help=_metric_help("the reading shown"))
    p.add_argument("--paired", nargs=2, default=None, metavar=("A", "B"),
                   help="instead of the tables: per dataset and loss (and other settings), the mean ± std over "
                        "seeds of the per-seed difference A − B of two models trained on the same split, the "
                        "seeds where A > B, and the paper's A − B; A, B: models (proposed sha2020) or KEY=VALUE "
                        "(loss=top-mse loss=mse)")
    p.add_argument("--against", type=Path, default=None, metavar="OTHER",
                   help="with --paired: read B's runs from another results folder or runs archive (A's from "
                        "RESULTS) and pair "
                        "them with A's of the same dataset, seed and other settings — a change kept in a folder of "
                        "its own, e.g. `synthcal table results-weighted --against results-plain --paired "
                        "segmentation=unet segmentation=unet`, or true maps against a UNet's, `--paired "
                        "segmentation=ground-truth segmentation=unet`")
    p.add_argument("--between", nargs=2, default=None, metavar=("C", "D"),
                   help="with --paired A B: per seed, A − B under C minus A − B under D (C, D: models, or "
                        "KEY=VALUE of another key than --paired's), with its mean, t interval over seeds and p — "
                        "e.g. whether a UNet's maps cost one model more than another: `--paired "
                        "segmentation=ground-truth segmentation=unet --between proposed sha2020`")
    p.set_defaults(func=_cmd_table)


def _add_segmentation(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("segmentation", help="the UNets a results folder caches, scored on their seed's test split "
                                            "(per-class IoU/Dice), and the readings on their maps beside true maps")
    p.add_argument("results", type=Path, help="the results folder of `synthcal bench --segmentation unet`")
    p.add_argument("--data", type=Path, default=None,
                   help="the folder holding the stores NAME.zarr (default: where each run recorded its store)")
    p.add_argument("--format", choices=["md", "csv"], default="md",
                   help="md: per seed, mean ± std over seeds, readings side by side; csv: the per-seed rows")
    p.add_argument("--metric", default=DEFAULT_READING, choices=METRICS,
                   help=_metric_help("the reading shown side by side"))
    p.add_argument("--device", default="cpu", help="torch device for the UNets (default cpu)")
    p.set_defaults(func=_cmd_segmentation)


def _metric_help(what: str) -> str:
    """``--metric``'s help: every reading with its description, the default marked."""
    readings = "; ".join(f"{name}{' (default)' if name == DEFAULT_READING else ''}: {DESCRIPTIONS[name]}"
                         for name in METRICS)
    return f"{what}. {readings}. docs/benchmark.md says why the default is what it is"


def _add_plot(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("plot", help="IoU bars per dataset and estimator, and overlays of test images")
    p.add_argument("results", type=Path, help="the results folder of `synthcal bench`")
    p.add_argument("-o", "--output", type=Path, required=True, help="folder receiving the PNGs")
    p.add_argument("--count", type=_positive_int, default=3, help="test images per overlay figure (default 3)")
    p.add_argument("--metric", default=DEFAULT_READING, choices=METRICS,
                   help=_metric_help("the reading the bars and overlay titles show"))
    p.set_defaults(func=_cmd_plot)


def build_parser() -> argparse.ArgumentParser:
    """The ``synthcal`` parser: one sub-command per ``_add_*`` function."""
    from synthcal import __version__

    parser = argparse.ArgumentParser(prog="synthcal", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}",
                        help="print the version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                help="one of the commands below; `synthcal COMMAND -h` tells more")
    _add_scenes(sub)
    _add_scene(sub)
    _add_osm(sub)
    _add_osm_junctions(sub)
    _add_datasets(sub)
    _add_config_cmd(sub)
    _add_generate(sub)
    _add_split(sub)
    _add_import(sub)
    _add_worldcup_stats(sub)
    _add_info(sub)
    _add_verify(sub)
    _add_show(sub)
    _add_demo(sub)
    _add_bench(sub)
    _add_table(sub)
    _add_segmentation(sub)
    _add_plot(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``synthcal`` console script.

    Returns:
        0, or 1 (``verify``: a damaged store), 2 (a user error, printed as one line
        ``synthcal: error: …``), 130 (interrupted: Ctrl-C), 141 (the reader of
        standard output went away, as in ``synthcal table … | head``).
    """
    command = None
    try:
        args = build_parser().parse_args(argv)
        command = args.command
        return run_command(args)
    except KeyboardInterrupt:
        return _interrupted(command)


# What a rerun of an interrupted command keeps (it resumes); other commands just stop.
_RESUMES = {"generate": "finished shards", "split": "seeds already drawn", "bench": "finished runs",
            "demo": "finished stores and runs"}


def _interrupted(command: str | None) -> int:
    """Ctrl-C: one line saying how to go on, exit status 130 (128 + SIGINT) as a shell reports it."""
    kept = _RESUMES.get(command or "")
    hint = f"; run the same command again to resume ({kept} are kept)" if kept else ""
    print(f"synthcal: interrupted{hint}", file=sys.stderr)
    return 130


def run_command(args: argparse.Namespace) -> int:
    """Run the command; user errors (bad input, files, stores) as one line, exit 2."""
    from synthcal.config import ConfigError
    from synthcal.estimators import EstimatorError
    from synthcal.scenes import SceneError
    from synthcal.store import StoreError

    default_format = warnings.formatwarning
    warnings.formatwarning = functools.partial(format_warning, default_format)
    try:
        status = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here rather than at exit
    except (ConfigError, SceneError, StoreError, EstimatorError, _UserError) as exc:
        print(f"synthcal: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return _stdout_gone()
    except OSError as exc:  # disk full, permission denied, a folder where a file should be: name the path
        where = ": ".join(str(name) for name in (exc.filename, exc.filename2) if name is not None)
        print(f"synthcal: error: {where + ': ' if where else ''}{exc.strerror or exc}", file=sys.stderr)
        return 2
    finally:
        warnings.formatwarning = default_format
    return status if isinstance(status, int) else 0


def _stdout_gone() -> int:
    """Standard output's reader went away (``synthcal table RESULTS | head``): stop quietly.

    Python would try to flush standard output again at exit and complain, so it is
    pointed at /dev/null first (the recipe of Python's ``signal`` documentation).
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # standard output replaced by an object without a descriptor
        pass
    return 141  # 128 + SIGPIPE, what a shell reports for a writer killed by the closed pipe


def format_warning(default: Callable[..., str], message: Warning | str, category: type[Warning],
                    *args: Any, **kwargs: Any) -> str:
    """synthcal's own warnings as ``synthcal: warning: …`` (they name their file); others as Python does."""
    if category.__module__.startswith("synthcal"):
        return f"synthcal: warning: {message}\n"
    return default(message, category, *args, **kwargs)


if __name__ == "__main__":
    sys.exit(main())
