"""Optimal experiment design over candidate poses (Sun & Hollerbach 2008: observability
index O1 = D-optimal, O3 = E-optimal, A-optimal; Fedorov / DETMAX exchange).

Every candidate pose contributes a 3 x K block ``J_i`` of the identification Jacobian
(identifiable parameters only, each column in units of its parameter's typical size,
rows divided by the measurement noise), so a design's information is
``M = prior + sum_i J_i^T J_i`` and ``M^-1`` is the covariance of the identified
parameters (in those units). The criteria, all to be maximised:

- ``D``: log det M (the volume of the confidence ellipsoid; invariant to the units);
- ``E``: the smallest eigenvalue of M (the worst-determined direction);
- ``A``: -trace(M^-1) (the sum of the parameters' variances);
- ``I``: -trace(W M^-1) with W = G^T G / T, G the position Jacobian at a program's T
  targets: minus the mean predicted error variance (mm^2) there (I-/V-optimal design).

The search is greedy (each step adds the candidate with the largest gain, all
candidates scored at once by rank-3 updates), then exchange passes swap a chosen pose
for a better candidate while that improves the criterion, then, at small N, restarts of
the exchange from the best design with some of its poses replaced at random keep the
best design found (``refine``). Poses fixed in advance (a random share) stay.
Everything is vectorised over candidates. ``i_optimal_bound`` (a pose may repeat) and
``relaxed_i_design`` (distinct poses, tighter) bound from below what any design can reach.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CRITERIA = ("D", "E", "A")
RIDGE = 1e-9  # x the mean per-pose information: makes the empty design invertible, far below any real one
E_SCREEN = 64  # E-optimal exchange: candidates scored exactly after a first-order screen
MAX_EXCHANGE_PASSES = 6
# Restarts of the exchange from the best design with a third of its free poses replaced at random
# (iterated local search): at small N the exchange's local optima differ most (a simulated KR160's
# machining pass, I-optimal, one seed, exploratory: 11 % less variance at N = 14, 0-2 % at N = 16-24,
# < 1 % at N = 32), and each restart costs one exchange, so they are spent where they pay:
# RESTART_POSES / N of them (4 at N = 14, 2 at N = 32, none from N = 65).
RESTART_POSES = 64
PERTURBED_SHARE = 1 / 3


@dataclass(frozen=True)
class Problem:
    """What a design is chosen from: per-candidate information blocks and what is known already."""

    blocks: np.ndarray  # (C, 3, K) whitened, scaled Jacobian of each candidate
    prior: np.ndarray  # (K, K) information of the poses already measured
    weight: np.ndarray | None  # (K, K) G^T G / T at a program's targets (None: no region)
    ridge: float

    @classmethod
    def of(cls, blocks: np.ndarray, prior: np.ndarray | None = None, targets: np.ndarray | None = None) -> "Problem":
        """``targets``: (T, 3, K) position Jacobian at the targets (scaled columns, mm)."""
        k = blocks.shape[-1]
        per_pose = float(np.einsum("cik,cik->", blocks, blocks)) / max(len(blocks), 1) / k
        weight = None
        if targets is not None:
            g = targets.reshape(-1, k)
            weight = g.T @ g / len(targets)
        return cls(blocks, np.zeros((k, k)) if prior is None else prior, weight, RIDGE * max(per_pose, 1e-300))

    def information(self, chosen: np.ndarray) -> np.ndarray:
        """M of the prior plus the chosen candidates (index array, repeats allowed)."""
        b = self.blocks[np.asarray(chosen, dtype=int)].reshape(-1, self.blocks.shape[-1])
        return self.prior + b.T @ b


def criterion_value(problem: Problem, info: np.ndarray, criterion: str) -> float:
    """The criterion of information ``info`` (larger is better); -inf where M is singular."""
    m = info + problem.ridge * np.eye(len(info))
    if criterion == "D":
        sign, logdet = np.linalg.slogdet(m)
        return float(logdet) if sign > 0 else -np.inf
    if criterion == "E":
        return float(np.linalg.eigvalsh(m)[0])
    cov = np.linalg.inv(m)
    weight = problem.weight if criterion == "I" else np.eye(len(info))
    return -float(np.einsum("kl,lk->", weight, cov))


def gains(problem: Problem, info: np.ndarray, criterion: str, among: np.ndarray | None = None) -> np.ndarray:
    """Increase of the criterion from adding each candidate (or those in ``among``) to ``info``."""
    blocks = problem.blocks if among is None else problem.blocks[among]
    m = info + problem.ridge * np.eye(len(info))
    if criterion == "E":
        return _e_gains(m, blocks)
    cov = np.linalg.inv(m)
    c, _, k = blocks.shape
    # one (3C, K) x (K, K) product instead of C small ones
    jc = (blocks.reshape(-1, k) @ cov).reshape(c, 3, k)  # J M^-1
    s = jc @ blocks.transpose(0, 2, 1) + np.eye(3)  # I + J M^-1 J^T
    if criterion == "D":
        return np.linalg.slogdet(s)[1]
    weight = problem.weight if criterion == "I" else np.eye(len(info))
    t = (jc.reshape(-1, k) @ weight).reshape(c, 3, k) @ jc.transpose(0, 2, 1)  # J M^-1 W M^-1 J^T
    # Woodbury: trace(W (M + J^T J)^-1) = trace(W M^-1) - trace((I + J M^-1 J^T)^-1 J M^-1 W M^-1 J^T)
    return np.einsum("cij,cji->c", _inverse_3x3(s), t)


def _inverse_3x3(s: np.ndarray) -> np.ndarray:
    """Inverses of a stack of 3 x 3 matrices by their adjugates (s here is I + a positive
    semi-definite matrix, so det >= 1): several times faster than a batched LAPACK solve."""
    a, b, c = s[:, 0], s[:, 1], s[:, 2]
    adj = np.stack([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=2)  # columns: cofactors of the rows
    det = np.einsum("ci,ci->c", a, adj[:, :, 0])
    return adj / det[:, None, None]


def _e_gains(m: np.ndarray, blocks: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """Smallest eigenvalue of M + J_i^T J_i minus that of M, for every block (batched)."""
    base = np.linalg.eigvalsh(m)[0]
    out = np.empty(len(blocks))
    for start in range(0, len(blocks), chunk):
        b = blocks[start:start + chunk]
        out[start:start + chunk] = np.linalg.eigvalsh(m + b.transpose(0, 2, 1) @ b)[:, 0] - base
    return out


def _e_screen(m: np.ndarray, blocks: np.ndarray, k: int) -> np.ndarray:
    """Indices of the k blocks a first-order estimate (||J_i v||^2 over the few weakest
    directions v of M) rates best: the E criterion's exact batched eigenvalues are then
    needed for those only."""
    values, vectors = np.linalg.eigh(m)
    weak = vectors[:, : min(3, len(values))]
    score = np.einsum("cik,kv->civ", blocks, weak) ** 2
    estimate = (score.sum(axis=1) / np.maximum(values[: weak.shape[1]] - values[0] + 1.0, 1.0)).max(axis=1)
    return np.argsort(-estimate, kind="stable")[:k]


def best_gain(problem: Problem, info: np.ndarray, criterion: str, allowed: np.ndarray) -> tuple[int, float]:
    """(candidate, gain) of the allowed candidate that adds most; ties go to the lowest index."""
    idx = np.nonzero(allowed)[0]
    if criterion == "E" and len(idx) > E_SCREEN:
        idx = np.sort(idx[_e_screen(info + problem.ridge * np.eye(len(info)), problem.blocks[idx], E_SCREEN)])
    g = gains(problem, info, criterion, idx)
    k = int(np.argmax(g))
    return int(idx[k]), float(g[k])


def greedy(problem: Problem, n: int, criterion: str, fixed: np.ndarray, excluded: np.ndarray | None = None,
           say=lambda msg: None) -> np.ndarray:
    """Add candidates one at a time until the design has n (``fixed`` ones first); the
    design in the order chosen (its prefixes are the greedy designs of fewer poses)."""
    allowed = np.ones(len(problem.blocks), dtype=bool) if excluded is None else ~excluded
    allowed[fixed] = False
    chosen = [int(i) for i in fixed]
    info = problem.information(chosen)
    while len(chosen) < n and allowed.any():
        i, _ = best_gain(problem, info, criterion, allowed)
        say(f"greedy search: pose {len(chosen) + 1} of {n}")
        chosen.append(i)
        allowed[i] = False
        info = info + problem.blocks[i].T @ problem.blocks[i]
    return np.array(chosen, dtype=int)


def exchange(problem: Problem, design: np.ndarray, criterion: str, n_fixed: int, excluded: np.ndarray | None = None,
             rel_tol: float = 1e-6, say=lambda msg: None) -> tuple[np.ndarray, int]:
    """Exchange passes: each free pose of the design is taken out and the best candidate put
    in its place when that beats putting it back. Returns the design and the swaps made."""
    design = design.copy()
    allowed = np.ones(len(problem.blocks), dtype=bool) if excluded is None else ~excluded
    allowed[design] = False
    info = problem.information(design)
    swaps = 0
    for p in range(MAX_EXCHANGE_PASSES):
        say(f"exchange pass {p + 1} ({swaps} swaps so far)")
        swapped = False
        for slot in range(n_fixed, len(design)):
            out = design[slot]
            without = info - problem.blocks[out].T @ problem.blocks[out]
            keep_gain = float(gains(problem, without, criterion, np.array([out]))[0])
            j, gain = best_gain(problem, without, criterion, allowed)
            if gain > keep_gain + rel_tol * max(abs(keep_gain), 1e-12):
                design[slot] = j
                allowed[j], allowed[out] = False, True
                info = without + problem.blocks[j].T @ problem.blocks[j]
                swaps += 1
                swapped = True
        if not swapped:
            break
    return design, swaps


BOUND_ITERATIONS = 1000  # the duality gap is then ~0.3 % of the bound (1,500 candidates, benchmarks/suggest.py)


def i_optimal_bound(problem: Problem, iterations: int = BOUND_ITERATIONS) -> tuple[float, float]:
    """A lower bound on N x trace(W M^-1) for every design of N poses from the candidates
    (no prior): the I-criterion of the best *approximate* design (weights on the
    candidates, Kiefer's relaxation, which contains every exact design), found by the
    multiplicative algorithm, less its duality gap (the equivalence theorem: for
    phi(w) = trace(W M(w)^-1), phi* >= phi(w) - (max_i d_i - phi(w)), d_i = trace(J_i M^-1 W M^-1 J_i^T)).
    Returns (lower bound, value reached); N x expected variance of any N-pose design is >= the bound."""
    if problem.weight is None:
        raise ValueError("i_optimal_bound needs the targets' weight (a region-targeted problem)")
    c, _, k = problem.blocks.shape
    rows = problem.blocks.reshape(-1, k)  # (3C, K): the candidates' equations, 3 each
    w = np.full(c, 1.0 / c)
    for _ in range(iterations):
        d, phi = _i_directional(problem, w, rows)
        w = w * np.sqrt(d / phi)  # sum w_i d_i = phi: the square-root update keeps the weights near the simplex, and converges monotonically
        w /= w.sum()
    d, phi = _i_directional(problem, w, rows)
    return float(phi - (d.max() - phi)), float(phi)


def _i_directional(problem: Problem, w: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, float]:
    """(d_i for every candidate, phi) of the approximate design with weights w."""
    k = rows.shape[1]
    m = (rows * np.repeat(w, 3)[:, None]).T @ rows + problem.ridge * np.eye(k)
    cov = np.linalg.inv(m)
    a = cov @ problem.weight @ cov
    d = ((rows @ a) * rows).sum(axis=1).reshape(-1, 3).sum(axis=1)  # trace(J_i A J_i^T), as matrix products
    return d, float(np.einsum("kl,lk->", problem.weight, cov))


# The capped relaxation (designs of distinct poses): 300 multiplicative steps bring its lower bound
# within 0.2 % of the converged one on the benchmark's 1,500 candidates (seed 0, N = 50 and 100:
# 0.2 % / 0.04 % after 200 steps), about 0.4 s.
RELAX_ITERATIONS = 300


@dataclass(frozen=True)
class Relaxation:
    """The best *fractional* design of distinct poses: x_i in [0, 1] of each candidate, sum x = the
    free poses, on top of the prior and the fixed poses (I-criterion, trace(W M(x)^-1))."""

    x: np.ndarray  # (C,) fraction of each candidate (0 for fixed and excluded ones)
    value: float  # trace(W M(x)^-1), mm^2
    lower_bound: float  # no design of these distinct poses (with the fixed ones) has less mean variance

    def rounded(self, fixed: np.ndarray, n_free: int) -> np.ndarray:
        """The exact design nearest it: the fixed poses, then the n_free candidates of largest x."""
        return np.concatenate([np.asarray(fixed, dtype=int), np.argsort(-self.x, kind="stable")[:n_free]])


def relaxed_i_design(problem: Problem, n_free: int, fixed: np.ndarray | None = None, excluded: np.ndarray | None = None,
                     iterations: int = RELAX_ITERATIONS) -> Relaxation:
    """Minimise trace(W M(x)^-1), M(x) = prior + fixed poses + sum_i x_i J_i^T J_i, over 0 <= x_i <= 1,
    sum x_i = n_free (the convex relaxation of choosing n_free distinct candidates; the prior, e.g.
    the information of poses measured already, and the fixed poses are held fixed, and candidates
    ``excluded`` (e.g. those measured already) get no fraction; Kiefer's
    approximate design with each candidate's weight capped at one pose, so unlike
    ``i_optimal_bound`` it knows that a pose is measured at most once). Multiplicative steps
    x_i <- x_i sqrt(d_i), d_i = trace(J_i M^-1 W M^-1 J_i^T) (minus the gradient), each projected back
    onto the capped simplex. Lower bound from the Frank-Wolfe duality gap: phi is convex in x, and the
    linear minimum over the capped simplex puts 1 on the n_free largest d_i, so
    phi* >= phi(x) - (sum of the n_free largest d_i - sum_i x_i d_i); every exact design is feasible."""
    if problem.weight is None:
        raise ValueError("relaxed_i_design needs the targets' weight (a region-targeted problem)")
    c, _, k = problem.blocks.shape
    fixed = np.zeros(0, dtype=int) if fixed is None else np.asarray(fixed, dtype=int)
    allowed = np.ones(c, dtype=bool) if excluded is None else ~excluded
    allowed[fixed] = False
    idx = np.nonzero(allowed)[0]
    n_free = min(n_free, len(idx))
    base = problem.information(fixed) + problem.ridge * np.eye(k)
    rows = problem.blocks[idx].reshape(-1, k)
    x = np.full(len(idx), n_free / max(len(idx), 1))
    for step in range(iterations + 1):
        cov = np.linalg.inv(base + (rows * np.repeat(x, 3)[:, None]).T @ rows)
        d = ((rows @ (cov @ problem.weight @ cov)) * rows).sum(axis=1).reshape(-1, 3).sum(axis=1)
        if step < iterations and n_free:
            x = _capped_simplex(x * np.sqrt(d), n_free)
    value = float(np.sum(problem.weight * cov))  # W and cov symmetric
    gap = float(np.sort(d)[len(d) - n_free:].sum() - x @ d) if n_free else 0.0
    full = np.zeros(c)
    full[idx] = x
    return Relaxation(full, value, value - max(gap, 0.0))


def _capped_simplex(y: np.ndarray, total: float) -> np.ndarray:
    """lambda y with the entries above 1 set to 1, lambda such that the sum is ``total`` (y >= 0)."""
    capped = np.zeros(len(y), dtype=bool)
    while True:
        scale = (total - capped.sum()) / max(float(y[~capped].sum()), 1e-300)
        now = capped | (scale * y >= 1.0)
        if (now == capped).all():
            return np.where(capped, 1.0, scale * y)
        capped = now


def restarts_for(n: int) -> int:
    """How many perturbed restarts a design of n poses gets (RESTART_POSES / n, rounded down)."""
    return RESTART_POSES // max(n, 1)


def refine(problem: Problem, order: np.ndarray, criterion: str, n_fixed: int, rng: np.random.Generator,
           excluded: np.ndarray | None = None, restarts: int | None = None, say=lambda msg: None) -> tuple[np.ndarray, int]:
    """Exchange from ``order`` (the greedy design), then ``restarts`` times (default
    ``restarts_for(len(order))``): replace PERTURBED_SHARE of the best design's free poses by
    random other candidates, exchange again, keep the result if its criterion is higher.
    Deterministic for a given ``rng``. Returns the best design and how many of the greedy
    design's poses it replaced."""
    best, _ = exchange(problem, order, criterion, n_fixed, excluded, say=say)
    best_value = criterion_value(problem, problem.information(best), criterion)
    allowed = np.ones(len(problem.blocks), dtype=bool) if excluded is None else ~excluded
    free = np.arange(n_fixed, len(best))
    count = restarts_for(len(best)) if restarts is None else restarts
    for r in range(count if len(free) else 0):
        say(f"exchange restart {r + 1} of {count}")
        others = allowed.copy()
        others[best] = False
        k = min(max(1, int(round(PERTURBED_SHARE * len(free)))), int(others.sum()))
        start = best.copy()
        start[rng.choice(free, k, replace=False)] = rng.choice(np.nonzero(others)[0], k, replace=False)
        candidate, _ = exchange(problem, start, criterion, n_fixed, excluded)
        value = criterion_value(problem, problem.information(candidate), criterion)
        if value > best_value:
            best, best_value = candidate, value
    return best, int(np.setdiff1d(best[n_fixed:], order[n_fixed:]).size)
