"""Marginal likelihood of the GP kernel C * RBF(l_1..l_d) + White and its gradient, lean.

scikit-learn's gradient builds the (N, N, n_theta) kernel-gradient tensor and its
product/sum temporaries (about 190 bytes per kernel entry, 0.8 s per evaluation at 1,000
poses on a loaded 2-core machine). For this one kernel every gradient entry reduces to
sums over one (N, N) matrix S = W * K_f (W = alpha alpha^T - m K^-1, K_f the signal part):
d/dlog l_d = 1/(2 l_d^2) sum_ij S_ij (x_id - x_jd)^2 = (r . x_d^2 - x_d . S x_d) / l_d^2
with r the row sums of S. A few (N, N) matrices, O(N^3 + N^2 d) per evaluation. The
hyperparameters found are then handed to scikit-learn's regressor (optimizer=None) for
prediction, so the model is the same object as the exact GP's.
theta is scikit-learn's: log [C, l_1..l_d (or one l), noise], with the kernel's bounds.

Noise groups (``groups``, (N,) ints 0..G-1; ``postproc.model.noise_model``): group g's
noise is the kernel's white noise times a ratio r_g, r_{G-1} = 1 (the settled poses); the
log ratios of groups 0..G-2 are appended to theta (``with_group_noise``). With c_i =
1/2 noise_i (|alpha_i|^2 - m (K^-1)_ii), the gradient of the log noise is sum_i c_i and of
log r_g the sum of c_i over group g. Fitting the ratios together with the length scales
falls into a degenerate optimum on Series A (length scales of the travel inputs at their
lower bound: the signal turned into per-pose noise, the kernel's noise near zero), so the
ratios are fitted with the kernel held (``free``), and the kernel with the ratios held.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize
from scipy.spatial.distance import cdist

JITTER = 1e-10  # scikit-learn's default alpha
#: a noise group's variance ratio to the settled poses' stays within these bounds
RATIO_BOUNDS = (0.25, 100.0)


def with_group_noise(theta: np.ndarray, bounds: np.ndarray, n_groups: int) -> tuple[np.ndarray, np.ndarray]:
    """theta and bounds extended by the log noise ratios of groups 0..n_groups-2 (start 1)."""
    extra = n_groups - 1
    return np.r_[theta, np.zeros(extra)], np.vstack([bounds, np.tile(np.log(RATIO_BOUNDS), (extra, 1))])


def point_noise(theta: np.ndarray, n_kernel: int, groups: np.ndarray | None) -> np.ndarray | float:
    """Each pose's noise variance (normalised units) under an extended theta; the kernel's
    noise where there are no groups."""
    base = float(np.exp(theta[n_kernel - 1]))
    if groups is None:
        return base
    return base * np.exp(np.r_[theta[n_kernel:], 0.0])[groups]  # groups 0..G-2, then the settled (ratio 1)


def neg_log_marginal_likelihood(theta: np.ndarray, X: np.ndarray, Y: np.ndarray, groups: np.ndarray | None = None,
                                n_kernel: int | None = None) -> tuple[float, np.ndarray]:
    """-log p(Y | X, theta) summed over Y's columns (already normalised), and its gradient.
    ``groups``: each pose's noise group, theta then extended (``with_group_noise``) past
    its first ``n_kernel`` entries."""
    n_kernel = len(theta) if n_kernel is None else n_kernel
    c = np.exp(theta[0])
    noise = point_noise(theta, n_kernel, groups)
    scales = np.exp(theta[1 : n_kernel - 1])
    Xl = X / scales  # one length scale broadcasts too
    Kf = c * np.exp(-0.5 * cdist(Xl, Xl, "sqeuclidean"))
    K = Kf.copy()
    K[np.diag_indices_from(K)] += noise + JITTER  # a scalar, or one per pose
    try:
        factor = cho_factor(K, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return 1e25, np.zeros_like(theta)
    alpha = cho_solve(factor, Y, check_finite=False)
    m = Y.shape[1]
    nll = 0.5 * float(np.sum(Y * alpha)) + m * float(np.sum(np.log(np.diag(factor[0])))) + 0.5 * m * len(X) * np.log(2 * np.pi)
    W = cho_solve(factor, np.eye(len(X)), check_finite=False)  # K^-1, then W in place
    diag_w = np.sum(alpha * alpha, axis=1) - m * np.diag(W)  # per pose: what its noise's gradient sums
    W *= -m
    W += alpha @ alpha.T
    S = W * Kf
    del W
    r = S.sum(axis=1)
    grad = np.empty_like(theta)
    grad[0] = 0.5 * S.sum()
    per_dim = (r @ (Xl * Xl)) - np.einsum("id,id->d", Xl, S @ Xl)
    grad[1 : n_kernel - 1] = per_dim if n_kernel - 2 == X.shape[1] else per_dim.sum()
    grad[n_kernel - 1] = 0.5 * float(np.sum(noise * diag_w))
    if groups is not None:
        grad[n_kernel:] = 0.5 * np.bincount(groups, weights=noise * diag_w, minlength=len(theta) - n_kernel + 1)[:-1]
    return nll, -grad


def normalised(Y: np.ndarray) -> np.ndarray:
    """Y with each column at mean 0 and standard deviation 1 (a constant column left at 0), as
    scikit-learn's normalize_y does before the likelihood."""
    return (Y - Y.mean(axis=0)) / np.where(Y.std(axis=0) > 0, Y.std(axis=0), 1.0)


def optimize_theta(X: np.ndarray, Y: np.ndarray, theta0: np.ndarray, bounds: np.ndarray, max_iter: int | None, n_restarts: int = 0, rng=None,
                   groups: np.ndarray | None = None, n_kernel: int | None = None, free: np.ndarray | None = None) -> np.ndarray:
    """Best theta by L-BFGS-B from theta0 and n_restarts further starts (``groups``,
    ``n_kernel``: per-group noise, theta0 and bounds extended by ``with_group_noise``;
    ``free``: the entries fitted, the others held at theta0's values).

    Restarts draw each log-hyperparameter uniformly within a quarter of its bounds' log range either side
    around theta0 clipped to the bounds: starts at the bounds' extremes (length scales of
    0.01 standard deviations) fall into the degenerate all-noise optimum."""
    Yn = normalised(Y)
    options = {} if max_iter is None else {"maxiter": max_iter}
    full = np.asarray(theta0, dtype=float)
    free = np.ones(len(full), dtype=bool) if free is None else np.asarray(free, dtype=bool)

    def objective(x):
        theta = full.copy()
        theta[free] = x
        value, grad = neg_log_marginal_likelihood(theta, X, Yn, groups, n_kernel)
        return value, grad[free]

    bounds = np.asarray(bounds, dtype=float)[free]
    starts = [full[free]]
    for _ in range(n_restarts):
        half = 0.25 * (bounds[:, 1] - bounds[:, 0])
        starts.append(np.clip(rng.uniform(starts[0] - half, starts[0] + half), bounds[:, 0], bounds[:, 1]))
    best = None
    for start in starts:
        res = minimize(objective, start, method="L-BFGS-B", jac=True, bounds=bounds, options=options)
        if best is None or res.fun < best.fun:
            best = res
    out = full.copy()
    out[free] = best.x
    return out


def optimize_shared_theta(blocks: list[tuple[np.ndarray, np.ndarray]], starts: list[np.ndarray], bounds: np.ndarray,
                          workers: int = 1) -> tuple[np.ndarray, float]:
    """One theta for several independent data sets (``blocks``: (X, Y) each, Y normalised per
    block as the experts' normalize_y does): the sum of their negative log marginal
    likelihoods minimised by L-BFGS-B from each start; the best theta and its value.
    This is how distributed GP experts share hyperparameters (Deisenroth & Ng, "Distributed
    Gaussian Processes", ICML 2015): each block is dense local data, as an expert sees it.
    ``workers``: blocks evaluated at once (threads; LAPACK releases the GIL)."""
    standard = [(X, normalised(Y)) for X, Y in blocks]

    def objective(theta, pool):
        parts = list(pool.map(lambda block: neg_log_marginal_likelihood(theta, *block), standard))
        return sum(value for value, _ in parts), np.sum([grad for _, grad in parts], axis=0)

    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        results = [minimize(objective, np.asarray(start, dtype=float), args=(pool,), method="L-BFGS-B", jac=True, bounds=bounds) for start in starts]
    best = min(results, key=lambda res: res.fun)
    return best.x, float(best.fun)
