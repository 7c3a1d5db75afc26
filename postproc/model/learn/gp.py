"""Gaussian-process regression of position errors (seed 001 eq. 27-32).

Kernel: sigma_f^2 exp(-|x - x'|^2 / (2 l^2)) on standardised inputs, plus white noise
for the measurement variance; the constant mean is the training mean (normalize_y).
Hyperparameters by marginal likelihood (scikit-learn), with seeded restarts.

Two methods, chosen by ``method``:
- ``exact``: one GP over all poses. O(N^3) time, O(N^2) memory (about 190 bytes per kernel
  entry while fitting: 1.1 GB at 2,000 poses, 27 GB at 12,000);
- ``local``: exact-GP experts over workspace regions, blended smoothly (local_gp.py says
  why), for 10^4-10^5 poses: memory bounded by the region size, time linear in N;
- ``auto`` (default): exact up to ``exact_max`` poses (2,000: about 0.8 GB and a minute or
  two on 2 cores), local above.
The memory a fit needs is estimated before it starts; a fit that would not fit in the free
memory (or ``memory_limit_gb``) raises MemoryBudgetError naming the method that would.
Predictions are made in blocks, so predicting a 10^6-point program stays bounded too.

``noise_groups`` (fit): each pose's noise group (``postproc.model.noise_model``: its place
after the last large move). The kernel is fitted as without groups; then each group's
noise ratio to the last group's (the settled poses) by the marginal likelihood with the
kernel held, on up to GROUP_SAMPLE poses (gp_lml says why not together); the local experts
refine their kernels with the ratios held. The prediction is the mean, as without.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.preprocessing import StandardScaler
from threadpoolctl import threadpool_limits

from . import local_gp
from .gp_lml import optimize_shared_theta, optimize_theta, with_group_noise
from .memory import GB, check_budget, gp_fit_bytes, lean_fit_bytes

METHODS = ("auto", "exact", "local")
EXACT_MAX = 2000  # auto: the exact GP up to this many poses (about 0.8 GB and 1-2 minutes to fit)
GROUP_SAMPLE = 1500  # poses the noise groups' ratios are fitted on (a few seconds per likelihood on 2 cores)
# The local GP's kernel, the start every expert refines: one set of hyperparameters for
# SHARED_EXPERTS experts' data together (the sum of their log marginal likelihoods, as
# distributed GPs share them: Deisenroth & Ng, ICML 2015), from a fit on ``global_size``
# poses drawn over the whole workspace and from the kernel's defaults. A global subsample
# is sparse where an expert's data are dense: on UR10 Series A's random splits the
# 600-pose fit alone ended in a degenerate kernel (length scales at their lower bound, all
# noise) on two of four splits and depended on its sample by about the spread between
# splits (seed 2: 0.0683 mm held out; 0.0558 with the shared fit).
SHARED_EXPERTS = 4


class GPRPredictor(RegressorMixin, BaseEstimator):
    def __init__(self, length_scale: float = 1.0, noise_level: float = 1e-2, n_restarts: int = 2, anisotropic: bool = False, random_state: int = 0,
                 method: str = "auto", exact_max: int = EXACT_MAX, leaf_size: int = 500, overlap: float = 0.15, global_size: int = 600,
                 expert_iter: int | None = 15, memory_limit_gb: float | None = None, shared_experts: int = SHARED_EXPERTS):
        self.length_scale = length_scale
        self.noise_level = noise_level
        self.n_restarts = n_restarts
        self.anisotropic = anisotropic
        self.random_state = random_state
        self.method = method
        self.exact_max = exact_max
        self.leaf_size = leaf_size
        self.overlap = overlap
        self.global_size = global_size
        self.expert_iter = expert_iter
        self.memory_limit_gb = memory_limit_gb
        self.shared_experts = shared_experts

    def _kernel(self, n_features: int):
        scale = np.full(n_features, self.length_scale) if self.anisotropic else self.length_scale
        return ConstantKernel(1.0, (1e-3, 1e3)) * RBF(scale, (1e-2, 1e2)) + WhiteKernel(self.noise_level, (1e-6, 1e1))

    @staticmethod
    def _alpha(sample_weight):
        # A sample weight w scales that sample's noise by 1/w (how a GP takes weights).
        return 1e-10 if sample_weight is None else 1e-10 + 1e-3 / np.maximum(np.asarray(sample_weight, dtype=float), 1e-9)

    def resolved_method(self, n_points: int) -> str:
        if self.method not in METHODS:
            raise ValueError(f"GPR method '{self.method}' is not one of {', '.join(METHODS)}")
        if self.method == "auto":
            return "exact" if n_points <= self.exact_max else "local"
        return self.method

    def fit_memory_bytes(self, n_points: int, n_features: int) -> int:
        """Peak memory of fitting on n_points, by the method that would be used."""
        if self.resolved_method(n_points) == "exact":
            return gp_fit_bytes(n_points, n_features, self.anisotropic)
        largest = max(min(n_points, 2 * self.leaf_size), min(n_points, self.global_size))
        return lean_fit_bytes(largest) * local_gp.fit_workers() + 64 * n_points * (n_features + 3)

    def _check_memory(self, n_points: int, n_features: int) -> str:
        method = self.resolved_method(n_points)
        need = self.fit_memory_bytes(n_points, n_features)
        if method == "exact":
            local = GPRPredictor(**{**self.get_params(), "method": "local"}).fit_memory_bytes(n_points, n_features)
            alternative = f"the local-experts GP would need about {local / GB:.1f} GB (--gp-method local)"
        else:
            alternative = f"a smaller leaf size would need less (--gp-leaf-size {max(self.leaf_size // 2, 50)})"
        check_budget(need, f"gpr ({method}) on {n_points} poses x {n_features} features", self.memory_limit_gb, alternative)
        return method

    def fit(self, X, y, sample_weight=None, progress=None, noise_groups=None):
        """progress(done, total, message): called between stages (local: once per expert);
        noise_groups (N,) ints 0..G-1: one noise level per group, G - 1 the kernel's."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        groups = None if noise_groups is None else np.asarray(noise_groups, dtype=np.int64)
        if groups is not None and sample_weight is not None:
            raise ValueError("give sample weights or noise groups, not both")
        self.method_ = self._check_memory(len(X), X.shape[1])
        if self.method_ == "local":
            if sample_weight is not None:
                raise ValueError("the local-experts GP takes no sample weights (use method='exact')")
            return self._fit_local(X, y, progress, groups)
        if groups is not None:
            return self._fit_exact_groups(X, y, progress, groups)
        self.scaler_ = StandardScaler().fit(X)
        self.gpr_ = GaussianProcessRegressor(kernel=self._kernel(X.shape[1]), alpha=self._alpha(sample_weight), normalize_y=True,
                                             n_restarts_optimizer=self.n_restarts, random_state=self.random_state)
        if progress is not None:
            progress(0, 1, f"exact GP on {len(X)} poses")
        with warnings.catch_warnings():
            # A length scale at its bound (a residual that is only noise) is a valid answer.
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.gpr_.fit(self.scaler_.transform(X), y)
        self._keep(X, y, sample_weight)
        return self

    def _fit_exact_groups(self, X, y, progress, groups):
        """The exact GP with a noise level per group, by the lean marginal likelihood."""
        self.scaler_ = StandardScaler().fit(X)
        Xs = self.scaler_.transform(X)
        if progress is not None:
            progress(0, 1, f"exact GP on {len(X)} poses, {int(groups.max()) + 1} noise groups")
        kernel = self._kernel(X.shape[1])
        rng = np.random.default_rng(self.random_state)
        theta = optimize_theta(Xs, y, kernel.theta, kernel.bounds, None, self.n_restarts, rng)
        theta = self._group_ratios(Xs, y, kernel, theta, groups, rng)
        self.gpr_ = local_gp.fit_expert(Xs, y, kernel, None, groups, theta)
        self._keep(X, y, None, groups)
        return self

    @staticmethod
    def _group_ratios(Xs, y, kernel, theta, groups, rng):
        """theta extended by the groups' noise ratios, fitted with the kernel held (its white
        noise free too) on up to GROUP_SAMPLE poses."""
        full, bounds = with_group_noise(theta, kernel.bounds, int(groups.max()) + 1)
        sub = np.sort(rng.choice(len(Xs), min(len(Xs), GROUP_SAMPLE), replace=False))
        free = np.arange(len(full)) >= len(kernel.theta) - 1
        return optimize_theta(Xs[sub], y[sub], full, bounds, None, 0, rng, groups[sub], len(kernel.theta), free)

    def _keep(self, X, y, sample_weight, groups=None):
        self.X_train_, self.y_train_ = X, y
        self.weights_ = None if sample_weight is None else np.asarray(sample_weight, dtype=float)
        self.noise_groups_ = groups
        self.n_features_in_ = X.shape[1]

    # ------------------------------------------------------------------ local experts
    def _region_coords(self, X):
        return (X[:, :3] - self.region_center_) / self.region_scale_

    def _partition(self, X):
        self.scaler_ = StandardScaler().fit(X)
        self.region_center_ = X[:, :3].mean(axis=0)
        self.region_scale_ = float(X[:, :3].std(axis=0).max()) or 1.0
        P = self._region_coords(X)
        regions, leaves = local_gp.split_regions(P, self.leaf_size, self.overlap)
        rng = np.random.default_rng(self.random_state)
        return regions, local_gp.expert_members(regions, leaves, P, 2 * self.leaf_size, rng)

    def _fit_local(self, X, y, progress, groups=None):
        regions, members = self._partition(X)
        Xs = self.scaler_.transform(X)
        rng = np.random.default_rng(self.random_state)
        total = len(members) + 1
        kernel = self._kernel(X.shape[1])
        start = self._shared_theta(Xs, y, members, kernel, rng, lambda message: progress is not None and progress(0, total, message))
        if groups is not None:
            start = self._group_ratios(Xs, y, kernel, start, groups, rng)
        experts = []
        for k, expert in enumerate(local_gp.fit_experts(Xs, y, members, kernel, self.expert_iter, groups=groups, theta=start)):
            experts.append(expert)
            if progress is not None:
                progress(k + 1, total, f"expert {k + 1} of {len(members)} ({len(members[k])} poses)")
        self._set_local(regions, members, experts)
        self._keep(X, y, None, groups)
        return self

    def _shared_theta(self, Xs, y, members, kernel, rng, say) -> np.ndarray:
        """The experts' start: the hyperparameters of ``shared_experts`` experts' data together
        (see SHARED_EXPERTS), from the global subsample's fit and from the kernel's defaults,
        the better likelihood kept; with ``shared_experts`` 0, the global subsample's fit.
        Records the experts used as ``shared_experts_`` and the subsample's size as
        ``global_poses_``."""
        size = min(len(Xs), self.global_size)
        sub = np.sort(rng.choice(len(Xs), size, replace=False))
        say(f"global hyperparameters on {size} of {len(Xs)} poses")
        theta = optimize_theta(Xs[sub], y[sub], kernel.theta, kernel.bounds, None, self.n_restarts, rng)
        self.global_poses_ = size
        self.shared_experts_ = np.sort(rng.choice(len(members), min(self.shared_experts, len(members)), replace=False))
        if len(self.shared_experts_) == 0:
            return theta
        blocks = [(Xs[members[k]], y[members[k]]) for k in self.shared_experts_]
        say(f"shared hyperparameters on {len(blocks)} experts' {sum(len(b[0]) for b in blocks)} poses")
        with threadpool_limits(limits=1):  # blocks of about 1,000 poses: threaded BLAS does not pay (local_gp.fit_workers)
            shared, _ = optimize_shared_theta(blocks, [theta, kernel.theta], kernel.bounds, local_gp.fit_workers())
        return shared

    def _set_local(self, regions, members, experts):
        self.regions_, self.members_, self.experts_ = regions, members, experts

    def restore_local(self, X, y, regions, members, thetas, center, scale, groups=None):
        """The local-experts GP with every expert's kernel fixed (restoring a saved model);
        ``groups``: the poses' noise groups, each theta then extended by their levels."""
        self.method_ = "local"
        self.scaler_ = StandardScaler().fit(X)
        self.region_center_, self.region_scale_ = np.asarray(center, dtype=float), float(scale)
        Xs = self.scaler_.transform(X)
        kernel = self._kernel(X.shape[1])
        experts = [local_gp.fit_expert(Xs[idx], y[idx], kernel, None, None if groups is None else groups[idx], np.asarray(th, dtype=float))
                   for idx, th in zip(members, thetas)]
        self._set_local(regions, members, experts)
        self._keep(X, y, None, groups)
        return self

    # ------------------------------------------------------------------ exact, restored
    def fit_fixed(self, X, y, theta, sample_weight=None, groups=None):
        """The exact GP with its kernel hyperparameters fixed (restoring a saved model);
        ``groups``: the poses' noise groups, theta then extended by their levels."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        self.method_ = "exact"
        self.scaler_ = StandardScaler().fit(X)
        if groups is not None:
            self.gpr_ = local_gp.fit_expert(self.scaler_.transform(X), y, self._kernel(X.shape[1]), None, groups, np.asarray(theta, dtype=float))
            self._keep(X, y, None, groups)
            return self
        kernel = self._kernel(X.shape[1]).clone_with_theta(np.asarray(theta, dtype=float))
        self.gpr_ = GaussianProcessRegressor(kernel=kernel, alpha=self._alpha(sample_weight), normalize_y=True, optimizer=None)
        self.gpr_.fit(self.scaler_.transform(X), y)
        self._keep(X, y, sample_weight)
        return self

    def predict(self, X, return_std: bool = False):
        X = np.asarray(X, dtype=float)
        Xs = self.scaler_.transform(X)
        if getattr(self, "method_", "exact") == "local":
            return local_gp.blend_predict(self.experts_, self.regions_, Xs, self._region_coords(X), return_std)
        parts = [self.gpr_.predict(Xs[i : i + local_gp.PREDICT_CHUNK], return_std=return_std) for i in range(0, max(len(Xs), 1), local_gp.PREDICT_CHUNK)]
        if not return_std:
            return np.concatenate(parts)
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
