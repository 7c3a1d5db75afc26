"""Which cyclic joint errors (``joint_harmonics`` terms) a dense measurement set supports.

A joint's transmission or encoder error repeats with the joint angle: delta q_j is a
Fourier series in q_j. Its image at the measured point is dp/dq_j times that series, the
column ``joint_harmonics`` fits. On a set dense in joint space (neighbouring poses closer
than a period) two questions are answered here, on a model's residual linearised around
its fit:

- ``periodogram``: each single term (joint j, order k) fitted on training rows and scored
  on held-out rows, for every order of a range (a strain-wave gear's transmission error
  would show near once and twice its ratio);
- ``choose_terms``: forward selection over joints and orders, the number of terms by
  cross-validation grouped by a column (e.g. the commanded position, so that all poses of
  one position are held out together and a term is not kept for what a neighbour already
  carries), with the one-standard-error rule.

Forward selection and not ``postproc.model.term_selection``'s best subset: that one is
exact for tens of candidates and a few terms; a joint's cyclic error needs tens of terms
out of hundreds of candidates, where the best-subset search no longer fits. The
cross-validation redoes the whole path in each fold, so the figure it gives is honest
about the search.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Residual:
    """A fitted model's residual on a set, with what the harmonic columns need
    (``postproc.model.identify.cyclic_residual(model, meas)`` makes one)."""

    r: np.ndarray  # (N, 3) predicted - measured, mm
    dp_dq: np.ndarray  # (N, 3, 6) mm per degree of each joint
    base: np.ndarray  # (3N, n_params) the model's identification Jacobian (profiled out)
    q_rad: np.ndarray  # (N, 6)


@dataclass(frozen=True)
class TermChoice:
    terms: tuple[tuple[int, int], ...]  # (joint 1..6, order), in the order they were added
    cv_rms_mm: np.ndarray  # (max_terms + 1,) cross-validated RMS per pose for 0, 1, ... terms


def periodogram(res: Residual, orders: np.ndarray, train: np.ndarray, test: np.ndarray) -> np.ndarray:
    """(6, len(orders)): share of the test rows' sum of squares that each single term removes,
    fitted on the training rows (a 2 x 2 weighted least squares per joint and order)."""
    out = np.zeros((6, len(orders)))
    for j in range(6):
        g = (res.dp_dq[:, :, j] ** 2).sum(axis=1)
        u = -(res.dp_dq[:, :, j] * res.r).sum(axis=1)
        s, c = np.sin(np.outer(res.q_rad[:, j], orders)), np.cos(np.outer(res.q_rad[:, j], orders))
        a11, a22, a12 = ((g[train, None] * m[train]).sum(axis=0) for m in (s * s, c * c, s * c))
        b1, b2 = (u[train, None] * s[train]).sum(axis=0), (u[train, None] * c[train]).sum(axis=0)
        det = a11 * a22 - a12 ** 2
        fitted = ((a22 * b1 - a12 * b2) / det) * s[test] + ((a11 * b2 - a12 * b1) / det) * c[test]
        out[j] = (2 * fitted * u[test, None] - fitted ** 2 * g[test, None]).sum(axis=0) / (res.r[test] ** 2).sum()
    return out


def term_columns(res: Residual, terms) -> np.ndarray:
    """(3N, 2 * len(terms)): joint_harmonics' columns, sin then cos per term."""
    cols = []
    for j, k in terms:
        for wave in (np.sin, np.cos):
            cols.append((res.dp_dq[:, :, j - 1] * wave(k * res.q_rad[:, j - 1])[:, None]).reshape(-1))
    return np.column_stack(cols)


def reduced_normal(design: np.ndarray, base: np.ndarray, target: np.ndarray, rows: np.ndarray):
    """Gram and right-hand side of the design on ``rows`` with the base columns profiled out,
    and the maps that give the base coefficients back."""
    d, b, t = design[rows], base[rows], target[rows]
    g_bb = b.T @ b + 1e-9 * np.trace(b.T @ b) / b.shape[1] * np.eye(b.shape[1])
    maps = np.linalg.solve(g_bb, b.T @ np.column_stack([d, t]))
    gram = d.T @ d - (d.T @ b) @ maps[:, :-1]
    rhs = d.T @ t - (d.T @ b) @ maps[:, -1]
    return gram, rhs, maps


def forward_path(gram: np.ndarray, rhs: np.ndarray, n_terms: int, max_terms: int) -> list[int]:
    """Terms (pairs of columns 2t, 2t+1) added one at a time, each the one that lowers the
    training sum of squares most given those before it (the chosen columns profiled out of
    every candidate's 2 x 2 normal equations)."""
    chosen: list[int] = []
    pairs = np.arange(2 * n_terms).reshape(n_terms, 2)
    for _ in range(min(max_terms, n_terms)):
        cols = pairs[chosen].ravel()
        if len(cols):
            ridge = 1e-10 * np.trace(gram[np.ix_(cols, cols)]) / len(cols) * np.eye(len(cols))
            proj = np.linalg.solve(gram[np.ix_(cols, cols)] + ridge, gram[cols])  # (|S|, all)
            g_red, r_red = gram - gram[:, cols] @ proj, rhs - proj.T @ rhs[cols]
        else:
            g_red, r_red = gram, rhs
        blocks = g_red[pairs[:, :, None], pairs[:, None, :]] + 1e-12 * np.eye(2)
        r = r_red[pairs]
        gains = np.einsum("mi,mi->m", r, np.linalg.solve(blocks, r[..., None])[..., 0])
        gains[chosen] = -np.inf
        chosen.append(int(np.argmax(gains)))
    return chosen


def fitted_prediction(design, base, target, rows, cols, pred_rows) -> np.ndarray:
    """The columns ``cols`` and the base fitted to ``target`` on ``rows``, predicted on ``pred_rows``."""
    gram, rhs, maps = reduced_normal(design[:, cols], base, target, rows)
    coef = np.linalg.solve(gram + 1e-10 * np.eye(len(cols)), rhs)
    return design[pred_rows][:, cols] @ coef + base[pred_rows] @ (maps[:, -1] - maps[:, :-1] @ coef)


def _columns_of(path: list[int]) -> np.ndarray:
    return np.ravel([[2 * t, 2 * t + 1] for t in path]).astype(int)


def per_group_sums(values: np.ndarray, groups: np.ndarray, train: np.ndarray, train_groups: np.ndarray) -> np.ndarray:
    """(sizes, len(train_groups)): each row of ``values`` (sizes, N) summed over the training
    rows of each group (``train_groups``: the sorted ids of the training rows' groups)."""
    group_index = np.searchsorted(train_groups, groups[train])
    return np.stack([np.bincount(group_index, weights=row[train], minlength=len(train_groups)) for row in values])


def _one_standard_error(per_group: np.ndarray, n_rows: int) -> int:
    """The smallest size whose held-out MSE is within one standard error (paired over the
    groups) of the best size's."""
    mse = per_group.sum(axis=1) / n_rows
    best = int(np.argmin(mse))
    std_err = np.sqrt(per_group.shape[1] * np.var(per_group - per_group[best], axis=1)) / n_rows
    return int(np.nonzero(mse <= mse[best] + std_err)[0][0])


def choose_terms(res: Residual, groups: np.ndarray, train: np.ndarray, candidates, max_terms: int = 120, folds: int = 5,
                 seed: int = 0, say: Callable[[str], None] = lambda m: None) -> TermChoice:
    """Forward selection over the ``candidates`` (joint 1..6, order) on the ``train`` rows;
    the number of terms (at most ``max_terms``) by ``folds``-fold cross-validation with whole
    groups (``groups``: an id per row) held out together."""
    candidates = [(int(j), int(k)) for j, k in candidates]
    max_terms = min(max_terms, len(candidates))
    design, target = term_columns(res, candidates), -res.r.reshape(-1)
    train_groups = np.unique(groups[train])
    fold_of_group = dict(zip(train_groups, np.random.default_rng(seed).permutation(len(train_groups)) % folds))
    fold = np.where(train, [fold_of_group.get(g, -1) for g in groups], -1)
    sq = np.zeros((max_terms + 1, len(groups)))
    for f in range(folds):
        say(f"forward selection, cross-validation fold {f + 1}/{folds}")
        fit_rows, held = np.repeat(train & (fold != f), 3), np.repeat(fold == f, 3)
        path = forward_path(*reduced_normal(design, res.base, target, fit_rows)[:2], len(candidates), max_terms)
        for size in range(max_terms + 1):
            pred = fitted_prediction(design, res.base, target, fit_rows, _columns_of(path[:size]), held)
            sq[size, fold == f] = ((target[held] - pred) ** 2).reshape(-1, 3).sum(axis=1)
    per_group = per_group_sums(sq, groups, train, train_groups)
    size = _one_standard_error(per_group, int(train.sum()))
    say("forward selection on all training rows")
    path = forward_path(*reduced_normal(design, res.base, target, np.repeat(train, 3))[:2], len(candidates), size)
    return TermChoice(tuple(candidates[t] for t in path), np.sqrt(per_group.sum(axis=1) / train.sum()))


def amplitude_phase(res: Residual, term: tuple[int, int]) -> tuple[float, float]:
    """One term fitted alone (with the base columns) on the whole set: a sin(k q_j) + b cos(k q_j)
    = A sin(k q_j + phase), as A (mdeg) and phase = atan2(b, a) (deg)."""
    design = term_columns(res, [term])
    x = np.linalg.lstsq(np.column_stack([design, res.base]), -res.r.reshape(-1), rcond=1e-10)[0]
    return 1e3 * float(np.hypot(x[0], x[1])), float(np.degrees(np.arctan2(x[1], x[0])))
