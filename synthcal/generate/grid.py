"""The camera parameter grids of SPEC §3, and sampling from them.

A grid is the Cartesian product of six axes (pan, tilt, focal, X, Y, Z), each an
inclusive range; a pan range spanning 360° drops its upper end (≡ its lower end).
An axis's values and a grid's size are methods of the configuration types
(:meth:`~synthcal.config.AxisRange.values`, :meth:`~synthcal.config.GridConfig.size`).
Grid cameras are numbered in C order over the axes in that order, and that number
is the sample's ``grid_index`` in the store.

Example
-------
>>> from synthcal.config import AxisRange, GridConfig
>>> grid = GridConfig(pan_deg=AxisRange(start=-25, stop=25, step=1),
...                   tilt_deg=AxisRange(start=-15, stop=0, step=1),
...                   focal_px=AxisRange(start=500, stop=800, step=50))
>>> grid.size()
5712
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from synthcal.config import GRID_AXES, GridConfig

__all__ = ["grid_axes", "CameraSamples", "sample_cameras", "redraw_cameras"]


def grid_axes(
    grid: GridConfig,
    scene_position: tuple[float, float, float] | None = None,
    anchor: tuple[float, float] | None = None,
) -> list[np.ndarray]:
    """The six axes' values, X/Y/Z from the scene when the grid leaves them out.

    Args:
        grid: the grid; with ``xy_relative`` its X/Y are offsets from ``anchor``.
        scene_position: the scene's ``(X, Y, Z)`` for a grid without X/Y/Z.
        anchor: the scene's camera anchor (:attr:`synthcal.scenes.Scene.anchor`),
            needed by a relative grid.

    Returns:
        six (K_i,) float64 arrays in :data:`~synthcal.config.GRID_AXES` order.

    Raises:
        ValueError: the grid has no X/Y/Z and the scene no camera position, or
            the grid is relative and no anchor is given.
    """
    axes = _Axes(grid, scene_position, anchor)
    return [axes.at(i, np.arange(count)) for i, count in enumerate(axes.shape)]


class _Axes:
    """A grid's six axes as closed forms (its shape, the values at positions): sampling never
    materialises an axis, which may hold up to :data:`~synthcal.config.MAX_GRID_CAMERAS` values."""

    def __init__(self, grid: GridConfig, scene_position: tuple[float, float, float] | None,
                 anchor: tuple[float, float] | None) -> None:
        if grid.xy_relative:
            if anchor is None:
                raise ValueError("the grid's X/Y are relative to the scene's anchor, but no anchor was given")
            grid = grid.anchored(anchor)
        for name in GRID_AXES[3:]:
            if grid.axis(name) is None and scene_position is None:
                raise ValueError(f"grid axis {name!r} is not given and the scene has no camera_position")
        self.grid = grid
        self.scene_position = scene_position
        self.shape = tuple(grid.counts().values())
        self.size = math.prod(self.shape)

    def at(self, axis: int, positions: np.ndarray) -> np.ndarray:
        """(K,) float64 values of axis ``axis`` (a :data:`GRID_AXES` position) at ``positions``."""
        axis_range = self.grid.axis(GRID_AXES[axis])
        if axis_range is None:
            assert self.scene_position is not None  # checked in __init__
            return np.full(len(positions), float(self.scene_position[axis - 3]))
        return axis_range.value_at(positions)

    def cameras(self, grid_index: np.ndarray) -> np.ndarray:
        """(K, 6) values of the grid cameras numbered ``grid_index`` (C order over the axes)."""
        positions = np.unravel_index(grid_index, self.shape)
        return np.stack([self.at(i, pos) for i, pos in enumerate(positions)], axis=-1)


@dataclass(frozen=True)
class CameraSamples:
    """N cameras drawn from a grid.

    Attributes:
        grid_index: (N,) int64 positions in the enumerated grid.
        values: (N, 6) float64 pan_deg, tilt_deg, focal_px (at the reference
            width), x, y, z of each camera (jittered when asked).
    """

    grid_index: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.grid_index)

    def __getitem__(self, index: slice) -> CameraSamples:
        return CameraSamples(self.grid_index[index], self.values[index])


def sample_cameras(
    grid: GridConfig,
    count: int,
    seed: int | tuple[int, ...],
    scene_position: tuple[float, float, float] | None = None,
    anchor: tuple[float, float] | None = None,
) -> CameraSamples:
    """Draw ``count`` distinct grid cameras uniformly, reproducibly from ``seed``.

    With ``grid.jitter`` each value moves uniformly within its grid cell
    (± half a step; axes with a single value stay put). ``scene_position`` and
    ``anchor`` are as in :func:`grid_axes`. ``seed`` is an int or a sequence of
    ints (``numpy.random.SeedSequence`` entropy).

    Raises:
        ValueError: ``count`` exceeds the grid size.
    """
    axes = _Axes(grid, scene_position, anchor)
    if count > axes.size:
        raise ValueError(f"{count} samples asked for, but the grid holds only {axes.size} cameras")
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0,)))
    grid_index = rng.choice(axes.size, size=count, replace=False).astype(np.int64)
    values = axes.cameras(grid_index)
    if grid.jitter:
        values = _jitter(axes, values, rng)
    return CameraSamples(grid_index=grid_index, values=values)


def redraw_cameras(
    grid: GridConfig,
    samples: CameraSamples,
    keep: Callable[[np.ndarray], np.ndarray],
    seed: int | tuple[int, ...],
    scene_position: tuple[float, float, float] | None = None,
    anchor: tuple[float, float] | None = None,
    max_draws: int = 1000,
) -> tuple[CameraSamples, int]:
    """Replace the cameras that ``keep`` rejects, deterministically.

    Sample ``i``'s replacements come from its own stream,
    ``SeedSequence(seed, spawn_key=(4, i))``: grid cameras drawn uniformly one at a
    time (each jittered from the same stream when the grid jitters), skipping any
    grid camera the pool holds or held; the first one ``keep`` accepts takes its
    place. Rejected samples are redrawn in index order, so the result depends on
    the seed, the grid and ``keep`` alone (never on how the pool is rendered later).

    Args:
        grid, seed, scene_position, anchor: as for :func:`sample_cameras`, which
            drew ``samples``.
        samples: the pool's cameras.
        keep: (K, 6) camera values → (K,) bool, True for a camera to keep.
        max_draws: draws per rejected sample before giving up.

    Returns:
        the cameras (rejected ones replaced) and how many were replaced.

    Raises:
        ValueError: a sample found no acceptable camera in ``max_draws`` draws.
    """
    rejected = np.flatnonzero(~np.asarray(keep(samples.values), bool))
    if len(rejected) == 0:
        return samples, 0
    axes = _Axes(grid, scene_position, anchor)
    grid_index, values = samples.grid_index.copy(), samples.values.copy()
    taken = set(grid_index.tolist())
    for i in rejected.tolist():
        grid_index[i], values[i] = _redraw_one(axes, taken, keep, seed, i, max_draws)
        taken.add(int(grid_index[i]))
    return CameraSamples(grid_index=grid_index, values=values), len(rejected)


def _redraw_one(
    axes: _Axes, taken: set[int], keep: Callable[[np.ndarray], np.ndarray], seed: int | tuple[int, ...],
    sample: int, max_draws: int,
) -> tuple[int, np.ndarray]:
    """The first camera of sample ``sample``'s redraw stream that is not taken and that ``keep`` accepts."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(4, sample)))
    for _ in range(max_draws):
        index = int(rng.integers(axes.size))
        value = axes.cameras(np.array([index]))
        if axes.grid.jitter:
            value = _jitter(axes, value, rng)
        if index not in taken and bool(keep(value)[0]):
            return index, value[0]
    raise ValueError(f"sample {sample}: no acceptable camera in {max_draws} draws from the grid")


def _jitter(axes: _Axes, values: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Move each value uniformly within its cell, the cell clipped to the range.

    Clipping keeps e.g. tilt ≤ 0 (SPEC §2 relies on it); a full-circle pan axis
    wraps instead and is not clipped.
    """
    low, high = values.copy(), values.copy()
    for i, (name, count) in enumerate(zip(GRID_AXES, axes.shape, strict=True)):
        axis = axes.grid.axis(name)
        if axis is None or count < 2:
            continue
        low[:, i] -= axis.step / 2
        high[:, i] += axis.step / 2
        if not (name == "pan_deg" and count * axis.step >= 360.0 - 1e-9):
            low[:, i] = np.maximum(low[:, i], axis.value_at(0))
            high[:, i] = np.minimum(high[:, i], axis.value_at(count - 1))
    return low + rng.uniform(size=values.shape) * (high - low)
