"""ABB RAPID modules (.mod, .modx, .prg, .sys)."""

from __future__ import annotations

import re

import numpy as np

from ...ir import SourceDoc, Toolpath
from ..base import Dialect


class RapidDialect(Dialect):
    name = "rapid"
    description = "ABB RAPID module"
    extensions = (".mod", ".modx", ".prg", ".sys")

    def sniff(self, head: str) -> bool:
        return "MODULE " in head and ("ENDMODULE" in head or "PROC " in head)

    def parse_sources(self, sources: list[SourceDoc]) -> Toolpath:
        from .parse import RapidParser

        return RapidParser(sources[0]).parse()

    def branch_from_conf(self, robot, solutions, conf):
        """confdata cf1, cf4, cf6, cfx pick the branch (RAPID reference, 'confdata')."""
        from ...kinematics import select_by_abb_conf

        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_abb_conf(robot, solutions[has], conf[has].astype(int))
        return q, branch

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """MoveJ follows its confdata unless ConfJ\\Off is in force; MoveL/MoveC unless
        ConfL\\Off is (RAPID reference, 'ConfJ', 'ConfL': with \\Off the robot takes the
        configuration nearest the current one). The switches are taken in the order of the
        module's text, which is the order of execution within one routine."""
        from ...ir import Kind

        has = ~np.isnan(tp.conf).any(axis=1)
        lin_off, joint_off = _switch_state(tp, "CONFL"), _switch_state(tp, "CONFJ")
        joint = tp.kind == Kind.JOINT
        return has & np.where(joint, ~joint_off, ~lin_off)

    def place_workpiece(self, text, frame_name, new_frame, path):
        from .placing import set_work_object

        return set_work_object(text, frame_name, new_frame, path)

    def new_writer(self, name: str):
        from .writer import RapidWriter

        return RapidWriter(name)


def _switch_state(tp: Toolpath, switch: str) -> np.ndarray:
    """(N,) True where the last ``ConfL``/``ConfJ`` instruction before the target's line
    (in the module's text) was ``\\Off``."""
    text = tp.sources[0].text
    pattern = re.compile(rf"^[ \t]*{switch}[ \t]*\\(ON|OFF)[ \t]*;", re.IGNORECASE | re.MULTILINE)
    events = [(text.count("\n", 0, m.start()) + 1, m.group(1).upper() == "OFF") for m in pattern.finditer(text)]
    if not events:
        return np.zeros(len(tp.line), dtype=bool)
    lines = np.array([line for line, _ in events])
    off = np.array([state for _, state in events])
    last = np.searchsorted(lines, tp.line, side="right") - 1
    return np.where(last >= 0, off[np.maximum(last, 0)], False)


RAPID = RapidDialect()
