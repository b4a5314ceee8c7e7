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

from dataclasses import dataclass

import numpy as np

from synthcal.config import GRID_AXES, GridConfig

__all__ = ["grid_axes", "CameraSamples", "sample_cameras"]


def grid_axes(grid: GridConfig, scene_position: tuple[float, float, float] | None = None) -> list[np.ndarray]:
    """The six axes' values, X/Y/Z from the scene when the grid leaves them out.

    Returns:
        six (K_i,) float64 arrays in :data:`~synthcal.config.GRID_AXES` order.

    Raises:
        ValueError: the grid has no X/Y/Z and the scene no camera position.
    """
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
    seed: int,
    scene_position: tuple[float, float, float] | None = None,
) -> CameraSamples:
    """Draw ``count`` distinct grid cameras uniformly, reproducibly from ``seed``.

    With ``grid.jitter`` each value moves uniformly within its grid cell
    (± half a step; axes with a single value stay put).

    Raises:
        ValueError: ``count`` exceeds the grid size.
    """
    axes = grid_axes(grid, scene_position)
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
