"""A hidden effect that depends on two variables together: joint 3's zero moves with
joint 4's angle and its own, delta q3 = c sin(q4) sin(q3 - q3c) (the wrist's cable dress
pulling on the elbow, say). Neither angle explains it alone and no catalog effect has the
product. (A product of joint 2's and joint 3's angles would not do: over a joint box the
reducer harmonics of joints 2 and 3 together imitate most of it.) A plugin-style effect
file: not in the catalog, loaded by tests/hidden_plugins.py.
"""

from __future__ import annotations

import numpy as np

from postproc.model.effects.api import Context, Effect, Param


class JointCoupling(Effect):
    name = "joint_coupling"
    kind = "joint"
    summary = "joint 3's zero moves with the product of joint 3's and joint 4's angles"
    finding = "residuals follow joint 3's and joint 4's angles together"
    #: joint 3's angle (deg) about which the coupling is odd (the middle of its range)
    centre_deg = 90.0

    def params(self, robot) -> list[Param]:
        return [Param(f"{self.name}.c", "deg", 0.01, 0.05)]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        q = np.deg2rad(ctx.q_deg)
        basis = np.zeros((len(q), 6, 1))
        basis[:, 2, 0] = np.sin(q[:, 3]) * np.sin(q[:, 2] - np.deg2rad(self.centre_deg))
        return basis
