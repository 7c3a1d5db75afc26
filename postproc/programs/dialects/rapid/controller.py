"""ABB IRC5 / OmniCore: what the controller does with a RAPID program (RAPID reference manual)."""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError
from postproc.robot.kinematics import select_by_abb_conf

from ...controller import Controller
from ...ir import Kind, Toolpath
from .facts import CONF_REFUSED, CONFJ_OFF, CONFL_OFF, SINGAREA
from .loads import payloads, stated_loads


class AbbController(Controller):
    name = "ABB IRC5 / OmniCore"
    maker = "ABB"

    def branch_from_conf(self, robot, solutions, conf):
        """confdata cf1, cf4, cf6, cfx pick the branch (RAPID reference, 'confdata')."""
        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_abb_conf(robot, solutions[has], conf[has].astype(int))
        return q, branch

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """MoveJ follows its confdata unless ConfJ\\Off is in force; MoveL/MoveC unless
        ConfL\\Off is (RAPID reference, 'ConfJ', 'ConfL': with \\Off the robot takes the
        configuration nearest the current one). The switch in force at each target is the
        parser's (``Toolpath.extras``, postproc.programs.dialects.rapid.facts: in the order of the
        program's execution from main); where the program gives no single state, refused."""
        refused = next((why for why in tp.extras[CONF_REFUSED] if why), None) if len(tp) else None
        if refused:
            raise InputError(refused)
        has = ~np.isnan(tp.conf).any(axis=1)
        joint = tp.kind == Kind.JOINT
        return has & np.where(joint, ~tp.extras[CONFJ_OFF], ~tp.extras[CONFL_OFF])

    def stated_loads(self, tp: Toolpath):
        """tooldata's tload and GripLoad at each target, from the parser's facts (``rapid.loads``)."""
        return stated_loads(tp)

    def payloads(self, tp: Toolpath):
        """The load (tload mass) of every tooldata the program's Cartesian targets use, and its
        GripLoad / \\TLoad payloads, from the parser's facts (``rapid.loads``)."""
        return payloads(tp)

    def inexact_interpolation(self, tp):
        """The first ``SingArea \\Wrist`` / ``\\LockAxis4`` (``extras["rapid.singarea"]``): from there
        MoveL/MoveC may move the wrist off the programmed orientation between targets (RAPID
        technical reference, SingArea), so a predicted path between targets would not be the robot's."""
        where = tp.extras[SINGAREA][0] if len(tp) else ""
        if not where:
            return None
        return (f"{where}: between targets the controller may turn the wrist off the "
                "programmed orientation (RAPID technical reference, SingArea), so the path between compensated targets cannot be "
                "predicted; use SingArea \\Off for a program compensated along its path")


IRC5 = AbbController()
