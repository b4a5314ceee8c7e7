"""The ``synthcal`` command line: one module, one sub-command per job.

Errors that come from the user's input (configuration, files, stores) are printed
as one clear message with exit status 2, without a traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

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
    specs = [config.resolve(name, args.profile, args.n) for name in args.datasets]  # validate all first
    for spec in specs:
        started = time.perf_counter()
        path = generate_dataset(spec, args.out, workers=args.workers, scheduler=args.scheduler,
                                progress=not args.quiet)
        print(f"{path}  {spec.pool_size} samples  {time.perf_counter() - started:.1f} s")


def _cmd_info(args: argparse.Namespace) -> None:
    from synthcal.generate.store import open_store

    group = open_store(args.store, allow_incomplete=True)
    attrs = dict(group.attrs)
    if args.json:
        print(json.dumps(attrs, indent=2))
        return
    scene = attrs["scene"]
    width, height = attrs["image_size"]
    print(f"store        {args.store}  ({'complete' if attrs.get('complete') else 'INCOMPLETE'})")
    print(f"dataset      {attrs['dataset']}  ({attrs['format_version']})")
    print(f"samples      {attrs['N']} at {width} × {height}, {attrs['shard_size']} per shard, seed {attrs['seed']}")
    print(f"scene        {scene['name']}: {', '.join(f'{i} {c}' for i, c in enumerate(scene['classes']))}")
    print(f"scene size   {group['scene/semantic'].shape[1]} × {group['scene/semantic'].shape[0]} px, "
          f"heading {scene['heading_deg']:g}°")
    for axis, values in attrs["grid"].items():
        if isinstance(values, dict):
            print(f"grid {axis:8s}{values['start']:g}..{values['stop']:g} step {values['step']:g}")
    print(f"config hash  {attrs['config_hash'][:16]}…")
    print(f"software     {', '.join(f'{k} {v}' for k, v in attrs['software'].items())}")
    if "splits" in group:
        print(f"splits       {', '.join(sorted(group['splits'].keys()))}")


def _cmd_show(args: argparse.Namespace) -> None:
    from synthcal.generate.store import open_store, read_samples
    from synthcal.viz import sample_strip, tile, write_png

    group = open_store(args.store)
    count = min(args.n, group["image"].shape[0])
    index = np.linspace(0, group["image"].shape[0] - 1, count).round().astype(np.int64)
    samples = read_samples(group, index)
    palette = group.attrs["scene"]["palette"]
    strips = [sample_strip(samples["image"][k], samples["semantic"][k], palette) for k in range(count)]
    print(write_png(args.output, tile(strips, columns=args.columns)))


def _cmd_demo(args: argparse.Namespace) -> None:
    from synthcal.config import load_config
    from synthcal.generate.pipeline import generate_dataset
    from synthcal.generate.store import open_store, read_samples
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
        palette = group.attrs["scene"]["palette"]
        strips += [sample_strip(samples["image"][k], samples["semantic"][k], palette) for k in range(2)]
    montage = write_png(out / "montage.png", tile(strips, columns=2))
    print(f"montage: {montage}  (per scene two samples: image | semantic map | overlay)")


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
    _add_config(p)
    p.set_defaults(func=_cmd_generate)

    p = sub.add_parser("info", help="what a store holds (from its attributes)")
    p.add_argument("store", type=Path)
    p.add_argument("--json", action="store_true", help="print the raw attributes")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("show", help="montage of samples: image | semantic | overlay")
    p.add_argument("store", type=Path)
    p.add_argument("-n", type=int, default=16)
    p.add_argument("-o", "--output", type=Path, required=True)
    p.add_argument("--columns", type=int, default=None)
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("demo", help="generate every built-in dataset at demo size and draw a montage")
    p.add_argument("--out", type=Path, default=Path("demo_out"))
    p.add_argument("--profile", default="demo")
    p.add_argument("--workers", type=int, default=2)
    _add_config(p)
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``synthcal`` console script."""
    from synthcal.config import ConfigError
    from synthcal.generate.scenes import SceneError
    from synthcal.generate.store import StoreError

    args = build_parser().parse_args(argv)
    try:
        args.func(args)
    except (ConfigError, SceneError, StoreError) as exc:
        print(f"synthcal: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
