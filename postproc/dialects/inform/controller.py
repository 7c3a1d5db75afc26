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
        on the way (DX100 operator's manual, "type" of a position: the form is used for joint
        interpolation to a Cartesian position)."""
        return (tp.kind == Kind.JOINT) & ~np.isnan(tp.conf).any(axis=1)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solution with the written form: flip, upper/lower arm, front/back and the
        R, T, S turns (data transmission function manual, ///RCONF; see form.py)."""
        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_form(robot, np.asarray(solutions)[has], conf[has])
        return q, branch


YRC = YaskawaController()
