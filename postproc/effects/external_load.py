"""Joint deflection under an external force at the TCP: delta q = C J^T F (columns fx, fy, fz).

Shares the compliances c_i with ``joint_compliance``.
"""

from __future__ import annotations

import numpy as np

from .base import Context, Effect, Param
from .joint_compliance import compliance_params


class ExternalLoad(Effect):
    name = "external_load"
    kind = "joint"
    needs = ("force",)

    def params(self, robot) -> list[Param]:
        return compliance_params(robot)

    def joint_basis(self, ctx: Context, robot) -> np.ndarray:
        basis = np.zeros((ctx.q_deg.shape[0], 6, 6))
        idx = np.arange(6)
        basis[:, idx, idx] = np.rad2deg(ctx.force_torque)
        return basis
