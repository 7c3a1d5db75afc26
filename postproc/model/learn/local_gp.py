"""Local exact-GP experts over workspace regions, blended smoothly: GPR on 10^4-10^5 poses.

Why this method. An exact GP costs O(N^3) time and O(N^2) memory (scikit-learn's gradient
needs ~190 bytes per kernel entry: 27 GB at the 11,911 poses of the UR10's Series A). The
errors a physics model leaves are local in the workspace (seed 001 splits the workspace into
sub-spaces for this reason; reducer and cable effects change with the arm's posture, so one
stationary kernel over the whole workspace is a compromise anyway). So the workspace is cut
into regions and each gets its own exact GP:
- regions: a k-d tree on the TCP position (the first three features, standardised) split
  at the median of the widest axis until a region holds at most ``leaf_size`` poses; the
  outer regions extend to infinity, so every point of space lies in exactly one region;
- each expert is trained on its region's poses plus those within a margin around it
  (``overlap`` times the region's extent per axis), at most ``2 * leaf_size`` poses, so
  memory is bounded by the leaf size, not by N, and time grows linearly with N;
- blending is a partition of unity: an expert's weight is 1 inside its region and falls to
  0 across the margin with a C1 smoothstep (product over the three axes); weights are
  normalised. The prediction is therefore continuous (C1) everywhere — a compensated path
  never jumps at a region border — and uses at most the few experts whose margins overlap;
- predictive variance is that of the mixture: sum w_k (s_k^2 + m_k^2) - m^2;
- hyperparameters: one set shared by a few experts' data together (the sum of their log
  marginal likelihoods; Deisenroth & Ng, "Distributed Gaussian Processes", ICML 2015),
  started from an exact GP (with restarts) on a random subsample of ``global_size`` poses,
  gives the starting point (gp.py, SHARED_EXPERTS, says why not the subsample alone);
  each expert then refines it by marginal likelihood on its own data (a bounded number
  of L-BFGS steps), so each region gets its own length scales and noise (local,
  non-stationary), which is what the dense local data support.
Inducing-point (sparse variational) GPs were the alternative: they keep one global kernel
and smooth away detail finer than the inducing-point spacing, which is exactly the local
structure dense tracker data are measured for; the local experts keep exact-GP accuracy
locally, need no new dependency, and their cost is predictable before the fit starts.
With fewer poses than one leaf holds this is the exact GP itself (one expert, no margin).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from threadpoolctl import threadpool_limits

from .gp_lml import JITTER, optimize_theta, point_noise, with_group_noise

PREDICT_CHUNK = 8192  # query rows per block: bounds the (rows x expert size) kernel blocks


@dataclass(frozen=True)
class Regions:
    """Leaf boxes of the k-d tree in standardised position coordinates (+-inf outside)."""

    lo: np.ndarray  # (K, 3)
    hi: np.ndarray  # (K, 3)
    margin: np.ndarray  # (K, 3), > 0

    def weights(self, P: np.ndarray) -> np.ndarray:
        """(n, K) normalised blending weights of each region's expert at points P (n, 3)."""
        outside = np.maximum(np.maximum(self.lo[None] - P[:, None], P[:, None] - self.hi[None]), 0.0)
        t = np.minimum(outside / self.margin[None], 1.0)
        w = np.prod(1.0 - t * t * (3.0 - 2.0 * t), axis=2)
        return w / w.sum(axis=1, keepdims=True)  # >= 1 before normalising: each point is in a leaf


def split_regions(P: np.ndarray, leaf_size: int, overlap: float) -> tuple[Regions, list[np.ndarray]]:
    """Median k-d tree on P (N, 3) until leaves hold <= leaf_size points; leaf index arrays."""
    n_dim = P.shape[1]
    stack = [(np.arange(len(P)), np.full(n_dim, -np.inf), np.full(n_dim, np.inf))]
    los, his, margins, leaves = [], [], [], []
    floor = 1e-6 * max(float(np.ptp(P, axis=0).max()), 1e-9)
    while stack:
        idx, lo, hi = stack.pop()
        pts = P[idx]
        extent = pts.max(axis=0) - pts.min(axis=0)
        if len(idx) <= leaf_size or extent.max() <= floor:
            los.append(lo), his.append(hi), leaves.append(idx)
            margins.append(np.maximum(overlap * extent, np.maximum(overlap * extent.max(), floor)))
            continue
        axis = int(np.argmax(extent))
        order = np.argsort(pts[:, axis], kind="stable")
        half = len(idx) // 2
        cut = 0.5 * (pts[order[half - 1], axis] + pts[order[half], axis])
        left_hi, right_lo = hi.copy(), lo.copy()
        left_hi[axis] = right_lo[axis] = cut
        stack.append((idx[order[half:]], right_lo, hi))
        stack.append((idx[order[:half]], lo, left_hi))
    return Regions(np.array(los), np.array(his), np.array(margins)), leaves


def expert_members(regions: Regions, leaves: list[np.ndarray], P: np.ndarray, cap: int, rng) -> list[np.ndarray]:
    """Per expert: its leaf's points plus the points in its margin (at most cap in all)."""
    members = []
    for k, leaf in enumerate(leaves):
        inside = np.all((P >= regions.lo[k] - regions.margin[k]) & (P <= regions.hi[k] + regions.margin[k]), axis=1)
        extra = np.setdiff1d(np.nonzero(inside)[0], leaf, assume_unique=False)
        room = max(cap - len(leaf), 0)
        if len(extra) > room:
            extra = np.sort(rng.choice(extra, room, replace=False))
        members.append(np.sort(np.concatenate([leaf, extra])))
    return members


def fit_expert(Xs: np.ndarray, y: np.ndarray, kernel, max_iter: int | None, groups: np.ndarray | None = None,
               theta: np.ndarray | None = None) -> GaussianProcessRegressor:
    """One exact GP on standardised inputs: its kernel refined from ``theta`` (default
    kernel.theta) by at most max_iter L-BFGS steps of the lean marginal likelihood (gp_lml),
    or kept (max_iter None). ``groups``: each pose's noise group, ``theta`` then extended by
    their noise ratios (gp_lml.with_group_noise), held here; a pose's noise beyond the
    kernel's white noise is its ``alpha``. The full theta is kept as ``theta_full_`` (saved
    with the model)."""
    n_kernel = len(kernel.theta)
    theta = kernel.theta if theta is None else np.asarray(theta, dtype=float)
    if max_iter is not None:
        _, bounds = with_group_noise(kernel.theta, kernel.bounds, len(theta) - n_kernel + 1)
        theta = optimize_theta(Xs, y, theta, bounds, max_iter, groups=groups, n_kernel=n_kernel, free=np.arange(len(theta)) < n_kernel)
    alpha = JITTER if groups is None else JITTER + point_noise(theta, n_kernel, groups) - np.exp(theta[n_kernel - 1])
    gpr = GaussianProcessRegressor(kernel=kernel.clone_with_theta(theta[:n_kernel]), alpha=alpha, normalize_y=True, optimizer=None)
    gpr.fit(Xs, y)
    gpr.theta_full_ = theta
    return gpr


def fit_workers() -> int:
    """Experts fitted at once: one per core this process may use, each on one BLAS thread
    (a 1,000-pose expert's factorisations are too small for threaded BLAS to pay: on the
    shared 2-core machine one expert took 2.1 s on one thread and 5.9 s on two)."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def fit_experts(Xs: np.ndarray, y: np.ndarray, members: list[np.ndarray], kernel, max_iter: int | None, workers: int | None = None,
                groups: np.ndarray | None = None, theta: np.ndarray | None = None):
    """Yield the fitted expert of each member set, in order, fitting ``workers`` at a time
    (threads: LAPACK and NumPy release the GIL). Stopping the iteration (Ctrl-C) cancels the
    experts not started; at most ``workers`` are in memory being fitted at once. ``groups``,
    ``theta``: per-pose noise groups and the start theta (``fit_expert``)."""

    workers = workers or fit_workers()

    def submit(pool, idx):
        return pool.submit(fit_expert, Xs[idx], y[idx], kernel, max_iter, None if groups is None else groups[idx], theta)

    with threadpool_limits(limits=1), ThreadPoolExecutor(max_workers=workers) as pool:
        pending = [submit(pool, idx) for idx in members[:workers]]
        try:
            for k in range(len(members)):
                expert = pending[k].result()
                if k + workers < len(members):
                    pending.append(submit(pool, members[k + workers]))
                yield expert
        finally:
            for fut in pending:
                fut.cancel()


def blend_predict(experts, regions: Regions, Xs: np.ndarray, P: np.ndarray, return_std: bool):
    """Partition-of-unity blend of the experts' predictions, in blocks of PREDICT_CHUNK rows."""
    n_out = experts[0].y_train_.shape[1] if experts[0].y_train_.ndim == 2 else 1
    mean = np.zeros((len(Xs), n_out))
    second = np.zeros((len(Xs), n_out))
    for start in range(0, len(Xs), PREDICT_CHUNK):
        rows = slice(start, start + PREDICT_CHUNK)
        w = regions.weights(P[rows])
        for k in np.nonzero((w > 0).any(axis=0))[0]:
            use = np.nonzero(w[:, k] > 0)[0]
            wk = w[use, k][:, None]
            if return_std:
                m, s = experts[k].predict(Xs[rows][use], return_std=True)
                m, s = m.reshape(len(use), -1), s.reshape(len(use), -1)
                second[start + use] += wk * (s * s + m * m)
            else:
                m = experts[k].predict(Xs[rows][use]).reshape(len(use), -1)
            mean[start + use] += wk * m
    if not return_std:
        return mean
    return mean, np.sqrt(np.maximum(second - mean * mean, 0.0))
