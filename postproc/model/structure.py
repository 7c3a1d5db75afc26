"""What the residual follows: smooth functions of one variable or of two together.

For every per-pose variable (joint angles, approach directions, gravity torques, load,
temperature, time, workspace position) and every pair of the pose variables, the
residual (N, 3) is regressed on a smooth basis of them: Legendre polynomials of a
continuous variable (degree 4 alone; degree 3 each plus their degree-2 products in a
pair), indicators of a categorical one (an approach direction), and the products of the
two in a pair, so a pair captures what neither variable explains alone (a joint's torque
acting only in one approach direction, one joint's angle against another's).

Evidence per variable (or pair): the held-out share of the residual variance the smooth
function explains (k-fold, the diagnosis' folds), and an F test of the in-sample fit
against a constant (Holm-corrected over everything tested, so noise is not structure).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
from numpy.polynomial import legendre
from scipy import stats as sps

ALPHA = 0.05
#: a variable (or pair) is structure when a smooth function of it explains this held-out share
MIN_STRUCTURE = 0.03
#: a pair is named instead of its better variable only when it explains this much more (share)
PAIR_MARGIN = 0.05
SINGLE_DEGREE, PAIR_DEGREE, PRODUCT_DEGREE = 4, 3, 2
#: variables taken in pairs: the per-pose state (workspace position is a function of the joints)
PAIRED_PREFIXES = ("q", "s", "tau", "load", "temp", "time")


@dataclass(frozen=True)
class Structure:
    variables: tuple[str, ...]
    explained: float  # held-out share of the residual variance a smooth function of them explains
    in_sample: float  # in-sample share (R^2)
    p_value: float
    p_adjusted: float = 1.0

    @property
    def name(self) -> str:
        return " x ".join(self.variables)

    @property
    def significant(self) -> bool:
        return self.p_adjusted < ALPHA and self.explained >= MIN_STRUCTURE

    def as_json(self) -> dict:
        return {"variable": self.name, "variables": list(self.variables), "explained": self.explained, "eta2": self.in_sample,
                "p_value": self.p_adjusted, "significant": self.significant}


def basis(values: np.ndarray, categorical: bool, degree: int) -> np.ndarray:
    """(N, k) centred smooth basis of one variable (no constant column)."""
    values = np.asarray(values, dtype=float)
    if categorical:
        levels = np.unique(values)
        cols = np.stack([values == v for v in levels[1:]], axis=1).astype(float) if len(levels) > 1 else np.zeros((len(values), 0))
    else:
        lo, hi = values.min(), values.max()
        z = 2 * (values - lo) / (hi - lo) - 1 if hi > lo else np.zeros_like(values)
        cols = legendre.legvander(z, degree)[:, 1:]
    return cols - cols.mean(axis=0)


def pair_basis(a: tuple[np.ndarray, bool], b: tuple[np.ndarray, bool]) -> np.ndarray:
    """(N, k) centred smooth basis of two variables together (their products included)."""
    return _pair_columns(*({d: basis(v, cat, d) for d in (PAIR_DEGREE, PRODUCT_DEGREE)} for v, cat in (a, b)))


def _pair_columns(a: dict, b: dict) -> np.ndarray:
    low_a, low_b = a[PRODUCT_DEGREE], b[PRODUCT_DEGREE]
    products = (low_a[:, :, None] * low_b[:, None, :]).reshape(len(low_a), -1)
    cols = np.hstack([a[PAIR_DEGREE], b[PAIR_DEGREE], products])
    return cols - cols.mean(axis=0)


def _varies(values: np.ndarray) -> bool:
    return float(np.ptp(values)) > 1e-9 * max(1.0, float(np.abs(values).max()))


def _score(cols: np.ndarray, resid: np.ndarray, fold_of: list[np.ndarray]) -> tuple[float, float, float]:
    """(held-out share, in-sample share, F-test p) of a least-squares fit of resid on cols;
    ``fold_of``: each fold's test mask."""
    n, k = cols.shape
    centred = resid - resid.mean(axis=0)
    total = float(np.sum(centred**2))
    if total <= 0 or k == 0 or n <= k + 2:
        return 0.0, 0.0, 1.0
    design = np.hstack([np.ones((n, 1)), cols])
    coef, _, rank, _ = np.linalg.lstsq(design, resid, rcond=None)
    rss = float(np.sum((resid - design @ coef) ** 2))
    held = 0.0
    for test in fold_of:
        c, *_ = np.linalg.lstsq(design[~test], resid[~test], rcond=None)
        held += float(np.sum((resid[test] - design[test] @ c) ** 2))
    rank -= 1  # the constant
    df1, df2 = 3 * rank, 3 * (n - rank - 1)
    p = float(sps.f.sf(((total - rss) / df1) / (rss / df2), df1, df2)) if rank > 0 and rss > 0 else 1.0
    return 1.0 - held / total, 1.0 - rss / total, p


def find_structure(variables: dict, resid: np.ndarray, fold_of: np.ndarray) -> list[Structure]:
    """Every variable and every pair of pose variables, strongest held-out share first.

    ``variables``: name -> (label, unit, values (N,), categorical)."""
    fold_of = [fold_of == f for f in np.unique(fold_of)]
    usable = {name: (v[2], v[3]) for name, v in variables.items() if _varies(v[2])}
    bases = {name: {d: basis(values, cat, d) for d in (SINGLE_DEGREE, PAIR_DEGREE, PRODUCT_DEGREE)} for name, (values, cat) in usable.items()}
    paired = [name for name in usable if name.startswith(PAIRED_PREFIXES)]
    raw = [((name,), *_score(bases[name][SINGLE_DEGREE], resid, fold_of)) for name in usable]
    for a, b in combinations(paired, 2):
        raw.append(((a, b), *_score(_pair_columns(bases[a], bases[b]), resid, fold_of)))
    adjusted = holm([r[3] for r in raw])
    out = [Structure(names, held, r2, p, p_adj) for (names, held, r2, p), p_adj in zip(raw, adjusted)]
    out.sort(key=lambda s: -s.explained)
    return out


def holm(p_values: list[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (family-wise error control), in the input order."""
    p = np.asarray(p_values, dtype=float)
    order = np.argsort(p)
    scaled = np.minimum(1.0, (len(p) - np.arange(len(p))) * p[order])
    adjusted = np.empty(len(p))
    adjusted[order] = np.maximum.accumulate(scaled)
    return adjusted.tolist()


def named(structures: list[Structure]) -> Structure | None:
    """The variable, or pair, the residual follows: the strongest significant one, a pair
    only when it explains clearly more than the better of its two variables alone."""
    significant = [s for s in structures if s.significant]
    if not significant:
        return None
    singles = {s.variables[0]: s for s in structures if len(s.variables) == 1}
    top = significant[0]
    if len(top.variables) == 2:
        best_single = max((singles[v] for v in top.variables if v in singles), key=lambda s: s.explained, default=None)
        if best_single is not None and best_single.significant and best_single.explained >= top.explained - PAIR_MARGIN:
            return best_single
    return top


def smooth_fit(variables: dict, names: tuple[str, ...], resid: np.ndarray) -> np.ndarray:
    """(N, 3) the smooth function of ``names`` fitted to the residual (for the partial-residual plot)."""
    usable = {name: (variables[name][2], variables[name][3]) for name in names}
    cols = basis(*usable[names[0]], SINGLE_DEGREE) if len(names) == 1 else pair_basis(usable[names[0]], usable[names[1]])
    design = np.hstack([np.ones((len(resid), 1)), cols])
    coef, *_ = np.linalg.lstsq(design, resid, rcond=None)
    return design @ coef
