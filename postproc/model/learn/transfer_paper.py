"""Seed 001's transfer learning as published (§2.1-2.2, eq. 11-26): ``TrGPRPredictor(variant="paper")``.

What is implemented, with the sizes of the paper (k sub-spaces, n source and m target poses):

- eq. 11-12, T_j: a turn theta_1j about base z and a shift (eps_x, eps_y, eps_z), fitted by
  least squares. *Reading*: eq. 12 needs pairs of corresponding source and target
  coordinates; the paper's sampling rule 1 (§2.4) makes source and target sub-space map one
  to one, and for two regions sampled alike that least-squares fit of eq. 11's form is the
  turn between the regions' mean base angles and the shift between their centroids after
  the turn. That is what is fitted (target poses here are not drawn in pairs).
- eq. 13-14, H_j: D_j = (X T_j, Y_sd,td,j, L) -> Y_td,j, a (3 + 3 + 1) x 3 map per sub-space:
  the 3 transformed position coordinates (T_j is 4x4 on homogeneous positions; its
  homogeneous 1 is the column L, kept once), the 3 source errors at the corresponding
  poses, and L. *Readings*: (a) Y_sd,td,j, the source errors at the poses that map onto
  the target poses, are the source-region predictor f_sd (eq. 26, a GPR on the source
  data) at T_j^-1 x, since no source pose was measured exactly there; (b) the weight
  omega_m = diag(eps_p / sigma_p) per axis, zero where the error does not exceed the
  tracker error by the threshold (taken as one more sigma); it multiplies the residual,
  so rows enter squared; (c) the ridge lambda (no value given) is chosen by
  leave-one-out error, on centred, unit-scaled columns with L not penalised: eq. 14's
  lambda I is not scale invariant (positions in metres of mm, errors in tenths of mm).
- eq. 15-17: the source set transferred to every sub-space, (X_sd T_j, (X_sd T_j, Y_sd, L) H_j),
  merged with the m target poses: kn + m samples.
- eq. 19: initial weights 1/(kn + m) (no overlapping sub-spaces).
- eq. 20-23: e_i = |omega_m (y_i - G(x_i))| / E_t, E_t the largest over the target samples;
  eps_t = the target samples' weighted mean of e; stop when eps_t > 0.5; target weights
  times beta_t^(1 - e_i), beta_t = eps_t / (1 - eps_t). *Reading*: eq. 22 sums e_i w_i over
  the target samples with the weights of all kn + m samples, which is at most m/(kn + m)
  (0.11 in Table 7's design) so the stop rule could never act; it is taken with the target
  weights normalised, as in TrAdaBoost.R2 (Pardoe & Stone 2010, the paper's ref. 19).
- eq. 24: every transferred source sample weighs ln(1/beta_t). *Reading*: as an absolute
  weight against target weights that sum to about one it would bury the target data; it
  is taken as a factor on the initial weight 1/(kn + m): the source counts more while the
  boosted model fits the target well (small beta_t), less as eps_t nears 0.5. Then all
  weights are normalised (Z_t).
- eq. 25: f_td, read as the weighted median of the rounds' predictions G_l(x) with weights
  ln(1/beta_l) (AdaBoost.R2): the formula as printed, a sum of ln(1/beta_l) times a median
  of beta_l G_l(x), does not keep the scale of an error in mm.
- eq. 26: f_sd (the source GPR) is kept for the source region; the caller applies it.
"""

from __future__ import annotations

import numpy as np

from .gp import GPRPredictor

RIDGE_GRID = 10.0 ** np.arange(-6, 5)


def theta1(X: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(X[:, 1], X[:, 0]))


def turn(X: np.ndarray, theta_deg: float, shift: np.ndarray) -> np.ndarray:
    """T_j applied to pose features (x, y, z, A, B, C): positions turned about base z by
    theta, then shifted; the orientation's A (about z) turns with them."""
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    out = np.array(X, dtype=float, copy=True)
    out[:, 0] = c * X[:, 0] - s * X[:, 1] + shift[0]
    out[:, 1] = s * X[:, 0] + c * X[:, 1] + shift[1]
    out[:, 2] = X[:, 2] + shift[2]
    if X.shape[1] >= 4:
        out[:, 3] = (X[:, 3] + theta_deg + 180.0) % 360.0 - 180.0
    return out


def unturn(X: np.ndarray, theta_deg: float, shift: np.ndarray) -> np.ndarray:
    """T_j^-1: the source-region pose that maps onto each target pose."""
    return turn(turn(X, 0.0, -np.asarray(shift)), -theta_deg, np.zeros(3))


def fit_turn(X_target: np.ndarray, X_source: np.ndarray) -> tuple[float, np.ndarray]:
    """eq. 11-12 for regions sampled alike: the turn between mean base angles, the shift
    between centroids after the turn."""
    theta = float(np.mean(theta1(X_target)) - np.mean(theta1(X_source)))
    shift = X_target[:, :3].mean(axis=0) - turn(X_source, theta, np.zeros(3))[:, :3].mean(axis=0)
    return theta, shift


def measurement_weights(errors: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """omega_m of eq. 13, per sample and axis: |error| / sigma, zero unless the error
    exceeds the tracker error by the threshold (one more sigma)."""
    mag = np.abs(errors)
    return np.where(mag - sigma > sigma, mag / sigma, 0.0)


def label_map(design: np.ndarray, y: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, float]:
    """H_j of eq. 13-14: weighted ridge regression of y (m, 3) on design (m, 7) = (X T, Y_src, L),
    lambda by leave-one-out error over RIDGE_GRID on centred, scaled columns (L not penalised).
    Returns H (7, 3) in the original columns, and lambda."""
    body = design[:, :-1]
    mean, scale = body.mean(axis=0), np.maximum(body.std(axis=0), 1e-12)
    z = np.column_stack([(body - mean) / scale, np.ones(len(design))])
    penalty = np.eye(z.shape[1])
    penalty[-1, -1] = 0.0
    best = None
    for lam in RIDGE_GRID:
        coef = np.zeros((z.shape[1], 3))
        score = 0.0
        for c in range(3):
            w2 = weights[:, c] ** 2
            inv = np.linalg.pinv(z.T @ (z * w2[:, None]) + lam * penalty)
            coef[:, c] = inv @ (z.T @ (w2 * y[:, c]))
            lever = w2 * np.einsum("ij,jk,ik->i", z, inv, z)
            loo = (y[:, c] - z @ coef[:, c]) / np.maximum(1.0 - lever, 1e-9)
            score += float(np.sum(w2 * loo**2))
        if best is None or score < best[0]:
            best = (score, lam, coef)
    coef = best[2]
    h = np.vstack([coef[:-1] / scale[:, None], coef[-1:] - (mean / scale) @ coef[:-1]])
    return h, float(best[1])


def align(X, y, Xs, ys, source_model, n_subspaces: int, sigma: np.ndarray):
    """eq. 11-17: the k sub-spaces' transferred source sets merged with the target data.
    Returns X_all, y_all, is_target and the alignments (theta, shift, H, lambda) per sub-space."""
    groups = np.array_split(np.argsort(theta1(X)), n_subspaces)
    parts_X, parts_y, alignments = [], [], []
    for g in groups:
        theta, shift = fit_turn(X[g], Xs)
        y_src = source_model.predict(unturn(X[g], theta, shift))  # Y_sd,td,j
        design = np.column_stack([X[g, :3], y_src, np.ones(len(g))])  # (X_sd,td,j T_j, Y_sd,td,j, L)
        h, lam = label_map(design, y[g], measurement_weights(y[g], sigma))
        moved = turn(Xs, theta, shift)  # eq. 15
        parts_X.append(moved)
        parts_y.append(np.column_stack([moved[:, :3], ys, np.ones(len(Xs))]) @ h)
        alignments.append({"theta_deg": theta, "offset_mm": shift.tolist(), "H": h.tolist(), "ridge": lam})
    n_src = sum(len(p) for p in parts_X)
    return np.vstack(parts_X + [X]), np.vstack(parts_y + [y]), np.r_[np.zeros(n_src, bool), np.ones(len(X), bool)], alignments


def boost(X_all, y_all, is_target, sigma, n_iter: int, random_state: int):
    """eq. 19-25 (TrAdaBoost.R2 as the paper writes it): the rounds' GPRs and their weights ln(1/beta)."""
    n = len(X_all)
    weights = np.full(n, 1.0 / n)  # eq. 19
    first = GPRPredictor(random_state=random_state).fit(X_all, y_all, sample_weight=weights * n)
    kernel = first.gpr_.kernel_.theta
    omega = measurement_weights(y_all, sigma)
    learners, betas = [], []
    for _ in range(n_iter):
        learner = GPRPredictor(random_state=random_state).fit_fixed(X_all, y_all, kernel, sample_weight=weights * n)
        wres = np.linalg.norm(omega * (y_all - learner.predict(X_all)), axis=1)
        e = np.minimum(wres / max(wres[is_target].max(), 1e-12), 1.0)  # eq. 20-21
        eps = float(np.sum(e[is_target] * weights[is_target]) / np.sum(weights[is_target]))  # eq. 22
        if eps > 0.5:
            break
        beta = max(eps, 1e-6) / (1.0 - eps)
        learners.append(learner)
        betas.append(beta)
        weights = np.where(is_target, weights * beta ** (1.0 - e), np.log(1.0 / beta) / n)  # eq. 23-24
        weights /= weights.sum()
    if not learners:
        learners, betas = [first], [0.5]
    return learners, np.log(1.0 / np.asarray(betas))
