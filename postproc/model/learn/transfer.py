"""Transfer-learned GPR (seed 001 §2) and the region-similarity measure (eq. 9-10).

A source region measured densely and a target region measured sparsely. The target is
split into k sub-spaces by base angle theta1. For each sub-space j:
- feature alignment (eq. 11-12): the source poses turned about the base z axis by the
  sub-space's angle (shifted by the mean offset only with ``shift=True``: a shift moves
  the arm, the turn is the arm's one symmetry), T_j;
- the physics of that turn: errors of the arm (joints 2-6, compliance, reducers) turn
  with joint 1, while a base-frame tilt omega and shift t add ((I - Rz) omega) x p +
  (I - Rz) t; their four horizontal components are fitted once over all sub-spaces, and
  source errors are carried over as Rz y + that term;
- label alignment (eq. 13-14): a 3x3 map H_j (ridge regression towards the identity,
  weighted by the measurement precision, the ridge chosen by leave-one-out error) from
  the source model's carried-over errors at the target poses to the measured ones;
- the source set transferred as (T_j x, H_j y) and merged with the target data (eq. 15-17).
TrAdaBoost.R2 (eq. 19-24) then reweights: target samples by the weighted fitting error
relative to the largest target error, source samples that fit badly lose weight; the
GPR base learners are combined by their weighted median (eq. 25). The kernel is fitted
once and then kept, so every boosting round is one factorisation.
eq. 26: the source-region GPR is kept and predicts poses inside the source region's base
angle range (``keep_source``, on by default).

``variant="paper"`` runs seed 001's eq. 11-25 as published instead (``transfer_paper``:
T_j with its shift, a (3 + 3 + 1) x 3 H_j per sub-space weighted by omega_m, the paper's
weight update); on the Table 7 design it is 1.35-2.8x GPR-378 where this default is 0.75-1.26x
(README, "Seed 001 as published").
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin

from . import transfer_paper
from .gp import GPRPredictor
from .state import base_estimator_from_state, estimator_state


def region_similarity(errors_a: np.ndarray, errors_b: np.ndarray) -> float:
    """Mean cosine similarity of min-max normalised error vectors of two regions (eq. 9-10).

    The two sets hold the same number of samples taken in corresponding order; 1 means the
    error patterns are alike (seed 001 Table 4: >= 0.94 for transferable regions)."""
    a = np.asarray(errors_a, dtype=float)
    b = np.asarray(errors_b, dtype=float)
    n = min(len(a), len(b))
    a, b = a[:n], b[:n]

    def norm(e):
        lo, hi = e.min(axis=0), e.max(axis=0)
        return (e - lo) / np.where(hi > lo, hi - lo, 1.0)

    na, nb = norm(a), norm(b)
    dots = np.sum(na * nb, axis=1)
    lengths = np.linalg.norm(na, axis=1) * np.linalg.norm(nb, axis=1)
    return float(np.mean(np.where(lengths > 0, dots / np.where(lengths > 0, lengths, 1.0), 1.0)))


def _theta1(X):
    return np.degrees(np.arctan2(X[:, 1], X[:, 0]))


def _rotate(X, theta_deg, offset):
    """Pose features (x, y, z, A, B, C) turned about base z by theta and shifted."""
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    out = np.array(X, dtype=float, copy=True)
    out[:, 0] = c * X[:, 0] - s * X[:, 1] + offset[0]
    out[:, 1] = s * X[:, 0] + c * X[:, 1] + offset[1]
    out[:, 2] = X[:, 2] + offset[2]
    if X.shape[1] >= 4:
        out[:, 3] = (X[:, 3] + theta_deg + 180.0) % 360.0 - 180.0  # A: the turn about z
    return out


RIDGE_GRID = 10.0 ** np.arange(0, 13)


def _label_map(f_src: np.ndarray, y: np.ndarray, precision: float, ridge: float | None) -> tuple[np.ndarray, float]:
    """H minimising precision * |y - f_src H|^2 + ridge * |H - I|^2 (eq. 13-14), and the ridge.

    ``ridge=None`` picks it from RIDGE_GRID by leave-one-out error over the sub-space's
    target points (closed form): 16 points and a source model that is itself uncertain
    rarely support a map far from the identity."""
    resid = y - f_src  # what H - I has to explain
    gram = precision * f_src.T @ f_src
    best = None
    for lam in RIDGE_GRID if ridge is None else [ridge]:
        inv = np.linalg.inv(gram + lam * np.eye(3))
        d = inv @ (precision * f_src.T @ resid)
        lever = precision * np.einsum("ij,jk,ik->i", f_src, inv, f_src)
        loo = (resid - f_src @ d) / np.maximum(1.0 - lever, 1e-9)[:, None]
        score = float(np.sum(loo**2))
        if best is None or score <= best[0]:  # ties go to the stronger prior
            best = (score, lam, d)
    return np.eye(3) + best[2], float(best[1])


def _rz(theta_deg: float) -> np.ndarray:
    t = np.radians(theta_deg)
    return np.array([[np.cos(t), -np.sin(t), 0.0], [np.sin(t), np.cos(t), 0.0], [0.0, 0.0, 1.0]])


def _turn_design(rz: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """(3N, 4): d/d(omega_x, omega_y, t_x, t_y) of ((I - Rz) omega) x p + (I - Rz) t, omega in rad, p in mm."""
    m = (np.eye(3) - rz)[:, :2]  # (3, 2)
    p = positions
    # (m w) x p = -[p]x (m w)
    skew = np.zeros((len(p), 3, 3))
    skew[:, 0, 1], skew[:, 0, 2] = -p[:, 2], p[:, 1]
    skew[:, 1, 0], skew[:, 1, 2] = p[:, 2], -p[:, 0]
    skew[:, 2, 0], skew[:, 2, 1] = -p[:, 1], p[:, 0]
    tilt = -skew @ m  # (N, 3, 2)
    shift = np.broadcast_to(m, (len(p), 3, 2))
    return np.concatenate([tilt, shift], axis=2).reshape(-1, 4)


def _weighted_median(preds: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Per sample and output, the weighted median over learners: preds (L, N, 3)."""
    order = np.argsort(preds, axis=0)
    sorted_preds = np.take_along_axis(preds, order, axis=0)
    w = weights[order]
    cum = np.cumsum(w, axis=0)
    idx = np.argmax(cum >= 0.5 * cum[-1], axis=0)
    return np.take_along_axis(sorted_preds, idx[None], axis=0)[0]


class TrGPRPredictor(RegressorMixin, BaseEstimator):
    """variant: "physics" (default: the turn's physics carries the labels, see the module
    docstring) or "paper" (seed 001 eq. 11-25 as published, ``transfer_paper``).
    keep_source: eq. 26, the source-region GPR predicts poses inside the source region's
    base-angle range, the transfer model the rest."""

    def __init__(self, n_subspaces: int = 5, n_iter: int = 10, ridge: float | None = None, noise_mm: float = 0.02, shift: bool = False,
                 random_state: int = 0, variant: str = "physics", keep_source: bool = True):
        self.n_subspaces = n_subspaces
        self.shift = shift
        self.n_iter = n_iter
        self.ridge = ridge
        self.noise_mm = noise_mm
        self.random_state = random_state
        self.variant = variant
        self.keep_source = keep_source

    def fit(self, X, y, X_source=None, y_source=None):
        """X, y: target poses and errors (few); X_source, y_source: the source region's (many)."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        if X_source is None or y_source is None:
            raise ValueError("tr-gpr needs source-domain data (X_source, y_source)")
        if self.variant not in ("physics", "paper"):
            raise ValueError(f"tr-gpr variant '{self.variant}' is not one of physics, paper")
        Xs = np.asarray(X_source, dtype=float)
        ys = np.asarray(y_source, dtype=float)
        source_model = GPRPredictor(random_state=self.random_state).fit(Xs, ys)
        if self.variant == "paper":

            sigma = np.full(3, self.noise_mm)
            X_all, y_all, is_target, self.alignments_ = transfer_paper.align(X, y, Xs, ys, source_model, self.n_subspaces, sigma)
            self.learners_, self.learner_weights_ = transfer_paper.boost(X_all, y_all, is_target, sigma, self.n_iter, self.random_state)
        else:
            X_all, y_all, is_target, self.alignments_ = self._align(X, y, Xs, ys, source_model)
            self.learners_, self.learner_weights_ = self._boost(X_all, y_all, is_target)
        self.source_model_ = source_model if self.keep_source else None
        self.source_theta_ = (float(_theta1(Xs).min()), float(_theta1(Xs).max()))
        self.n_features_in_ = X.shape[1]
        return self

    def _align(self, X, y, Xs, ys, source_model):
        """Sub-space alignment by the turn's physics; the merged training set (eq. 15-17)."""
        order = np.argsort(_theta1(X))
        groups = np.array_split(order, self.n_subspaces)
        precision = 1.0 / self.noise_mm**2  # the tracker's precision weights the label fit
        # Feature alignment (eq. 11-12): each sub-space's turn about base z and offset.
        turns, offsets, backs = [], [], []
        for g in groups:
            theta = float(np.mean(_theta1(X[g])) - np.mean(_theta1(Xs)))
            # The offset of eq. 11-12 is the difference of the regions' mean positions. Only
            # the turn about base z is a symmetry of the arm: shifting a pose moves the arm
            # and its error does not follow, and with regions sampled alike the offset of 16
            # poses is mostly sampling noise (tens of mm). So it is applied only on request.
            offset = X[g, :3].mean(axis=0) - _rotate(Xs, theta, np.zeros(3))[:, :3].mean(axis=0) if self.shift else np.zeros(3)
            turns.append(theta)
            offsets.append(offset)
            backs.append(source_model.predict(_rotate(_rotate(X[g], 0.0, -offset), -theta, np.zeros(3))))
        # Physics of the turn: errors of the arm turn with joint 1; a base-frame tilt omega
        # and shift t do not, and add ((I - Rz) omega) x p + (I - Rz) t. Their four
        # horizontal components are fitted once over every sub-space.
        rows_a, rows_b = [], []
        for g, theta, f_src in zip(groups, turns, backs):
            rz = _rz(theta)
            rows_a.append(_turn_design(rz, X[g, :3]))
            rows_b.append((y[g] - f_src @ rz.T).reshape(-1))
        frame = np.linalg.lstsq(np.vstack(rows_a), np.concatenate(rows_b), rcond=None)[0]  # 240 equations for 4 unknowns
        parts_X, parts_y, alignments = [], [], []
        for g, theta, offset, f_src, design_g in zip(groups, turns, offsets, backs, rows_a):
            rz = _rz(theta)
            moved = _rotate(Xs, theta, offset)
            turned_src = f_src @ rz.T + (design_g @ frame).reshape(-1, 3)
            # Label alignment (eq. 13-14): what the turn leaves, a 3x3 map pulled towards the identity.
            h, ridge = _label_map(turned_src, y[g], precision, self.ridge)
            labels = ys @ rz.T + (_turn_design(rz, moved[:, :3]) @ frame).reshape(-1, 3)
            parts_X.append(moved)
            parts_y.append(labels @ h)
            alignments.append({"theta_deg": theta, "offset_mm": offset.tolist(), "H": h.tolist(), "ridge": ridge})
        n_src = sum(len(p) for p in parts_X)
        return np.vstack(parts_X + [X]), np.vstack(parts_y + [y]), np.r_[np.zeros(n_src, bool), np.ones(len(X), bool)], alignments

    def _boost(self, X_all, y_all, is_target):
        """TrAdaBoost.R2 with a fixed kernel: target samples that fit badly gain weight, bad
        source samples lose it (Pardoe & Stone); learners weighted ln(1/beta)."""
        weights = np.full(len(X_all), 1.0 / len(X_all))  # eq. 19 with no overlapping sub-spaces
        n_src = int((~is_target).sum())
        beta_src = 1.0 / (1.0 + np.sqrt(2.0 * np.log(max(n_src, 2)) / max(self.n_iter, 1)))
        first = GPRPredictor(random_state=self.random_state).fit(X_all, y_all, sample_weight=weights * len(X_all))
        theta_kernel = first.gpr_.kernel_.theta
        learners, betas = [], []
        for _ in range(self.n_iter):
            learner = GPRPredictor(random_state=self.random_state).fit_fixed(X_all, y_all, theta_kernel, sample_weight=weights * len(X_all))
            err = np.linalg.norm(learner.predict(X_all) - y_all, axis=1)
            e = err / max(err[is_target].max(), 1e-12)  # eq. 20-21
            eps = float(np.sum(e[is_target] * weights[is_target]) / np.sum(weights[is_target]))  # eq. 22
            if eps >= 0.5:
                break
            beta_t = max(eps, 1e-6) / (1.0 - eps)
            learners.append(learner)
            betas.append(beta_t)
            weights = np.where(is_target, weights * beta_t ** (-(e)), weights * beta_src**e)
            weights /= weights.sum()
        if not learners:
            learners, betas = [first], [0.5]
        return learners, np.log(1.0 / np.asarray(betas))  # eq. 24-25

    def predict(self, X):
        X = np.asarray(X, dtype=float)
        out = _weighted_median(np.stack([m.predict(X) for m in self.learners_]), self.learner_weights_)
        if getattr(self, "source_model_", None) is not None:
            # eq. 26: inside the source region the source model, measured densely there, predicts.
            theta = _theta1(X)
            inside = (theta >= self.source_theta_[0]) & (theta <= self.source_theta_[1])
            if inside.any():
                out[inside] = self.source_model_.predict(X[inside])
        return out

    def to_state(self) -> dict:
        source = None if getattr(self, "source_model_", None) is None else estimator_state(self.source_model_)
        return {"type": "tr-gpr", "params": self.get_params(), "learners": [estimator_state(m) for m in self.learners_],
                "learner_weights": self.learner_weights_.tolist(), "source": source, "source_theta_deg": list(getattr(self, "source_theta_", (0.0, 0.0)))}

    @classmethod
    def from_state(cls, state: dict) -> "TrGPRPredictor":
        est = cls(**state["params"])
        est.learners_ = [base_estimator_from_state(s) for s in state["learners"]]
        est.learner_weights_ = np.asarray(state["learner_weights"], dtype=float)
        est.source_model_ = None if state.get("source") is None else base_estimator_from_state(state["source"])
        est.source_theta_ = tuple(state.get("source_theta_deg", (0.0, 0.0)))
        est.n_features_in_ = est.learners_[0].n_features_in_
        return est
