"""Yaskawa DX100 / DX200 / YRC1000: what the controller does with an INFORM job (which IK
solution it takes, which motions follow the form written with the position)."""

from __future__ import annotations

import numpy as np

from ...controller import Controller
from ...ir import Kind, Toolpath
from .form import select_by_form


class YaskawaController(Controller):
    """The rules of a Yaskawa controller running INFORM jobs. What it shares with the base
    class: a job states no payload (loads are tool-file data, TOOL.CND), PL=1..8 rounds
    corners but keeps linear and circular interpolation, a MOVC circle ends at its third point."""

    name = "Yaskawa DX100 / DX200 / YRC1000"
    maker = "Yaskawa"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """The form (``///RCONF``) of a Cartesian position decides the posture of a joint move
        (MOVJ) to it; MOVL / MOVC interpolate from the current posture and cannot change form
        on the way (NX100 / DX100 operator's manual 3.9 "Manipulator Types": the type selects
        one of the solutions when the robot moves to an XYZ position; a straight or circular
        path is driven from where the robot is)."""
        return (tp.kind == Kind.JOINT) & ~np.isnan(tp.conf).any(axis=1)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solution with the written form: flip, upper/lower arm, front/rear and the
        R, T, S turns (DX100 "Interface with an easy offline teaching system" 4.1 RCONF, NX100
        operator's manual 3.9 "Manipulator Types"; see form.py)."""
        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_form(robot, np.asarray(solutions)[has], conf[has])
        return q, branch


YRC = YaskawaController()
