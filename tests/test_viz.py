"""The demo montage (issue 14, item 6): one labelled row per dataset, non-empty examples; ``show``'s montage
with column headers and a class legend (issue 24, item 6)."""

from __future__ import annotations

import numpy as np
import pytest

from synthcal.viz import labelled_rows, non_empty_examples, sample_montage, sample_strip, tile


def test_non_empty_examples_skip_all_background_maps():
    maps = np.zeros((6, 4, 5), np.uint8)
    maps[2, :2] = 1  # 40 % labelled
    maps[4] = 3  # all labelled
    maps[5, 0, 0] = 2  # 5 %
    np.testing.assert_array_equal(non_empty_examples(maps, 2), [2, 4])
    # too few reach the threshold: the most labelled of the rest fill up, not an empty one
    np.testing.assert_array_equal(non_empty_examples(maps, 3), [2, 4, 5])
    assert len(non_empty_examples(maps, 10)) == 6


def test_labelled_rows_put_each_label_left_of_its_pictures():
    red = np.zeros((20, 30, 3), np.uint8)
    red[..., 0] = 255
    montage = labelled_rows([("intersection-1", [red, red]), ("soccer", [red])], gap=4)
    assert montage.shape[0] == 2 * (20 + 4) + 4
    label_width = montage.shape[1] - 2 * (30 + 4) - 4
    assert label_width > 20
    for top in (4, 28):
        label = montage[top:top + 20, :label_width]
        assert (label.max(axis=-1) < 100).any()  # dark text in the label column
        assert np.array_equal(montage[top:top + 20, label_width + 4:label_width + 34], red)
    assert (montage[28:48, label_width + 38:] == 255).all()  # the shorter row leaves white
    with pytest.raises(ValueError):
        labelled_rows([])


def test_demo_examples_of_a_store_are_labelled(smoke_stores):
    from synthcal.cli import demo_examples
    from synthcal.store import open_store

    store = smoke_stores.path("soccer")
    strips = demo_examples(store)
    assert len(strips) == 2
    semantic = open_store(store)["semantic"][:]
    width = semantic.shape[2]
    palette = np.asarray(open_store(store).attrs["scene"]["palette"], np.uint8)
    for strip in strips:
        coloured = strip[:, width + 2:2 * width + 2]  # [image | semantic | overlay], gap 2
        assert (coloured != palette[0]).any(axis=-1).mean() >= 0.2


PALETTE = np.array([[0, 0, 0], [128, 128, 128], [0, 160, 0], [200, 40, 40]], np.uint8)
CLASSES = ("background", "road", "terrain", "bicycle path")


def test_sample_montage_has_column_headers_and_a_class_legend():
    rng = np.random.default_rng(0)
    images = rng.integers(0, 255, (3, 40, 64, 3), dtype=np.uint8)
    semantics = rng.integers(0, 4, (3, 40, 64), dtype=np.uint8)
    montage = sample_montage(images, semantics, PALETTE, CLASSES, columns=2, gap=6)
    strips = [sample_strip(i, s, PALETTE) for i, s in zip(images, semantics, strict=True)]
    grid = tile(strips, columns=2, gap=6)
    picture, top = montage.picture, montage.header_height
    # The grid itself, unchanged, between a header strip above and a legend strip below.
    assert top > 0 and picture.shape[1] == grid.shape[1] and picture.shape[0] > grid.shape[0] + top
    assert np.array_equal(picture[top:top + len(grid)], grid)
    # A caption (dark text) over each of the three panels of both strip columns, none over the gaps.
    header = picture[:top]
    for column in range(2):
        left = 6 + column * (strips[0].shape[1] + 6)
        for panel in range(3):
            x0 = left + panel * (64 + 2)
            assert (header[:, x0:x0 + 64].max(axis=-1) < 128).any(), (column, panel)
    assert (header[:, :6] == 255).all() and (header[:, -6:] == 255).all()
    # Every class of the scene, in id order, with a box of exactly its palette colour below the grid.
    assert [entry.name for entry in montage.legend] == list(CLASSES)
    for entry, colour in zip(montage.legend, PALETTE, strict=True):
        x0, y0, x1, y1 = entry.box
        assert y0 >= top + len(grid) and x1 - x0 >= 8 and y1 - y0 >= 8
        assert entry.colour == tuple(colour) and (picture[y0:y1, x0:x1] == colour).all()
        # Its name right of the box: dark pixels there.
        assert (picture[y0:y1, x1:x1 + 40].max(axis=-1) < 128).any()


def test_the_legend_wraps_to_the_montage_width():
    images, semantics = np.zeros((1, 40, 30, 3), np.uint8), np.zeros((1, 40, 30), np.uint8)
    montage = sample_montage(images, semantics, PALETTE, CLASSES)
    rows = sorted({entry.box[1] for entry in montage.legend})
    assert len(rows) > 1  # 4 names do not fit beside each other in 100 pixels
    assert all(entry.box[2] <= montage.picture.shape[1] for entry in montage.legend)


def test_show_draws_the_headers_and_the_scenes_legend(smoke_stores, tmp_path, capsys):
    import cv2

    from synthcal.cli import main
    from synthcal.data import read_scene
    from synthcal.store import open_store, read_samples

    store = smoke_stores.path("soccer")
    output = tmp_path / "montage.png"
    assert main(["show", str(store), "-n", "2", "--columns", "2", "-o", str(output)]) == 0
    picture = cv2.cvtColor(cv2.imread(str(output)), cv2.COLOR_BGR2RGB)
    scene = read_scene(store)
    group = open_store(store)
    samples = read_samples(group, np.array([0, group.attrs["N"] - 1]))
    grid = tile([sample_strip(samples["image"][k], samples["semantic"][k], scene.palette) for k in range(2)], 2)
    expected = sample_montage(samples["image"], samples["semantic"], scene.palette, scene.classes, 2)
    assert np.array_equal(picture, expected.picture)  # PNG is lossless
    assert picture.shape[0] > grid.shape[0] + expected.header_height
    assert [entry.name for entry in expected.legend] == list(scene.classes)
    for entry in expected.legend:
        x0, y0, x1, y1 = entry.box
        assert (picture[y0:y1, x0:x1] == scene.palette[scene.classes.index(entry.name)]).all()
