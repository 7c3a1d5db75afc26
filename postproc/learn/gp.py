"""Gaussian-process regression of position errors (seed 001 eq. 27-32).

Kernel: sigma_f^2 exp(-|x - x'|^2 / (2 l^2)) on standardised inputs, plus white noise
for the measurement variance; the constant mean is the training mean (normalize_y).
Hyperparameters by marginal likelihood (scikit-learn), with seeded restarts.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.exceptions import ConvergenceWarning
from sklearn.preprocessing import StandardScaler


class GPRPredictor(RegressorMixin, BaseEstimator):
    def __init__(self, length_scale: float = 1.0, noise_level: float = 1e-2, n_restarts: int = 2, anisotropic: bool = False, random_state: int = 0):
        self.length_scale = length_scale
        self.noise_level = noise_level
        self.n_restarts = n_restarts
        self.anisotropic = anisotropic
        self.random_state = random_state

    def _kernel(self, n_features: int):
        scale = np.full(n_features, self.length_scale) if self.anisotropic else self.length_scale
        return ConstantKernel(1.0, (1e-3, 1e3)) * RBF(scale, (1e-2, 1e2)) + WhiteKernel(self.noise_level, (1e-6, 1e1))

    @staticmethod
    def _alpha(sample_weight):
        # A sample weight w scales that sample's noise by 1/w (how a GP takes weights).
        return 1e-10 if sample_weight is None else 1e-10 + 1e-3 / np.maximum(np.asarray(sample_weight, dtype=float), 1e-9)

    def fit(self, X, y, sample_weight=None):
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        self.scaler_ = StandardScaler().fit(X)
        self.gpr_ = GaussianProcessRegressor(kernel=self._kernel(X.shape[1]), alpha=self._alpha(sample_weight), normalize_y=True,
                                             n_restarts_optimizer=self.n_restarts, random_state=self.random_state)
        with warnings.catch_warnings():
            # A length scale at its bound (a residual that is only noise) is a valid answer.
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.gpr_.fit(self.scaler_.transform(X), y)
        self.X_train_, self.y_train_ = X, y
        self.weights_ = None if sample_weight is None else np.asarray(sample_weight, dtype=float)
        self.n_features_in_ = X.shape[1]
        return self

    def fit_fixed(self, X, y, theta, sample_weight=None):
        """The same GP with its kernel hyperparameters fixed (restoring a saved model)."""
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
        self.scaler_ = StandardScaler().fit(X)
        kernel = self._kernel(X.shape[1]).clone_with_theta(np.asarray(theta, dtype=float))
        self.gpr_ = GaussianProcessRegressor(kernel=kernel, alpha=self._alpha(sample_weight), normalize_y=True, optimizer=None)
        self.gpr_.fit(self.scaler_.transform(X), y)
        self.X_train_, self.y_train_ = X, y
        self.weights_ = None if sample_weight is None else np.asarray(sample_weight, dtype=float)
        self.n_features_in_ = X.shape[1]
        return self

    def predict(self, X, return_std: bool = False):
        Xs = self.scaler_.transform(np.asarray(X, dtype=float))
        return self.gpr_.predict(Xs, return_std=return_std)
