"""Held-out errors of a model by a linearised refit per fold.

A model fitted on the whole set sits at its least-squares optimum; leaving a fold out
moves the optimum a little, and one Gauss-Newton step from it, with the analytic Jacobian
the fit already uses, lands where the full nonlinear refit does to well below the noise
(tests/test_diagnose_speed.py compares the two). The same linearisation answers "what if
this effect were added": the effect's analytic columns join the model's, and each fold is
one small least-squares solve instead of a nonlinear fit. A parameter a fit left at a
bound is held there (``inside_bounds``); a candidate's own parameters start at their
initial values, so a candidate about to be recommended is confirmed by the real fit
(``postproc.model.candidates``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errormodel import ErrorModel, Prepared
from .identify import identifiability
from .measurements import MeasurementSet

#: relative singular-value cut of the per-fold solves (columns the fold cannot separate)
RCOND = 1e-9


@dataclass(frozen=True)
class Linearised:
    """A model at its fit: what it misses (measured - predicted, (N, 3)) and the Jacobian's
    identifiable columns (N, 3, P), each scaled to unit norm."""

    miss: np.ndarray
    jac: np.ndarray
    free: np.ndarray  # which of the model's parameters the columns are


def linearise(model: ErrorModel, meas: MeasurementSet, prep: Prepared | None = None, free: np.ndarray | None = None) -> Linearised:
    """``model`` linearised on ``meas``; ``free``: the parameters to refit (default: the
    identifiable ones, by the fit's own rule)."""
    prep = model.prepare(meas) if prep is None else prep
    predicted, jac = model.evaluate(prep)
    if free is None:
        free, _ = identifiability(model, prep, np.ones(len(model.params), dtype=bool))
    return Linearised(meas.measured_mm - predicted, _unit_columns(jac[:, :, free]), np.asarray(free, dtype=bool))


def inside_bounds(model: ErrorModel, free: np.ndarray) -> np.ndarray:
    """``free`` less the parameters a fit left at one of their bounds: a linearised step
    would carry them past it (a play below zero), where no fit can go."""
    lower = np.array([p.lower for p in model.params])
    upper = np.array([p.upper for p in model.params])
    tol = 1e-9 * np.array([p.scale for p in model.params])
    return np.asarray(free, dtype=bool) & (model.values > lower + tol) & (model.values < upper - tol)


def _unit_columns(jac: np.ndarray) -> np.ndarray:
    if jac.shape[-1] == 0:  # the nominal model: nothing to refit
        return jac
    norms = np.linalg.norm(jac.reshape(-1, jac.shape[-1]), axis=0)
    keep = norms > 1e-12 * max(norms.max(initial=0.0), 1e-300)
    return jac[:, :, keep] / norms[keep]


def held_out_miss(lin: Linearised, fold_of: np.ndarray) -> np.ndarray:
    """(N, 3) measured - predicted of each pose by the model refitted without its fold."""
    out = np.empty_like(lin.miss)
    if lin.jac.shape[-1] == 0:
        return lin.miss.copy()
    for k in np.unique(fold_of):
        test = fold_of == k
        a = lin.jac[~test].reshape(-1, lin.jac.shape[-1])
        step, *_ = np.linalg.lstsq(a, lin.miss[~test].ravel(), rcond=RCOND)
        out[test] = lin.miss[test] - lin.jac[test] @ step
    return out


def fitted_miss(lin: Linearised) -> np.ndarray:
    """(N, 3) measured - predicted after the linearised refit on the whole set."""
    if lin.jac.shape[-1] == 0:
        return lin.miss.copy()
    step, *_ = np.linalg.lstsq(lin.jac.reshape(-1, lin.jac.shape[-1]), lin.miss.ravel(), rcond=RCOND)
    return lin.miss - lin.jac @ step


def rms(miss: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(miss**2, axis=1))))
