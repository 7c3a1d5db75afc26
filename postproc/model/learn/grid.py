"""Spatial-grid interpolation of position errors (seed 004; seed 001's grid method).

Errors measured on a regular grid of TCP positions are interpolated trilinearly inside
the grid; a query outside its hull is an error, never an extrapolation.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from sklearn.base import BaseEstimator, RegressorMixin

from postproc.errors import InputError


class OutsideGridError(InputError):
    """A position outside the measured grid."""


class GridPredictor(RegressorMixin, BaseEstimator):
    def __init__(self, decimals: int = 6):
        self.decimals = decimals

    def fit(self, X, y):
        X = np.asarray(X, dtype=float)[:, :3]
        y = np.asarray(y, dtype=float)
        axes = [np.unique(np.round(X[:, k], self.decimals)) for k in range(3)]
        shape = tuple(len(a) for a in axes)
        if np.prod(shape) != len(X) or min(shape) < 2:
            raise InputError(f"grid predictor: the {len(X)} points do not form a full regular grid ({' x '.join(map(str, shape))} distinct coordinates)")
        idx = tuple(np.searchsorted(axes[k], np.round(X[:, k], self.decimals)) for k in range(3))
        values = np.full(shape + (y.shape[1],), np.nan)
        values[idx] = y
        if np.isnan(values).any():
            raise InputError("grid predictor: a grid node was measured twice and another not at all")
        self.axes_ = axes
        self.interp_ = RegularGridInterpolator(axes, values, method="linear", bounds_error=False, fill_value=np.nan)
        self.n_features_in_ = 3
        return self

    def predict(self, X):
        X = np.asarray(X, dtype=float)[:, :3]
        lo = np.array([a[0] for a in self.axes_])
        hi = np.array([a[-1] for a in self.axes_])
        # A node computed through kinematics lands a few nm off: within 1 um is on the grid.
        X = np.where((X < lo) & (X > lo - 1e-3), lo, np.where((X > hi) & (X < hi + 1e-3), hi, X))
        out = self.interp_(X)
        outside = np.isnan(out).any(axis=1)
        if outside.any():
            i = int(np.nonzero(outside)[0][0])
            raise OutsideGridError(f"{int(outside.sum())} point(s) outside the measured grid (first: {np.round(X[i], 3).tolist()}, grid spans {lo.tolist()} to {hi.tolist()} mm)")
        return out
