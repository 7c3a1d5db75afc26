"""A hidden effect that catalog effects imitate in part: joint 2 gives under gravity only
when it approached from the negative side, delta q2 = c tau2 (1 - s2) / 2 (a reducer
whose stiffness depends on which flank carries the load). Gravity compliance takes the
mean stiffness, backlash the direction times the mean torque; the product of the torque's
variation and the direction is left, a function of two variables together. A
plugin-style effect file: not in the catalog, loaded by tests/hidden_plugins.py.
"""

from __future__ import annotations

import numpy as np

from postproc.model.effects.api import Context, Effect, Param, gravity_torque


class DirectionStiffness(Effect):
    name = "direction_stiffness"
    kind = "joint"
    needs = ("approach",)
    summary = "joint 2 is softer when it approached from the negative side"
    finding = "residuals follow joint 2's gravity torque, in one approach direction only"

    def params(self, robot) -> list[Param]:
        compliance = 1.0 / robot.stiffness_nm_per_rad[1]
        return [Param(f"{self.name}.c2", "rad/(N*m)", compliance, compliance)]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        tau = gravity_torque(robot, ctx.q_deg)[:, 1]
        basis = np.zeros((len(tau), 6, 1))
        basis[:, 1, 0] = np.rad2deg(tau * (1.0 - ctx.approach[:, 1]) / 2.0)
        return basis
