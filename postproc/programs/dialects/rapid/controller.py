"""ABB IRC5 / OmniCore: what the controller does with a RAPID program (RAPID reference manual)."""

from __future__ import annotations

import re

import numpy as np

from postproc.robot.kinematics import select_by_abb_conf

from ...controller import Controller
from ...ir import Kind, Toolpath
from .confswitch import switch_states
from .loads import stated_loads
from .singarea import wrist_singularity_avoidance
from .targets import tool_masses


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
        configuration nearest the current one). The switches are taken in the order of the
        program's execution from main (postproc.programs.dialects.rapid.confswitch: routines in the
        order they are called; a motion reached both ways is an error)."""
        has = ~np.isnan(tp.conf).any(axis=1)
        states = switch_states(tp, {"CONFL": _switch_state(tp, "CONFL"), "CONFJ": _switch_state(tp, "CONFJ")})
        lin_off, joint_off = states["CONFL"], states["CONFJ"]
        joint = tp.kind == Kind.JOINT
        return has & np.where(joint, ~joint_off, ~lin_off)

    def stated_loads(self, tp: Toolpath):
        return stated_loads(tp)

    def payloads(self, tp: Toolpath):
        """The load (tload mass) of every tooldata the program's Cartesian targets use."""
        return tool_masses(tp)

    def inexact_interpolation(self, tp):
        """The first ``SingArea \\Wrist`` / ``\\LockAxis4``: from there MoveL/MoveC may move the wrist
        off the programmed orientation between targets (RAPID technical reference, SingArea)."""
        return wrist_singularity_avoidance(tp)


def _switch_state(tp: Toolpath, switch: str) -> np.ndarray:
    """(N,) True where the last ``ConfL``/``ConfJ`` instruction before the target's line in
    its own module's text was ``\\Off``."""
    pattern = re.compile(rf"^[ \t]*{switch}[ \t]*\\(ON|OFF)[ \t]*;", re.IGNORECASE | re.MULTILINE)
    off_now = np.zeros(len(tp.line), dtype=bool)
    for f, doc in enumerate(tp.sources):
        events = [(doc.text.count("\n", 0, m.start()) + 1, m.group(1).upper() == "OFF") for m in pattern.finditer(doc.text)]
        mine = tp.file == f
        if not events or not mine.any():
            continue
        lines = np.array([line for line, _ in events])
        off = np.array([state for _, state in events])
        last = np.searchsorted(lines, tp.line[mine], side="right") - 1
        off_now[mine] = np.where(last >= 0, off[np.maximum(last, 0)], False)
    return off_now


IRC5 = AbbController()
