"""A new KRL .src and .dat from the writer events (see postproc.programs.emit.writer)."""

from __future__ import annotations

import numpy as np

from postproc.robot.frames import matrix_to_abc, quat_wxyz_to_matrix

from ...emit.writer import legal_name, short_number


class KrlWriter:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "prog").lower()
        self.body: list[str] = []
        self.approx = False
        self.written_load = None  # the last $LOAD written (None: as the controller has it)
        self.tool_written = False

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
        self.tool_written = True

    def load(self, state) -> None:
        """$LOAD with the tool and wherever the load changes (emit.load_plan.LoadState: KUKA's $LOAD is
        the whole load, a RAPID GripLoad payload included). Nothing while the program states none."""
        load = None if state is None else state.total
        if load is None or (not state.stated_at and self.written_load is None):
            return  # as the controller has it (e.g. RAPID tool0's empty load before any stated one)
        if load != self.written_load or self.tool_written:
            # KSS: $LOAD = {M kg, CM frame (mm, deg: the principal axes) relative to the flange, J kg m^2 about them}
            cm = ", ".join(f"{k} {short_number(v)}" for k, v in zip("XYZ", load.cog_mm))
            abc = matrix_to_abc(quat_wxyz_to_matrix(np.array(load.aom_wxyz))[None])[0]
            j = ", ".join(f"{k} {short_number(v, 6)}" for k, v in zip("XYZ", load.inertia_kgm2))
            abc_text = ", ".join(f"{k} {short_number(v)}" for k, v in zip("ABC", abc))
            self.body.append(f"$LOAD = {{M {short_number(load.mass_kg, 6)}, CM {{{cm}, {abc_text}}}, J {{{j}}}}}")
            self.written_load = load
        self.tool_written = False

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
