"""Fanuc TP: the ASCII listing (.ls) of a teach pendant program; its controller's rules
are in ``controller.py`` (the R-30iB's)."""

from __future__ import annotations

import numpy as np

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import CONTROLLER, fanuc_config


class FanucDialect(Dialect):
    name = "fanuc"
    description = "Fanuc TP program, ASCII listing (.ls: /PROG, /MN, /POS)"
    controller_maker = "Fanuc"
    extensions = (".ls",)
    comment_pattern = r"/(?:PROG|ATTR|APPL)[^\n]*|[ \t]*\d+:[ \t]*(?:!|//)[^\n]*"
    motion_words = "J, L, C or A motions"
    controller = CONTROLLER

    def sniff(self, head: str) -> bool:
        return "/PROG" in head and ("/MN" in head or "/ATTR" in head)

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        from .parse import parse_ls  # (here, as the other languages: the parser loads only when a program is read)

        return parse_ls(sources)

    # The controller's rules (controller.py).
    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        return self.controller.conf_applies(tp)

    def branch_from_conf(self, robot, solutions, conf):
        return self.controller.branch_from_conf(robot, solutions, conf)

    def payloads(self, tp: Toolpath):
        return self.controller.payloads(tp)

    def stated_loads(self, tp: Toolpath):
        return self.controller.stated_loads(tp)

    def inexact_interpolation(self, tp: Toolpath):
        return self.controller.inexact_interpolation(tp)

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        return self.controller.arc_ends_at_target(tp)

    arm_conf_column = 0  # the arm code (flip, up, front); columns 1-3 are turn numbers

    def conf_of_joints(self, robot, q_deg):
        return fanuc_config(robot, q_deg)

    def new_writer(self, name: str):
        from .writer import FanucWriter

        return FanucWriter(name)


FANUC = FanucDialect()
