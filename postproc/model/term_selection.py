"""Which terms of a candidate family the data support: best-subset regression with
cross-validation and a stability check.

The problem: a residual ``target`` (rows) is explained by always-present ``base`` columns
(the model's identified parameters) plus a few *terms* out of a family (for reducer
harmonics: one sin/cos column pair per joint and order, 24 terms). Which terms?

Why best subset and not greedy forward selection or group lasso:

- Greedy forward selection commits to the term that helps most *alone*. Harmonic terms are
  correlated once mapped through the arm's Jacobian and partly absorbed by the base
  parameters, so the best single term can be a wrong one (2:2 standing in for 2:4 + 3:3)
  and every later step builds on it.
- Group lasso / SR3 find the true support only under an irrepresentable condition (the
  wrong terms must not be well explained by the right ones), which correlated harmonic
  images violate; their shrinkage also biases the coefficients, so the support is then
  re-chosen by a threshold - a second tuning knob. STLSQ (PySINDy) is a thresholded
  version of the same joint fit and inherits the threshold choice.
- The family is small (tens of terms) and the true support is short, so the L0 problem can
  be solved almost exactly: with the base columns profiled out once per training set
  (Schur complement of the normal equations), the fit of any support is a solve of
  size 2|S|, so every support of up to three terms (and a wide beam of the best ones
  beyond) is scored in one batched solve.

Model size by K-fold cross-validation: within every training fold the best support of
each size is found again (so the score is honest about the search), and the smallest
size whose held-out error is within one paired standard error (or 2 %) of the best is
taken (the one-standard-error rule: a spurious term that wins by noise is not kept). The support is
then the best one of that size on all data.

Stability: the same search, at the chosen size, on each fold's training set and on
``n_resamples`` random halves of the units; each term's selection frequency is reported,
and how often the whole support came out exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BEAM = 3000  # supports of one size extended to the next; exhaustive for 24 terms up to size 3


@dataclass(frozen=True)
class TermSelection:
    chosen: tuple[int, ...]  # indices of the chosen terms (into ``groups``), sorted
    stability: np.ndarray  # (n_terms,) how often each term was chosen over the resamples
    support_stability: float  # how often exactly the chosen support came out
    cv_rms: float  # held-out RMS per unit of the chosen size
    cv_rms_by_size: np.ndarray  # (max_terms + 1,) held-out RMS per unit for each size (0: no term)
    coef: np.ndarray  # (n_cols,) coefficients of the design columns on all data (0 off the support)


@dataclass(frozen=True)
class _Reduced:
    """Normal equations of one training set with the base columns profiled out."""

    gram: np.ndarray  # (p + 1, p + 1) candidate Gram (last: a padding column, identity)
    rhs: np.ndarray  # (p + 1,)
    base_map: np.ndarray  # (n_base, p + 1): base coefficients that each column / the target carry
    target_map: np.ndarray  # (n_base,)


def _reduce(design: np.ndarray, base: np.ndarray, target: np.ndarray, weight: np.ndarray) -> _Reduced:
    bw = base * weight[:, None]
    g_bb = bw.T @ base
    g_bb += 1e-12 * np.trace(g_bb) / max(len(g_bb), 1) * np.eye(len(g_bb))
    maps = np.linalg.solve(g_bb, bw.T @ np.column_stack([design, target])) if base.shape[1] else np.zeros((0, design.shape[1] + 1))
    xw = design * weight[:, None]
    gram = xw.T @ design - (xw.T @ base) @ maps[:, :-1]
    rhs = xw.T @ target - (xw.T @ base) @ maps[:, -1]
    p = design.shape[1]
    padded = np.eye(p + 1)
    padded[:p, :p] = gram
    return _Reduced(padded, np.r_[rhs, 0.0], np.column_stack([maps[:, :-1], np.zeros(len(maps))]), maps[:, -1])


def _padded_groups(groups: list[np.ndarray], pad: int) -> np.ndarray:
    """(n_terms, widest) column indices of each term, short terms padded with ``pad``."""
    out = np.full((len(groups), max(len(g) for g in groups)), pad)
    for t, g in enumerate(groups):
        out[t, : len(g)] = g
    return out


def _gains(red: _Reduced, cols: np.ndarray) -> np.ndarray:
    """Reduction of the residual sum of squares by each support's columns (batched solve)."""
    g = red.gram[cols[:, :, None], cols[:, None, :]]
    r = red.rhs[cols]
    scale = np.maximum(np.einsum("mii->m", g) / cols.shape[1], 1e-300)
    g = g + 1e-10 * scale[:, None, None] * np.eye(cols.shape[1])
    return np.einsum("mi,mi->m", r, np.linalg.solve(g, r[..., None])[..., 0])


def _best_by_size(red: _Reduced, term_cols: np.ndarray, max_terms: int, beam: int) -> list[tuple[int, ...]]:
    """The support of each size 0..max_terms that fits the training set best (beam search,
    exhaustive while a size has at most ``beam`` supports)."""
    n_terms = len(term_cols)
    best = [()]
    frontier = np.zeros((1, 0), dtype=int)
    for size in range(1, min(max_terms, n_terms) + 1):
        grown = np.concatenate([np.repeat(frontier, n_terms, axis=0), np.tile(np.arange(n_terms), len(frontier))[:, None]], axis=1)
        grown = grown[~np.any(grown[:, :-1] == grown[:, -1:], axis=1)]
        rows = np.sort(grown, axis=1)
        # Unique rows in lexicographic order, as np.unique(axis=0) gives them, through one
        # integer per row (digits base n_terms): a 1-D unique is ~50 x faster than a row-wise one.
        _, first = np.unique(rows @ (n_terms ** np.arange(size - 1, -1, -1)), return_index=True)
        supports = rows[first]
        gains = _gains(red, term_cols[supports].reshape(len(supports), -1))
        order = np.argsort(-gains, kind="stable")
        best.append(tuple(int(t) for t in supports[order[0]]))
        frontier = supports[order[:beam]]
    return best


def _solve_support(red: _Reduced, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of the support's columns and of the base columns."""
    if len(cols) == 0:
        return np.zeros(0), red.target_map
    g = red.gram[np.ix_(cols, cols)]
    coef = np.linalg.lstsq(g, red.rhs[cols], rcond=1e-12)[0]
    return coef, red.target_map - red.base_map[:, cols] @ coef


def _heldout_sq(design, base, target, red, support, groups, test) -> np.ndarray:
    cols = np.concatenate([groups[t] for t in support]) if support else np.zeros(0, int)
    coef, base_coef = _solve_support(red, cols)
    pred = design[test][:, cols] @ coef + base[test] @ base_coef
    return (target[test] - pred) ** 2


def select_terms(
    design: np.ndarray,
    target: np.ndarray,
    groups,
    fold_of: np.ndarray,
    *,
    base: np.ndarray | None = None,
    unit_of: np.ndarray | None = None,
    max_terms: int = 4,
    n_resamples: int = 30,
    seed: int = 0,
    beam: int = BEAM,
    min_gain: float = 0.02,
) -> TermSelection:
    """Choose the terms (column groups of ``design``) that explain ``target`` beyond ``base``.

    design: (rows, n_cols) candidate columns; groups: one sequence of column indices per
    term; fold_of: (rows,) fold number of each row (rows of one unit - a pose's x, y, z -
    share a fold); base: (rows, n_base) columns always in the model, not penalised;
    unit_of: (rows,) unit of each row for per-unit errors and resampling (default: rows);
    max_terms: the largest support tried; n_resamples: random halves for the stability
    check; min_gain: the share of held-out MSE a size must gain to be preferred.
    """
    design = np.asarray(design, float)
    target = np.asarray(target, float)
    groups = [np.asarray(g, dtype=int) for g in groups]
    base = np.zeros((len(target), 0)) if base is None else np.asarray(base, float)
    base = base / np.maximum(np.linalg.norm(base, axis=0), 1e-300)  # unit columns: the profiling solve is well scaled
    unit_of = np.arange(len(target)) if unit_of is None else np.unique(unit_of, return_inverse=True)[1]
    max_terms = min(max_terms, len(groups))
    term_cols = _padded_groups(groups, design.shape[1])  # the padding column of _Reduced
    problem = (design, base, target)

    unit_sq, fold_best = _cross_validate(problem, groups, term_cols, fold_of, unit_of, max_terms, beam)
    size = _one_standard_error(unit_sq, min_gain)
    full = _reduce(*problem, np.ones(len(target)))
    chosen = _best_by_size(full, term_cols, size, beam)[size]
    picks = [best[size] for best in fold_best] + _half_sample_picks(problem, term_cols, unit_of, size, n_resamples, seed, beam)
    stability = np.zeros(len(groups))
    for pick in picks:
        stability[list(pick)] += 1
    coef = np.zeros(design.shape[1])
    cols = np.concatenate([groups[t] for t in chosen]) if chosen else np.zeros(0, int)
    coef[cols] = _solve_support(full, cols)[0]
    rms_by_size = np.sqrt(unit_sq.mean(axis=1))
    return TermSelection(
        chosen=tuple(sorted(chosen)),
        stability=stability / len(picks),
        support_stability=float(np.mean([tuple(sorted(p)) == tuple(sorted(chosen)) for p in picks])),
        cv_rms=float(rms_by_size[size]),
        cv_rms_by_size=rms_by_size,
        coef=coef,
    )


def _cross_validate(problem, groups, term_cols, fold_of, unit_of, max_terms, beam):
    """Held-out squared error per unit (sizes x units), the search redone in each training
    fold; and each fold's best support of every size."""
    design, base, target = problem
    unit_sq = np.zeros((max_terms + 1, int(unit_of.max()) + 1))
    fold_best = []
    for k in np.unique(fold_of):
        test = fold_of == k
        red = _reduce(design, base, target, (~test).astype(float))
        best = _best_by_size(red, term_cols, max_terms, beam)
        fold_best.append(best)
        for size, support in enumerate(best):
            np.add.at(unit_sq[size], unit_of[test], _heldout_sq(design, base, target, red, support, groups, test))
    return unit_sq, fold_best


def _half_sample_picks(problem, term_cols, unit_of, size, n_resamples, seed, beam) -> list[tuple[int, ...]]:
    """The best support of ``size`` on random halves of the units (stability selection)."""
    rng = np.random.default_rng(seed)
    n_units = int(unit_of.max()) + 1
    picks = []
    for _ in range(n_resamples):
        weight = np.isin(unit_of, rng.permutation(n_units)[: n_units // 2]).astype(float)
        picks.append(_best_by_size(_reduce(*problem, weight), term_cols, size, beam)[size])
    return picks


def _one_standard_error(unit_sq: np.ndarray, min_gain: float) -> int:
    """Smallest size whose held-out mean squared error exceeds the best size's by at most
    one paired standard error (per-unit differences) or by ``min_gain`` of it (a term that
    buys less than 2 % of the held-out MSE is not worth a parameter pair)."""
    mean = unit_sq.mean(axis=1)
    best = int(np.argmin(mean))
    for size in range(best + 1):
        diff = unit_sq[size] - unit_sq[best]
        se = diff.std(ddof=1) / np.sqrt(len(diff)) if len(diff) > 1 else 0.0
        if diff.mean() <= max(se, min_gain * mean[best]):
            return size
    return best


def term_labels(labels, selection: TermSelection) -> str:
    """'2:4 (100 %), 3:3 (97 %)': the chosen terms' labels with their selection frequency."""
    return ", ".join(f"{labels[t]} ({100 * selection.stability[t]:.0f} %)" for t in selection.chosen)


__all__ = ["TermSelection", "select_terms", "term_labels"]
