"""KUKA KRC4 / KRC5 (KSS 8): what the controller does with a KRL program."""

from __future__ import annotations

import re

import numpy as np

from postproc.robot.kinematics import select_by_kuka_status

from ...controller import Controller
from ...ir import Kind, Toolpath
from .loads import load_masses, stated_loads

_CIRCULAR_ANGLE = re.compile(r"\bCA\b", re.IGNORECASE)


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
        return stated_loads(tp)

    def payloads(self, tp: Toolpath):
        """Masses the program gives $LOAD ($LOAD.M = m, $LOAD = {M m, ...}, $LOAD = LOAD_DATA[n]
        with LOAD_DATA[n] in $config.dat, or BAS(#TOOL, n), which loads LOAD_DATA[n])."""
        return load_masses(tp)

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        """A CIRC with CA (circular angle) runs on past or stops short of its end point."""
        ends = np.ones(len(tp.kind), dtype=bool)
        arcs = np.nonzero(tp.kind == Kind.CIRC_END)[0]  # only arcs' lines are read (a long program has few)
        if arcs.size:
            lines = [doc.text.split("\n") for doc in tp.sources]
            ends[arcs] = [not _CIRCULAR_ANGLE.search(lines[f][n - 1]) if 0 < n <= len(lines[f]) else True
                          for f, n in zip(tp.file[arcs].tolist(), tp.line[arcs].tolist())]
        return ends


KRC = KukaController()
