"""A junction family in one picture: the bird's-eye RGB of the scenes an ``osm-junctions`` catalogue lists.

    synthcal osm-junctions examples/osm/esplanadi.osm.pbf --like intersection-1 --csv work/j.csv --datasets 4
    python examples/osm/junction_family.py work/j.csv work/j.datasets.yaml docs/osm_junction_family.png

Each tile is one scene of the snippet (built as ``synthcal scene osm-<node id> --config
work/j.datasets.yaml`` builds it), labelled with its node id, legs, ``difference_deg`` and
``rotation_deg`` (each scene drawn turned onto the layout's legs), in the CSV's order. Map data © OpenStreetMap contributors, ODbL.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import cv2
import numpy as np

from synthcal.config import load_config
from synthcal.generate.pipeline import load_scene

TILE_WIDTH = 208  # px: four tiles and their labels stay under 300 KB as PNG
WHITE = (255, 255, 255)


def label(text: list[str], width: int) -> np.ndarray:
    """A white strip with one line of black text per item, (18 · lines + 6, width, 3) uint8."""
    strip = np.full((18 * len(text) + 6, width, 3), 255, np.uint8)
    for i, line in enumerate(text):
        cv2.putText(strip, line, (4, 18 * i + 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def tile(rgb: np.ndarray, row: dict[str, str]) -> np.ndarray:
    """One scene's RGB shrunk to :data:`TILE_WIDTH` under its label, with a white margin on the right."""
    height = round(rgb.shape[0] * TILE_WIDTH / rgb.shape[1])
    small = cv2.resize(rgb, (TILE_WIDTH, height), interpolation=cv2.INTER_AREA)
    text = [f"node {row['node_id']}", f"{row['legs']} legs, {float(row.get('difference_deg') or 0):.1f} deg off"]
    if row.get("rotation_deg"):  # ranked: the scene is drawn turned onto the layout's legs
        text.append(f"turned {float(row['rotation_deg']):.1f} deg")
    picture = np.concatenate([label(text, TILE_WIDTH), small], axis=0)
    return np.pad(picture, ((0, 0), (0, 8), (0, 0)), constant_values=255)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", type=Path, help="the catalogue (osm-junctions --csv)")
    parser.add_argument("snippet", type=Path, help="its datasets.yaml snippet (osm-junctions --datasets K)")
    parser.add_argument("out", type=Path, help="PNG to write")
    args = parser.parse_args()
    config = load_config(args.snippet)
    with args.csv.open(newline="") as file:
        rows = [row for row in csv.DictReader(file) if f"osm-{row['node_id']}" in config.config.datasets]
    tiles = [tile(load_scene(config.resolve(f"osm-{row['node_id']}")).image, row) for row in rows]
    montage = np.concatenate(tiles, axis=1)
    footer = label([f"{len(tiles)} junctions of {args.csv.name} ranked by likeness; "
                    "(c) OpenStreetMap contributors (ODbL)"], montage.shape[1])
    montage = np.concatenate([montage, footer], axis=0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(args.out), cv2.cvtColor(montage, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
        raise SystemExit(f"{args.out}: could not write the picture")
    print(f"{args.out}: {len(tiles)} scenes, {montage.shape[1]} × {montage.shape[0]} px")
