"""G-code (ISO / Fanuc / LinuxCNC / Siemens)."""

from __future__ import annotations

from ...ir import SourceDoc, Toolpath
from ..base import Dialect


class GcodeDialect(Dialect):
    name = "gcode"
    description = "G-code (ISO, Fanuc, LinuxCNC, Siemens)"
    extensions = (".nc", ".ngc", ".gcode", ".tap", ".cnc", ".mpf", ".spf", ".iso", ".txt")
    machine_program = True
    speed_to_mm_per_s = 1.0 / 60.0  # F words are mm/min (G94)

    def sniff(self, head: str) -> bool:
        return any(tok in head for tok in ("G0", "G1", "G2", "G3", "M3", "M30", "M2"))

    def parse_sources(self, sources: list[SourceDoc]) -> Toolpath:
        from .parse import GcodeParser

        return GcodeParser(sources[0]).parse()

    def stream_rules(self):
        from .stream import RULES

        return RULES

    def insert_field(self, source: int, field: str, text: str) -> str:
        return f" {field.upper()}{text}"  # one more axis word in the block


GCODE = GcodeDialect()
