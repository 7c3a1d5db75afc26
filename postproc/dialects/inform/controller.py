"""What a Yaskawa DX100 / YRC1000 controller does with an INFORM job: which IK solution
it takes, which motions follow the form written with the position."""

from __future__ import annotations

import numpy as np

from ...ir import Kind, Toolpath


class InformController:
    """The rules of a Yaskawa controller running INFORM jobs (DX100, DX200, YRC1000)."""

    maker = "Yaskawa"
    name = "Yaskawa DX100/DX200/YRC1000"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """The form (``///RCONF``) of a Cartesian position decides the posture of a joint move
        (MOVJ) to it; MOVL / MOVC interpolate from the current posture and cannot change form
        on the way (DX100 operator's manual, "Type" of a position: the form is used for joint
        interpolation to a Cartesian position)."""
        return (tp.kind == Kind.JOINT) & ~np.isnan(tp.conf).any(axis=1)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solution with the written form: flip, upper/lower arm, front/back and the
        R, T, S turns (data transmission function manual, ///RCONF; see form.py)."""
        from .form import select_by_form  # needs the kinematics (numba kernels): loaded when compensating

        q, branch = np.full((len(conf), 6), np.nan), np.full(len(conf), -1)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_form(robot, np.asarray(solutions)[has], conf[has])
        return q, branch

    def payloads(self, tp: Toolpath) -> list[tuple[float, str]]:
        """The job states no payload: loads are tool-file data in the controller (TOOL.CND)."""
        return []

    def stated_loads(self, tp: Toolpath):
        return None

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """PL=1..8 rounds corners but keeps linear and circular interpolation between targets."""
        return None

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        """A MOVC circle ends at its third point (INFORM manual, MOVC)."""
        return np.ones(len(tp.kind), dtype=bool)


CONTROLLER = InformController()
