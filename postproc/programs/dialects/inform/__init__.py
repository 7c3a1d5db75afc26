"""Yaskawa INFORM: a job file (.JBI) of the DX100 / DX200 / YRC1000 controllers."""

from __future__ import annotations

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import YRC
from .form import form_of_joints
from .parse import InformParser
from .pulses import with_pulse_joints
from .writer import InformWriter


class InformDialect(Dialect):
    name = "inform"
    description = "Yaskawa INFORM job (.JBI)"
    controller = YRC
    extensions = (".jbi",)
    comment_pattern = r"'[^\n]*|/[^\n]*"  # comment lines and the /JOB, //NAME, ///... header lines
    motion_words = "MOVJ, MOVL, MOVC or MOVS"
    joint_motion_conf = "///RCONF form"  # MOVJ takes the posture its position's form names (form.py)

    def conf_of_joints(self, robot, q_deg):
        return form_of_joints(robot, q_deg)

    def sniff(self, head: str) -> bool:
        return head.lstrip().startswith("/JOB") and ("//POS" in head or "//INST" in head or "//NAME" in head)

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return InformParser(sources).parse()

    def with_robot(self, tp: Toolpath, robot) -> Toolpath:
        return with_pulse_joints(tp, robot)

    def new_writer(self, name: str):
        return InformWriter(name)


INFORM = InformDialect()
