"""What a Heidenhain TNC (TNC 640 / iTNC 530) does with a Klartext program, beyond reading it.

A five-axis CNC has no robot posture: the "configuration" question is which of the two
rotary solutions the control takes for a tool direction. With M128 / FUNCTION TCPM and
rotary words (the programs postproc reads and writes) the program states the axis positions
itself, so the control takes them as written: "M128 ... The TNC positions the rotary axes to
the programmed values and compensates the tool-tip offset" (TNC 640 User's Manual,
"Miscellaneous functions for rotary axes: M128"; FUNCTION TCPM ... AXIS POS, "Rotary axes as
axis positions"). M126 only picks the shorter way to the programmed angle (same section,
"Shorter-path traverse of rotary axes: M126"). A tilted working plane (PLANE ... SEQ+/SEQ-,
CYCL DEF 19) lets the control choose the solution itself: such targets are flagged
unresolved by the reader (parse.py) and refused by compensation.
"""

from __future__ import annotations

import numpy as np

from ...controller import Controller
from ...ir import Toolpath


class TncController(Controller):
    """Heidenhain TNC 640 rules for Klartext programs."""

    maker = None  # a CNC: no robot maker
    name = "Heidenhain TNC 640"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """No robot configuration data: a CNC program never selects a robot posture."""
        return np.zeros(len(tp), bool)

    def rotary_solution(self, programmed_deg: np.ndarray) -> np.ndarray:
        """(N, 2) the rotary axis positions the TNC turns to under M128 / FUNCTION TCPM AXIS POS:
        the programmed ones (TNC 640 manual, "M128"; M126 changes the way, not the end angle)."""
        return np.asarray(programmed_deg, dtype=float).copy()

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """CYCL DEF 32 TOLERANCE with T > 0 lets the TNC smooth the path within T (TNC 640
        User's Manual, "Cycle 32 TOLERANCE")."""
        for note in tp.notes:
            if "CYCL DEF 32 TOLERANCE" in note:
                return f"{tp.sources[0].path}:{note.split(':')[0].removeprefix('line ')}: CYCL DEF 32 TOLERANCE lets the TNC leave the programmed path"
        return None


TNC = TncController()
