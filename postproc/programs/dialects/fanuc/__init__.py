"""Fanuc TP: the ASCII listing (.ls) of a teach pendant program; its controller's rules
are in ``controller.py`` (the R-30iB's)."""

from __future__ import annotations

from pathlib import Path

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .calls import called_programs
from .controller import R30IB, fanuc_config
from .parse import parse_ls
from .writer import FanucWriter


class FanucDialect(Dialect):
    name = "fanuc"
    description = "Fanuc TP program, ASCII listing (.ls: /PROG, /MN, /POS)"
    extensions = (".ls",)
    comment_pattern = r"/(?:PROG|ATTR|APPL)[^\n]*|[ \t]*\d+:[ \t]*(?:!|//)[^\n]*"
    motion_words = "J, L, C or A motions"
    controller = R30IB  # the rules compensation asks (controller.py)

    def sniff(self, head: str) -> bool:
        return "/PROG" in head and ("/MN" in head or "/ATTR" in head)

    def read_sources(self, path: str | Path, data: bytes | None = None) -> list[SourceDoc]:
        """The program and the programs of its folder it calls (calls.py); read from standard
        input, the program alone."""
        docs = super().read_sources(path, data)
        return docs if data is not None else docs + called_programs(Path(path), docs[0].text)

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return parse_ls(sources)

    arm_conf_column = 0  # the arm code (flip, up, front); columns 1-3 are turn numbers
    joint_motion_conf = "CONFIG"  # a J motion takes the position's CONFIG (controller.py)

    def conf_of_joints(self, robot, q_deg):
        return fanuc_config(robot, q_deg)

    def new_writer(self, name: str):
        return FanucWriter(name)


FANUC = FanucDialect()
