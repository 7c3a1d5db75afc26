"""Linear-axis error map from a measured grid (seed 004): trilinear inside, an error outside.

CSV columns x, y, z (commanded linear axes, mm) and dx, dy, dz (measured minus commanded,
mm), one row per grid point; '#' comments. The points must form a rectilinear grid (every
combination of the distinct x, y and z values, in any order). An axis with one distinct
value (a planar grid, or seed 004's line-wise measurement along one axis) is not varied:
the map is taken as independent of that coordinate, and says so. Points outside the
extents of the varied axes are refused (never extrapolated).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from .errors import ProbeFileError
from .probes import _number, _rows


class GridFileError(ProbeFileError):
    """A grid CSV that is malformed or not a rectilinear grid (row and column named)."""


@dataclass(frozen=True)
class GridMap:
    path: str
    axes: tuple[np.ndarray, np.ndarray, np.ndarray]  # distinct grid values per axis (sorted)
    varied: tuple[bool, bool, bool]
    interpolator: RegularGridInterpolator | None
    constant: np.ndarray | None  # (3,) the one offset of a single-point grid

    @property
    def notes(self) -> list[str]:
        fixed = [f"{ax} = {vals[0]:g}" for ax, vals, v in zip("xyz", self.axes, self.varied) if not v]
        return [f"grid {Path(self.path).name} was measured at {', '.join(fixed)} only: its errors are taken as the same at every {', '.join(f[0] for f in fixed)}"] if fixed else []

    def inside(self, points: np.ndarray) -> np.ndarray:
        ok = np.ones(len(points), bool)
        for k in range(3):
            if self.varied[k]:
                ok &= (points[:, k] >= self.axes[k][0] - 1e-9) & (points[:, k] <= self.axes[k][-1] + 1e-9)
        return ok

    def offset(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) error (actual - commanded) at commanded linear positions (N, 3), NaN outside."""
        points = np.atleast_2d(points)
        out = np.full((len(points), 3), np.nan)
        ok = self.inside(points)
        if self.interpolator is None:
            out[ok] = self.constant
        else:
            dims = [k for k in range(3) if self.varied[k]]
            out[ok] = self.interpolator(points[ok][:, dims])
        return out


def load_grid(path: str | Path) -> GridMap:
    path = Path(path)
    header, data = _rows(path)
    need = ("x", "y", "z", "dx", "dy", "dz")
    for name in header:
        if name not in need:
            raise GridFileError(path, None, name, f"unknown column (a grid has {', '.join(need)})")
    for name in need:
        if name not in header:
            raise GridFileError(path, None, name, "required column missing")
    col = [header.index(n) for n in need]
    values = np.empty((len(data), 6))
    for k, line, row in data:
        if len(row) != len(header):
            raise GridFileError(path, k, None, f"{len(row)} fields, the header has {len(header)} (file line {line})")
        values[k - 1] = [_number(path, k, n, row[c], GridFileError) for n, c in zip(need, col)]
    if not len(values):
        raise GridFileError(path, None, None, "no grid points")
    return _build(path, values)


def _build(path: Path, values: np.ndarray) -> GridMap:
    axes = tuple(np.unique(values[:, k]) for k in range(3))
    shape = tuple(len(a) for a in axes)
    if np.prod(shape) != len(values):
        raise GridFileError(path, None, None, f"{len(values)} points are not a rectilinear grid of the {shape[0]} x, {shape[1]} y and {shape[2]} z values they use")
    idx = tuple(np.searchsorted(axes[k], values[:, k]) for k in range(3))
    grid = np.full(shape + (3,), np.nan)
    grid[idx] = values[:, 3:6]
    if np.isnan(grid).any():  # a repeated point leaves another missing
        flat = np.ravel_multi_index(idx, shape)
        first_dup = int(np.nonzero(np.bincount(flat, minlength=np.prod(shape))[flat] > 1)[0][0])
        raise GridFileError(path, first_dup + 1, None, "grid point given twice (another point of the grid is missing)")
    varied = tuple(n > 1 for n in shape)
    dims = [k for k in range(3) if varied[k]]
    if not dims:
        return GridMap(str(path), axes, varied, None, grid.reshape(3))
    squeezed = grid.reshape(tuple(shape[k] for k in dims) + (3,))
    interp = RegularGridInterpolator(tuple(axes[k] for k in dims), squeezed, method="linear", bounds_error=False, fill_value=np.nan)
    return GridMap(str(path), axes, varied, interp, None)
