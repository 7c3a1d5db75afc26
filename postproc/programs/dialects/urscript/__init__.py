"""Universal Robots URScript (.script): the language. What the controller does with a
program (which inverse-kinematics solution it takes, blends) is ``controller.UrController``."""

from __future__ import annotations

import re

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import UR_CONTROLLER
from .parse import UrParser
from .writer import UrWriter

_MOTION_CALL = re.compile(r"\b(?:MOVEJ|MOVEL|MOVEP|MOVEC|SERVOJ)[ \t]*\(")


class UrScriptDialect(Dialect):
    name = "urscript"
    description = "Universal Robots URScript (.script)"
    extensions = (".script", ".urscript")
    comment_pattern = r"#[^\n]*"
    motion_words = "movej, movel, movep, movec or servoj"
    speed_to_mm_per_s = 1000.0  # v= of movel/movep/movec: m/s (movej's rad/s is not kept as a speed)
    controller = UR_CONTROLLER

    def sniff(self, head: str) -> bool:
        """A motion function called with parentheses: no RAPID (MoveL p10, ...) or KRL
        (LIN {...}) statement looks like it."""
        return _MOTION_CALL.search(head) is not None

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return UrParser(sources).parse()

    def new_writer(self, name: str):
        return UrWriter(name)


URSCRIPT = UrScriptDialect()
