"""The noise floor a model's error is judged against, estimated from the data.

Repeats first: poses measured more than once (the same joint values) give the
measurement and repeatability noise directly, as the pooled spread within each repeated
pose. Without enough repeats, the residual of a flexible fit: kernel ridge regression of
the model's residual on the per-pose variables (joint angles, approach directions,
load, temperature, time), its smoothness chosen by generalised cross-validation, and
the noise variance as the residual sum of squares over the degrees of freedom left
(RSS / (3N - P - 3 tr H)). What no smooth function of those variables can follow is
treated as noise, so the floor is an upper estimate when the residual holds structure
too fine for the smoother.

The floor is the 3-D RMS pure noise would give: sqrt(3) x the per-axis sigma.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .measurements import MeasurementSet

#: repeated poses count as such when their joint values agree to this (degrees)
REPEAT_TOL_DEG = 1e-3
#: degrees of freedom within repeats needed to use them rather than a flexible fit
MIN_REPEAT_DOF = 10
#: the RBF kernel's length scales tried, in units of each standardised variable
LENGTH_SCALES = (0.35, 0.7, 1.4, 2.8)
#: poses the flexible fit uses at most (a seeded subset of a larger set)
MAX_POSES = 300
#: the smoother may spend at most this share of the poses on effective parameters
MAX_DF_SHARE = 0.5


@dataclass(frozen=True)
class NoiseFloor:
    floor_mm: float  # 3-D RMS of pure noise
    sigma_axis_mm: float  # per-axis standard deviation
    method: str  # 'repeats', 'flexible fit' or 'given'
    detail: str  # how it was estimated, for the report

    def as_json(self) -> dict:
        return {"floor_mm": self.floor_mm, "sigma_axis_mm": self.sigma_axis_mm, "method": self.method, "detail": self.detail}


def given(noise_mm: float) -> NoiseFloor:
    """The floor of a noise the user states (per axis, mm)."""
    return NoiseFloor(float(noise_mm * np.sqrt(3.0)), float(noise_mm), "given", f"noise given as {noise_mm:g} mm per axis")


def lowered(noise: NoiseFloor, floor_mm: float, why: str) -> NoiseFloor:
    """A lower floor than ``noise`` found otherwise (a held-out RMS below it)."""
    return NoiseFloor(float(floor_mm), float(floor_mm / np.sqrt(3.0)), noise.method,
                      f"{why}, below the {noise.floor_mm:.4f} mm of the {noise.detail}")


def estimate(meas: MeasurementSet, resid: np.ndarray, n_params: int = 0, focus: np.ndarray | None = None) -> NoiseFloor:
    """The noise floor of ``meas`` from repeats, else from a flexible fit of ``resid`` (N, 3),
    the residual of a model with ``n_params`` identified parameters.

    ``focus``: (N, k) the few variables the residual is known to follow; a smoother on them
    alone follows what one on every variable is too coarse for, and each fit's noise
    estimate is an upper bound, so the smaller of the two is kept."""
    from_repeats = _repeats(meas.q_deg, resid)
    if from_repeats is not None:
        return from_repeats
    fits = [_flexible_fit(pose_features(meas), resid, n_params)]
    if focus is not None and focus.shape[1]:
        fits.append(_flexible_fit(_standardised(focus), resid, n_params, "the variables the residual follows"))
    # No smoother: the model's own residual, per degree of freedom, bounds the noise too.
    own = float(np.sqrt(np.sum(resid**2) / max(resid.size - n_params, 1)))
    fits.append(NoiseFloor(float(np.sqrt(3.0) * own), own, "flexible fit", "the model's own residual (no smoother did better)"))
    return min(fits, key=lambda f: f.floor_mm)


def _repeats(q_deg: np.ndarray, resid: np.ndarray) -> NoiseFloor | None:
    keys = np.round(np.asarray(q_deg) / REPEAT_TOL_DEG).astype(np.int64)
    _, group, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    dof = int(np.sum(counts[counts > 1] - 1))
    if dof < MIN_REPEAT_DOF:
        return None
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, group, resid)
    means = sums / counts[:, None]
    ss = float(np.sum((resid - means[group]) ** 2))
    sigma = np.sqrt(ss / (3 * dof))
    return NoiseFloor(float(np.sqrt(3.0) * sigma), float(sigma), "repeats", f"spread within {int(np.sum(counts > 1))} repeated poses ({dof} degrees of freedom)")


def pose_features(meas: MeasurementSet) -> np.ndarray:
    """(N, d) standardised per-pose variables the residual may follow."""
    columns = [np.deg2rad(meas.q_deg)]
    if meas.approach is not None:
        columns.append(meas.approach)
    for extra in (None if meas.force_n is None else np.linalg.norm(meas.force_n, axis=1), meas.temp_c, meas.time_s):
        if extra is not None:
            columns.append(np.asarray(extra, dtype=float)[:, None])
    return _standardised(np.hstack(columns))


def _standardised(x: np.ndarray) -> np.ndarray:
    spread = x.std(axis=0)
    keep = spread > 1e-12
    return (x[:, keep] - x[:, keep].mean(axis=0)) / spread[keep]


def _flexible_fit(x: np.ndarray, resid: np.ndarray, n_params: int, on: str = "the per-pose variables") -> NoiseFloor:
    if len(x) > MAX_POSES:
        # The noise is the same over any subset; the kernel's eigendecomposition costs N^3.
        keep = np.sort(np.random.default_rng(0).choice(len(x), MAX_POSES, replace=False))
        x, resid, n_params = x[keep], resid[keep], int(round(n_params * MAX_POSES / len(x)))
    n = len(x)
    sq = np.sum(x**2, axis=1)
    dist2 = np.maximum(sq[:, None] + sq[None, :] - 2 * x @ x.T, 0.0)
    best = None
    for ell in LENGTH_SCALES:
        eig, vec = np.linalg.eigh(np.exp(-dist2 / (2 * (ell**2) * x.shape[1])))
        eig = np.clip(eig, 0.0, None)
        proj2 = np.sum((vec.T @ (resid - resid.mean(axis=0))) ** 2, axis=1)  # (N,) summed over the axes
        for lam in eig.max() * np.logspace(-6, 0, 25):
            shrink = lam / (eig + lam)
            rss = float(np.sum(proj2 * shrink**2))
            df = float(np.sum(eig / (eig + lam))) + 1.0  # + the mean
            if df > MAX_DF_SHARE * n:
                continue  # RSS / (N - df) is too unsteady an estimate so close to interpolation
            gcv = n * rss / (n - df) ** 2
            if best is None or gcv < best[0]:
                best = (gcv, rss, df, ell)
    _, rss, df, ell = best
    dof = max(3 * (n - df) - n_params, 1.0)
    sigma = float(np.sqrt(rss / dof))
    return NoiseFloor(float(np.sqrt(3.0) * sigma), sigma, "flexible fit",
                      f"residual of a kernel ridge fit on {on} ({df:.0f} effective parameters per axis, GCV)")
