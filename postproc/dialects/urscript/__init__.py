"""Universal Robots URScript (.script): the language. What the controller does with a
program (which inverse-kinematics solution it takes, blends) is ``controller.UrController``."""

from __future__ import annotations

import re

import numpy as np

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import UrController
from .parse import UrParser
from .writer import UrWriter

_MOTION_CALL = re.compile(r"\b(?:MOVEJ|MOVEL|MOVEP|MOVEC|SERVOJ)[ \t]*\(")


class UrScriptDialect(Dialect):
    name = "urscript"
    description = "Universal Robots URScript (.script)"
    controller_maker = "Universal Robots"
    extensions = (".script", ".urscript")
    comment_pattern = r"#[^\n]*"
    motion_words = "movej, movel, movep, movec or servoj"
    speed_to_mm_per_s = 1000.0  # v= of movel/movep/movec: m/s (movej's rad/s is not kept as a speed)
    controller = UrController()

    def sniff(self, head: str) -> bool:
        """A motion function called with parentheses: no RAPID (MoveL p10, ...) or KRL
        (LIN {...}) statement looks like it."""
        return _MOTION_CALL.search(head) is not None

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return UrParser(sources).parse()

    # The controller's rules (until postproc.controller.Controller is on main, the Dialect
    # methods compensation calls delegate to the controller object).
    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        return self.controller.conf_applies(tp)

    def branch_from_conf(self, robot, solutions, conf):
        return self.controller.branch_from_conf(robot, solutions, conf)

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        return self.controller.inexact_interpolation(tp)

    def payloads(self, tp: Toolpath):
        return self.controller.payloads(tp)

    def stated_loads(self, tp: Toolpath):
        return self.controller.stated_loads(tp)

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        return self.controller.arc_ends_at_target(tp)

    def new_writer(self, name: str):
        return UrWriter(name)


URSCRIPT = UrScriptDialect()
