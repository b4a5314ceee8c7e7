"""``plot``'s overlays carry a legend of the classes they tint (issue 24, item 6)."""

from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from synthcal.data import read_scene
from synthcal.eval.harness import collect_results, expand_runs, run_sweep
from synthcal.eval.plots import overlay_figure
from synthcal.generate.splits import draw_splits


@pytest.fixture(scope="module")
def results(smoke_stores, tmp_path_factory) -> Path:
    """One identity run on intersection-1 (seed 0)."""
    out = tmp_path_factory.mktemp("plots")
    store = smoke_stores.copy(["intersection-1"], out / "data")["intersection-1"]
    draw_splits(store, seeds=[0])
    run_sweep(expand_runs(out / "data", ["intersection-1"], ["identity"], [0]), out / "results", progress=False)
    return out / "results"


def test_overlays_have_a_legend_of_the_scenes_tinted_classes(results):
    frame = collect_results(results)
    scene = read_scene(results.parent / "data" / "intersection-1.zarr")
    figure = overlay_figure(results, frame, "intersection-1", count=2)
    (legend,) = figure.legends
    # Classes 1-3, the ones overlay() tints, each in its palette colour; background is never tinted.
    assert [text.get_text() for text in legend.get_texts()] == list(scene.classes[1:])
    colours = [to_rgb(patch.get_facecolor()) for patch in legend.get_patches()]
    np.testing.assert_allclose(colours, scene.palette[1:] / 255)

