"""The demo montage (issue 14, item 6): one labelled row per dataset, non-empty examples."""

from __future__ import annotations

import numpy as np
import pytest

from synthcal.viz import labelled_rows, non_empty_examples


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
