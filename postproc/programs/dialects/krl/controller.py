"""KUKA KRC4 / KRC5 (KSS 8): what the controller does with a KRL program."""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import select_by_kuka_status

from ...controller import Controller
from ...ir import Kind, Toolpath
from .facts import CIRCULAR_ANGLE
from .loads import load_masses, stated_loads


class KukaController(Controller):
    name = "KUKA KRC4 / KRC5 (KSS 8)"
    maker = "KUKA"

    def branch_from_conf(self, robot, solutions, conf):
        """KSS: a target's Status and Turn pick the branch (KUKA System Software 8, 'S and T')."""
        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf[:, :2]).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_kuka_status(robot, solutions[has], conf[has, 0].astype(int), conf[has, 1].astype(int))
        return q, branch

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """S and T count for PTP motions only; LIN, CIRC (and KSS 8 SLIN/SCIRC) ignore them
        and keep the current posture (KUKA System Software 8.x operating and programming
        manual, 'Status and Turn')."""
        return (tp.kind == Kind.JOINT) & ~np.isnan(tp.conf[:, :2]).any(axis=1)

    def stated_loads(self, tp: Toolpath):
        """The $LOAD in force at each target, from the parser's facts (``krl.loads``, ``krl.load``)."""
        return stated_loads(tp)

    def payloads(self, tp: Toolpath):
        """Masses the program gives $LOAD ($LOAD.M = m, $LOAD = {M m, ...}, $LOAD = LOAD_DATA[n]
        with LOAD_DATA[n] in $config.dat, or BAS(#TOOL, n), which loads LOAD_DATA[n]), from
        the parser's facts (``krl.loads``)."""
        return load_masses(tp)

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        """A CIRC with CA (circular angle, ``extras["krl.circular_angle"]``) runs on past or
        stops short of its end point."""
        return ~tp.extras[CIRCULAR_ANGLE]


KRC = KukaController()
