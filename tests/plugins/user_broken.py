"""A test plugin effect that breaks the contract: a wrong analytic derivative, no identifiability text."""

from __future__ import annotations

import numpy as np

from postproc.model.effects.api import Effect, Param


class UserBroken(Effect):
    name = "user_broken"
    kind = "geometry"
    summary = "link 2 grows by a constant (with a wrong derivative, on purpose)"
    finding = "residuals follow the arm's reach"
    identifiability = ""

    def params(self, robot):
        return [Param(f"{self.name}.grow", "mm", 0.1, 0.1, lower=-5.0, upper=5.0)]

    def apply_dh(self, dh, values, data):
        a = dh.a.copy()
        a[:, 1] += values[0]
        return dh.with_channels(a=a)

    def dh_derivatives(self, dh_in, values, data):
        own = np.zeros((6, 1))
        own[1, 0] = 2.0  # wrong: the true derivative is 1
        return {}, {"a": own}
