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
    if grid.xy_relative:
        if anchor is None:
            raise ValueError("the grid's X/Y are relative to the scene's anchor, but no anchor was given")
        grid = grid.anchored(anchor)
    axes = []
    for i, name in enumerate(GRID_AXES):
        axis = grid.axis(name)
        if axis is None:
            if scene_position is None:
                raise ValueError(f"grid axis {name!r} is not given and the scene has no camera_position")
            axes.append(np.array([float(scene_position[i - 3])]))
        else:
            axes.append(axis.values(name))
    return axes


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
    axes = grid_axes(grid, scene_position, anchor)
    grid = grid.anchored(anchor) if grid.xy_relative and anchor is not None else grid
    shape = tuple(len(a) for a in axes)
    size = int(np.prod(shape))
    if count > size:
        raise ValueError(f"{count} samples asked for, but the grid holds only {size} cameras")
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0,)))
    grid_index = rng.choice(size, size=count, replace=False).astype(np.int64)
    positions = np.unravel_index(grid_index, shape)
    values = np.stack([axis[pos] for axis, pos in zip(axes, positions, strict=True)], axis=-1)
    if grid.jitter:
        values = _jitter(grid, axes, values, rng)
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
    axes = grid_axes(grid, scene_position, anchor)
    grid = grid.anchored(anchor) if grid.xy_relative and anchor is not None else grid
    shape = tuple(len(a) for a in axes)
    grid_index, values = samples.grid_index.copy(), samples.values.copy()
    taken = set(grid_index.tolist())
    for i in rejected.tolist():
        grid_index[i], values[i] = _redraw_one(grid, axes, shape, taken, keep, seed, i, max_draws)
        taken.add(int(grid_index[i]))
    return CameraSamples(grid_index=grid_index, values=values), len(rejected)


def _redraw_one(
    grid: GridConfig, axes: list[np.ndarray], shape: tuple[int, ...], taken: set[int],
    keep: Callable[[np.ndarray], np.ndarray], seed: int | tuple[int, ...], sample: int, max_draws: int,
) -> tuple[int, np.ndarray]:
    """The first camera of sample ``sample``'s redraw stream that is not taken and that ``keep`` accepts."""
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(4, sample)))
    size = int(np.prod(shape))
    for _ in range(max_draws):
        index = int(rng.integers(size))
        value = np.array([[axis[pos] for axis, pos in zip(axes, np.unravel_index(index, shape), strict=True)]])
        if grid.jitter:
            value = _jitter(grid, axes, value, rng)
        if index not in taken and bool(keep(value)[0]):
            return index, value[0]
    raise ValueError(f"sample {sample}: no acceptable camera in {max_draws} draws from the grid")


def _jitter(grid: GridConfig, axes: list[np.ndarray], values: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Move each value uniformly within its cell, the cell clipped to the range.

    Clipping keeps e.g. tilt ≤ 0 (SPEC §2 relies on it); a full-circle pan axis
    wraps instead and is not clipped.
    """
    low, high = values.copy(), values.copy()
    for i, (name, axis_vals) in enumerate(zip(GRID_AXES, axes, strict=True)):
        axis = grid.axis(name)
        if axis is None or len(axis_vals) < 2:
            continue
        low[:, i] -= axis.step / 2
        high[:, i] += axis.step / 2
        if not (name == "pan_deg" and len(axis_vals) * axis.step >= 360.0 - 1e-9):
            low[:, i] = np.maximum(low[:, i], axis_vals[0])
            high[:, i] = np.minimum(high[:, i], axis_vals[-1])
    return low + rng.uniform(size=values.shape) * (high - low)
