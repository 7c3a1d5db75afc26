"""Siemens SINUMERIK 840D part programs (.MPF main programs, .SPF subprograms).

The language shares ISO G-code's words and the Sinumerik control flow the G-code reader
already runs (``..gcode``: DEF, PROC, IF, WHILE, FOR, REPEAT, calls); this package adds what
is Sinumerik's own (``translate.py``: R parameters, ``X=`` expressions, ``CR=``; ``frames.py``:
TRANS, ATRANS, ROT, AROT, RPL, SCALE, MIRROR) and what the 840D does with the program
(``controller.py``). Writing back is the G-code splice (numbers only, byte-identical when
unchanged); new programs are the five-axis TRAORI writer (``postproc.jobs.five_axis.emit``, mode
``siemens``).
"""

from __future__ import annotations

import re

from ...ir import SourceDoc, Toolpath
from ..gcode import GcodeDialect
from . import swivel_place
from .controller import SINUMERIK_840D
from .facts import with_controller_facts
from .parse import SinumerikParser

# Words no other G-code dialect writes at the start of a block (the head is upper case).
_SNIFF = re.compile(r"(?m)^[ \t]*(?:N\d+[ \t]+)?(?:A?TRANS|A?ROT|A?SCALE|A?MIRROR|TRAORI|TRAFOOF|CYCLE800|CYCLE832|G500|G710|G700|SUPA|"
                    r"MSG[ \t]*\(|DEF[ \t]+(?:REAL|INT|BOOL|STRING|AXIS|FRAME)\b|R\d+[ \t]*=)")


class SinumerikDialect(GcodeDialect):
    name = "sinumerik"
    description = "Siemens SINUMERIK 840D (.MPF / .SPF): frames, R parameters, TRAORI"
    extensions = (".mpf", ".spf")
    controller = SINUMERIK_840D
    rtcp_modes = ("siemens",)  # convert --to sinumerik writes TRAORI programs (postproc.jobs.five_axis.emit)

    def sniff(self, head: str) -> bool:
        return _SNIFF.search(head) is not None

    def for_machine(self, tp: Toolpath, machine) -> Toolpath:
        """The targets of CYCLE800 swivel planes placed on ``machine``: the 840D's rotary positions."""
        return swivel_place.place(tp, machine)

    def refuse_compensation(self, tp: Toolpath) -> None:
        """A swivel plane is not compensated: the correction would change the cycle's angles, not block numbers."""
        swivel_place.refuse_compensation(tp)

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return with_controller_facts(SinumerikParser(sources[0]).parse())


SINUMERIK = SinumerikDialect()
