"""Yaskawa INFORM: a job file (.JBI) of the DX100 / DX200 / YRC1000 controllers."""

from __future__ import annotations

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import CONTROLLER


class InformDialect(Dialect):
    name = "inform"
    description = "Yaskawa INFORM job (.JBI)"
    controller_maker = "Yaskawa"
    extensions = (".jbi",)
    comment_pattern = r"'[^\n]*|/[^\n]*"  # comment lines and the /JOB, //NAME, ///... header lines
    motion_words = "MOVJ, MOVL, MOVC or MOVS"
    controller = CONTROLLER

    def sniff(self, head: str) -> bool:
        return head.lstrip().startswith("/JOB") and ("//POS" in head or "//INST" in head or "//NAME" in head)

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        from .parse import InformParser  # (here, as the other dialects: the parser loads numpy-heavy builders)

        return InformParser(sources).parse()

    # The controller's rules (postproc.dialects.inform.controller), until Dialect takes a controller.
    def conf_applies(self, tp):
        return self.controller.conf_applies(tp)

    def branch_from_conf(self, robot, solutions, conf):
        return self.controller.branch_from_conf(robot, solutions, conf)

    def payloads(self, tp):
        return self.controller.payloads(tp)

    def stated_loads(self, tp):
        return self.controller.stated_loads(tp)

    def inexact_interpolation(self, tp):
        return self.controller.inexact_interpolation(tp)

    def arc_ends_at_target(self, tp):
        return self.controller.arc_ends_at_target(tp)

    def new_writer(self, name: str):
        from .writer import InformWriter

        return InformWriter(name)


INFORM = InformDialect()
