"""Joint deflection under an external force at the TCP: delta q = C J^T F (columns fx, fy, fz).

Shares the compliances c_i with ``joint_compliance``. At compensation time the force is
the process force given with ``--force fx,fy,fz`` (tool frame, N).
"""

from __future__ import annotations

import numpy as np

from .base import Context, Effect, Param
from .joint_compliance import COMPLIANCE_IDENTIFIABILITY, compliance_params, diagonal_basis, draw_compliance, identified_compliance


class ExternalLoad(Effect):
    name = "external_load"
    kind = "joint"
    needs = ("force",)
    consumes = ("force",)
    summary = "the joints give under a force at the tool (process or probing force): deflection = J^T F / stiffness"
    finding = "residuals grow with the load at the TCP"
    identifiability = COMPLIANCE_IDENTIFIABILITY + " With varied forces every loaded joint's compliance separates."

    def joint_compliance(self, values):
        return identified_compliance(values)

    def params(self, robot) -> list[Param]:
        return compliance_params(robot)

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        return diagonal_basis(ctx.force_torque)

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        return draw_compliance(param, rng)
