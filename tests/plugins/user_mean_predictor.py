"""A test plugin predictor (NOT built in): the residual's mean, plus a plane in x, y, z.

Loaded by ``--plugins``, ``POSTPROC_PLUGINS`` or the ``postproc.predictors`` entry point,
used as ``fit --predictor user_plane``.
"""

from __future__ import annotations

import numpy as np

from postproc.model.effects.api import PluginPredictor


class UserPlane(PluginPredictor):
    name = "user_plane"
    features = "position"  # x, y, z mm of the nominal measured point

    def fit(self, X, y):
        A = np.hstack([np.ones((len(X), 1)), np.asarray(X, dtype=float) / 1000.0])
        self.coef_ = np.linalg.lstsq(A, np.asarray(y, dtype=float), rcond=None)[0]  # (4, 3)
        return self

    def predict(self, X):
        A = np.hstack([np.ones((len(X), 1)), np.asarray(X, dtype=float) / 1000.0])
        return A @ self.coef_

    def to_state(self) -> dict:
        return {"coef": self.coef_.tolist()}

    @classmethod
    def from_state(cls, state: dict) -> "UserPlane":
        est = cls()
        est.coef_ = np.asarray(state["coef"], dtype=float)
        return est
