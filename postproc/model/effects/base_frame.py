"""Transform from the robot base to the measurement frame (6 DOF).

measured = R p + t with R = Rot(r) R0, t = t0 + dt, where (R0, t0) is a closed-form
point-set registration (Kabsch/Umeyama) done before the fit when the data are far from
the robot base frame, e.g. in a laser tracker's own frame.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.frames import kabsch, rotvec_to_matrix  # noqa: F401  (kabsch: re-exported for callers of this module)

from .base import Effect, Param

_DEG = np.pi / 180.0


class BaseFrame(Effect):
    name = "base_frame"
    kind = "base"
    first_step = True
    summary = "where the robot stands in the measurement frame: a rigid shift and small rotation (6 parameters)"
    finding = "residuals follow a rigid shift and tilt of the whole workspace"
    identifiability = (
        "Kept before the DH errors it duplicates: a base rotation about z absorbs geometric.dtheta1, a shift "
        "along z absorbs geometric.dd1; those DH errors are then fixed at zero."
    )

    def params(self, robot) -> list[Param]:
        trans = [Param(f"{self.name}.t{axis}", "mm", 0.1, 0.5) for axis in "xyz"]
        rots = [Param(f"{self.name}.r{axis}", "deg", 0.01, typ) for axis, typ in zip("xyz", (0.01, 0.02, 0.01))]
        return trans + rots

    def keep_priority(self, param_name: str) -> tuple:
        return (0, param_name)

    def transform(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) of this effect's parameters, to be composed as R @ R0, t0 + t."""
        return rotvec_to_matrix(values[3:6]), np.asarray(values[:3], dtype=float)

    def base_jacobian(self, rotated: np.ndarray, values: np.ndarray) -> np.ndarray:
        jac = np.zeros((len(rotated), 3, 6))
        for k in range(3):
            unit = np.zeros(3)
            unit[k] = 1.0
            jac[:, :, k] = unit
            # A small rotation about axis k turns v = R p by (e_k x v).
            jac[:, :, 3 + k] = np.cross(unit, rotated) * _DEG
        return jac
