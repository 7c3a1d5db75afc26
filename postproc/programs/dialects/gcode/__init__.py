"""G-code (ISO / Fanuc / LinuxCNC / Siemens)."""

from __future__ import annotations

import re

from postproc.errors import EmitError

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import CNC
from .interp import refuse_unwritable
from .parse import GcodeParser
from .stream import RULES


class GcodeDialect(Dialect):
    name = "gcode"
    description = "G-code (ISO, Fanuc, LinuxCNC, Siemens)"
    extensions = (".nc", ".ngc", ".gcode", ".tap", ".cnc", ".mpf", ".spf", ".iso", ".txt")
    machine_program = True
    controller = CNC
    speed_to_mm_per_s = 1.0 / 60.0  # F words are mm/min (G94)
    comment_pattern = r"\([^)\n]*\)|;[^\n]*|%[^\n]*"
    motion_words = "G0, G1, G2, G3 or a canned cycle"

    def sniff(self, head: str) -> bool:
        return any(tok in head for tok in ("G0", "G1", "G2", "G3", "M3", "M30", "M2"))

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return GcodeParser(sources[0]).parse()

    def emit_texts(self, original: Toolpath, modified: Toolpath) -> list[str]:
        refuse_unwritable(original, modified)  # canned-cycle and polar moves: refused by file:line:column, never left as they were
        return super().emit_texts(original, modified)

    def stream_rules(self):
        return RULES

    def insert_field(self, source: int, field: str, text: str) -> str:
        return f" {field.upper()}{text}"  # one more axis word in the block

    def clone_motion(self, text: str, where: str) -> str:
        """The block without its block number; a block that also changes tools, spindle,
        coolant or modes cannot be repeated."""
        body, _, comment = text.rstrip("\r\n").partition(";")
        body = re.sub(r"^\s*N\d+\s*", "", body, flags=re.IGNORECASE)
        words = re.findall(r"([A-Z])\s*([-+]?[\d.]+)", re.sub(r"\([^)]*\)", "", body).upper())
        # G2 / G3 with I J K or R: a split arc's piece repeats its block's motion
        other = [w + v for w, v in words if w not in "XYZABCUVWIJKFR" and not (w == "G" and float(v) in (0.0, 1.0, 2.0, 3.0))]
        if other:
            raise EmitError(f"{where}: the block also does {' '.join(other)}: a point before it cannot be written as a copy")
        return body + text[len(text.rstrip("\r\n")):]


GCODE = GcodeDialect()
