"""Gaussian-process regression of position errors (seed 001 eq. 27-32).

Kernel: sigma_f^2 exp(-|x - x'|^2 / (2 l^2)) on standardised inputs, plus white noise
for the measurement variance; the constant mean is the training mean (normalize_y).
Hyperparameters by marginal likelihood (scikit-learn), with seeded restarts.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.preprocessing import StandardScaler


class GPRPredictor(RegressorMixin, BaseEstimator):
    def __init__(self, length_scale: float = 1.0, noise_level: float = 1e-2, n_restarts: int = 2, anisotropic: bool = False, random_state: int = 0):
        self.length_scale = length_scale
        self.noise_level = noise_level
        self.n_restarts = n_restarts
        self.anisotropic = anisotropic
        self.random_state = random_state

    def fit(self, X, y, sample_weight=None):
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        self.scaler_ = StandardScaler().fit(X)
        scale = np.full(X.shape[1], self.length_scale) if self.anisotropic else self.length_scale
        kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(scale, (1e-2, 1e2)) + WhiteKernel(self.noise_level, (1e-6, 1e1))
        alpha = 1e-10 if sample_weight is None else 1e-10 + 1e-3 / np.maximum(np.asarray(sample_weight, dtype=float), 1e-9)
        self.gpr_ = GaussianProcessRegressor(kernel=kernel, alpha=alpha, normalize_y=True, n_restarts_optimizer=self.n_restarts, random_state=self.random_state)
        self.gpr_.fit(self.scaler_.transform(X), y)
        self.n_features_in_ = X.shape[1]
        return self

    def predict(self, X, return_std: bool = False):
        Xs = self.scaler_.transform(np.asarray(X, dtype=float))
        return self.gpr_.predict(Xs, return_std=return_std)
