"""A new KRL .src and .dat from the writer events (see postproc.emit.writer)."""

from __future__ import annotations

import numpy as np

from ...emit.writer import legal_name, short_number
from ...frames import matrix_to_abc


class KrlWriter:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "prog").lower()
        self.body: list[str] = []
        self.approx = False
        self.tool_load = None  # emit.tool_load.ToolLoad: convert --tool-load (else $LOAD is left as the controller has it)

    def set_tool_load(self, load) -> None:
        self.tool_load = load

    def start(self, name: str) -> None:
        pass

    @staticmethod
    def _frame(t: np.ndarray) -> str:
        abc = matrix_to_abc(t[None, :3, :3])[0]
        return "{" + ", ".join(f"{k} {short_number(v)}" for k, v in zip("XYZABC", [*t[:3, 3], *abc])) + "}"

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.body.append(f"$BASE = {self._frame(base_T_frame)}")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.body.append(f"$TOOL = {self._frame(flange_T_tcp)}")
        if self.tool_load is not None:  # KSS: LOAD = {M kg, CM frame (mm, deg) in the flange frame, J kg m^2}
            load = self.tool_load
            cm = ", ".join(f"{k} {short_number(v)}" for k, v in zip("XYZ", load.cog_mm))
            j = ", ".join(f"{k} {short_number(v, 6)}" for k, v in zip("XYZ", load.inertia_kgm2))
            self.body.append(f"$LOAD = {{M {short_number(load.mass_kg, 6)}, CM {{{cm}, A 0, B 0, C 0}}, J {{{j}}}}}")

    def speed(self, mm_s: float) -> None:
        if np.isfinite(mm_s):
            self.body.append(f"$VEL.CP = {short_number(mm_s / 1000.0, 6)}")

    def zone(self, mm: float) -> None:
        self.approx = np.isfinite(mm) and mm > 0
        if self.approx:
            self.body.append(f"$APO.CDIS = {short_number(mm, 3)}")

    def _c(self) -> str:
        return " C_DIS" if self.approx else ""

    def move_joint(self, pose, conf=None) -> None:
        # No C_DIS after PTP: a PTP motion is approximated by C_PTP with $APO.CPTP, a
        # percentage no distance maps to (KSS 8.x programming manual, "Approximate
        # positioning": C_DIS is for CP motions); a PTP point is reached exactly instead.
        self.body.append(f"PTP {self._frame(pose)}")

    def move_linear(self, pose, conf=None) -> None:
        self.body.append(f"LIN {self._frame(pose)}{self._c()}")

    def move_circular(self, via, end, conf=None) -> None:
        self.body.append(f"CIRC {self._frame(via)}, {self._frame(end)}{self._c()}")

    def move_joints(self, q) -> None:
        self.body.append("PTP {" + ", ".join(f"A{i + 1} {short_number(v)}" for i, v in enumerate(q)) + "}")

    def raw(self, line: str) -> None:
        self.body.append(f"; {line}")

    def end(self) -> list[str]:
        src = [f"DEF {self.name}( )", *self.body, "END", ""]
        dat = [f"DEFDAT {self.name}", "ENDDAT", ""]  # every target is written inline
        return ["\r\n".join(src), "\r\n".join(dat)]
