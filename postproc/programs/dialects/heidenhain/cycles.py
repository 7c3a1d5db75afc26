"""Klartext blocks that set the TNC's state rather than move: TOOL DEF / TOOL CALL, cycle
definitions (Cycle 7 datum shift, 19, 32, machining cycles), PLANE, FUNCTION TCPM."""

from __future__ import annotations

import math
import re

import numpy as np

from . import plane_forms
from .fields import along_z, translation

# PLANE forms and the words that define them (TNC 640 manual, "Tilting the working plane"; plane_forms)
_PLANE_FORMS = {
    "SPATIAL": ("SPA", "SPB", "SPC"), "EULER": ("EULPR", "EULNU", "EULROT"), "PROJECTED": ("PROPR", "PROMIN", "PROROT"),
    "VECTOR": ("BX", "BY", "BZ", "NX", "NY", "NZ"),
    "POINTS": ("P1X", "P1Y", "P1Z", "P2X", "P2Y", "P2Z", "P3X", "P3Y", "P3Z"),
    "RELATIV": (), "AXIAL": (), "RESET": (),
}


class StateBlocks:
    """KlartextReader's state blocks (a mixin: the reader's state is ``self``)."""

    def tool_def(self, s: str, at: int):
        m = re.match(r"TOOL DEF\s+(\d+)(.*)$", s, re.IGNORECASE)
        if not m:
            return None  # TOOL DEF "name" / TOOL DEF without data: pre-selection only
        length = re.search(r"\bL\s*([+-]?(?:\d+\.?\d*|\.\d+))", m.group(2), re.IGNORECASE)
        if length:  # TNC 4xx: TOOL DEF n L.. R.. defines the tool in the program
            self.b.tool_index(f"T{m.group(1)}", along_z(float(length.group(1)) * self.scale))
        radius = re.search(r"\bR\s*([+-]?(?:\d+\.?\d*|\.\d+))", m.group(2), re.IGNORECASE)
        if radius:  # its radius R: what RL / RR offset by (TNC 640 manual, 5.2 Tool data)
            self.tool_radius[f"T{m.group(1)}"] = float(radius.group(1)) * self.scale
        return None

    def tool_call(self, s: str, at: int, line: int):
        m = re.match(r"TOOL CALL\s*(\d+|\"[^\"]*\")?\s*([XYZ])?(.*)$", s, re.IGNORECASE)
        if not m:
            raise self.error(at, "TOOL CALL needs a tool number or name and the tool axis")
        if m.group(2) and m.group(2).upper() != "Z":
            raise self.error(at + m.start(2), f"tool axis {m.group(2).upper()}: only tool axis Z (working plane XY) is read")
        if m.group(1) is None:
            return None  # TOOL CALL Z: sets the tool axis only
        name = f"T{m.group(1)}" if m.group(1)[0] != '"' else m.group(1).strip('"')
        rest = m.group(3)
        dl = re.search(r"\bDL\s*([+-]?(?:\d+\.?\d*|\.\d+))", rest, re.IGNORECASE)
        if re.search(r"\bDL\s*[+-]?\s*Q", rest, re.IGNORECASE):
            raise self.error(at, "DL from a Q parameter is not read")
        base = self.b.tool_index(name, None) if name not in self.b.tool_names else self.b.tool_names.index(name)
        self.called.add(name)
        # the compensation value R + DR TAB + DR of TOOL CALL (TNC 640 manual, 5.3): R of TOOL DEF, or the table's R + DR given from outside
        self.radius = self.tool_radius.get(name, self.table_radius.get(name, math.nan)) + self._delta_radius(rest, at)
        # LN (3-D compensation) moves the tool along N by the sum of the delta values (tool table and TOOL
        # CALL): zero for a tool the program defines (no table row) called without DL / DR / DR2
        deltas = re.findall(r"\b(?:DL|DR2|DR)\s*([+-]?(?:\d+\.?\d*|\.\d+))", rest, re.IGNORECASE)
        self.ln_delta = sum(float(v) for v in deltas) * self.scale if name in self.tool_radius else math.nan
        if re.search(r"\bDR2\s*[+-]?\s*Q", rest, re.IGNORECASE):
            self.ln_delta = math.nan  # DR2 from a Q parameter: LN's displacement is not read
        if dl and float(dl.group(1)) != 0.0:
            delta = float(dl.group(1)) * self.scale
            known = bool(self.b.tool_known[base])
            # DL is added to the tool table's length (TNC 640 manual, "Tool call: delta values")
            self.tool = self.b.tool_index(f"{name}+DL{dl.group(1)}@line{line}", self.b.tools[base] @ along_z(delta), known)
        else:
            self.tool = base
        return None

    def _delta_radius(self, rest: str, at: int) -> float:
        """DR of TOOL CALL (mm): added to the tool's radius under RL / RR (TNC 640 manual,
        5.3: compensation value = R + DR TOOL CALL + DR TAB; a TOOL DEF tool has no table row).
        DR2 (the corner radius of 3-D compensation) is not it."""
        if re.search(r"\bDR(?!2)\s*[+-]?\s*Q", rest, re.IGNORECASE):
            raise self.error(at, "DR from a Q parameter is not read")
        dr = re.search(r"\bDR(?!2)\s*([+-]?(?:\d+\.?\d*|\.\d+))", rest, re.IGNORECASE)
        return float(dr.group(1)) * self.scale if dr else 0.0

    def cycle_def(self, s: str, at: int, line: int):
        m = re.match(r"CYCLE?\s+DEF\s+(\d+)(?:\.(\d+))?\s*(.*)$", s, re.IGNORECASE)
        if not m:
            raise self.error(at, "CYCL DEF needs a cycle number")
        number, sub, rest = int(m.group(1)), m.group(2), m.group(3)
        if number == 7:
            return self.datum_shift(sub, rest, at + m.start(3), line)
        if number == 19:
            return self.cycle19(sub, rest, at + m.start(3), line)
        if number in (8, 10, 11, 26):
            if sub and sub != "0":
                raise self.error(at, f"coordinate transformation cycle {number} (mirror / rotation / scaling) is not read")
            return None
        if number == 32:  # TOLERANCE: the TNC smooths the path within T (TNC 640 manual, Cycle 32)
            if sub == "1" and re.search(r"T\s*\+?0*\.?0*[1-9]", rest):
                self.tolerance_line = self.tolerance_line or line
            return None
        if number == 9:  # dwell
            return None
        self.cycle_defined = line  # a machining cycle: its moves run at CYCL CALL / M99 / M89
        return None

    def datum_shift(self, sub: str | None, rest: str, at: int, line: int):
        if sub in (None, "0"):
            self.cycl7_line = line
            return None
        table = re.match(r"\s*#", rest)
        if table:
            self.frame = (f"PRESET+datum table {rest.strip()}@line{line}", None)
            return None
        words = list(re.finditer(r"(I?)([XYZ])\s*([+-]?\s*(?:\d+\.?\d*|\.\d+|Q[LR]?\d+))", rest, re.IGNORECASE))
        if not words:
            raise self.error(at, "datum shift: X, Y or Z and its value expected")
        for w in words:
            k = "XYZ".index(w.group(2).upper())
            v = self.value(w.group(3), at + w.start(3))[0] * self.scale  # NaN: from a value the text does not give
            self.shift[k] = self.shift[k] + v if w.group(1) else v
        if np.isnan(self.shift).any():
            self.frame = (f"PRESET+CYCL7@line{self.cycl7_line or line}(from Q parameters the text does not determine)", None)
            return None
        shown = " ".join(f"{a}{v:+g}" for a, v in zip("XYZ", self.shift / self.scale))
        name = f"PRESET+CYCL7@line{self.cycl7_line or line}({shown})"  # one frame per shift value (a loop may shift again)
        self.frame = (name, translation(self.shift)) if self.shift.any() else ("PRESET", None)
        return None

    def cycle_call(self, at: int, line: int):
        if self.cycle_defined:
            self.unresolved_row(line, at, f"line {line}: CYCL CALL runs the machining cycle defined at line {self.cycle_defined}: its moves are not read")
        return None

    def plane(self, s: str, at: int, line: int):
        up = s.upper()
        form = re.match(r"PLANE\s+([A-Z]+)", up)
        if form is None or form.group(1) not in _PLANE_FORMS:
            raise self.error(at, f"'{' '.join(up.split()[:2])}' is not a PLANE function (SPATIAL, PROJECTED, EULER, VECTOR, POINTS, RELATIV, AXIAL, RESET)")
        active = self.tilt if self.tilt_line else np.eye(3)
        self.tilt = None
        axes = np.full(3, np.nan)
        if form.group(1) == "RESET":
            self.tilt_line, self.tilt_form = 0, ""
        else:
            self.tilt_line, self.tilt_form = line, form.group(1)
            self.tilt = self._plane_rotation(form.group(1), s, at, active)
            if form.group(1) == "AXIAL":
                axes = self._axis_words(s[form.end():], at + form.end(), "PLANE AXIAL")
        mode = re.search(r"\b(MOVE|TURN|STAY)\b", up)
        seq = re.search(r"\bSEQ\s*([+-])", up)
        dist = re.search(r"\b(?:DIST|ABST)\s*([+-]?(?:\d+\.?\d*|\.\d+))", up[mode.end():]) if mode else None
        if mode and dist is None and re.search(r"\b(?:DIST|ABST)\b", up[mode.end():]):
            raise self.error(at + mode.end(), "PLANE ... DIST: the distance is read as a number only")
        self.planes[line] = (0 if seq is None else 1 if seq.group(1) == "+" else -1, mode.group(1) if mode else "STAY",
                             float(dist.group(1)) * self.scale if dist else 0.0, form.group(1), axes)
        if self.tilt_line and (not mode or mode.group(1) == "STAY"):  # the TNC stores its solution in Q120 (A), Q121 (B), Q122 (C)
            for name in ("Q120", "Q121", "Q122"):
                self.q[name] = math.nan
                self.q_origin.pop(name, None)
                self.plane_q_line[name] = line
        if mode and mode.group(1) in ("MOVE", "TURN"):
            # the TNC positions the rotary axes itself (TNC 640 manual, "PLANE: automatic positioning")
            self.positioning_rows.add(self.rows_all())
            self.unresolved_row(line, at, f"line {line}: PLANE ... {mode.group(1)} positions the rotary axes as the TNC solves the plane (SEQ+/SEQ-): "
                                "computed where a machine is given (compensate / convert), else not read", self._tilt_only(line, False))
        return None

    def cycle19(self, sub: str | None, rest: str, at: int, line: int):
        """CYCL DEF 19 WORKING PLANE: A B C as spatial angles or axis angles, as the machine's
        parameters say (machine file [heidenhain] cycle19_angles; placed in plane_solution); all
        zero resets the tilt. The cycle positions no axis: the program's own blocks do (TNC 640
        manual, "Cycle 19 WORKING PLANE")."""
        if not sub or sub == "0":
            return None
        axes = self._axis_words(rest, at, "CYCL DEF 19")
        if np.all(np.nan_to_num(axes) == 0.0):
            self.tilt_line, self.tilt_form, self.tilt = 0, "", None
            return None
        self.tilt_line, self.tilt_form, self.tilt = line, "CYCL19", None
        self.planes[line] = (0, "STAY", 0.0, "CYCL19", axes)
        return None

    def _axis_words(self, s: str, at: int, what: str) -> np.ndarray:
        """A B C of PLANE AXIAL / Cycle 19 (deg; NaN: not given)."""
        out = np.full(3, np.nan)
        for m in re.finditer(r"(?<![A-Z])([ABC])\s*([+-]?\s*(?:\d+\.?\d*|\.\d+|Q[LR]?\d+))", s, re.IGNORECASE):
            out["ABC".index(m.group(1).upper())] = self.value(m.group(2), at + m.start(2))[0]
        if re.search(r"(?<![A-Z])I[ABC]", s, re.IGNORECASE):
            raise self.error(at, f"{what}: incremental angles are not read")
        if any(m.group(2).strip().upper().startswith("Q") for m in re.finditer(r"(?<![A-Z])([ABC])\s*([+-]?\s*Q[LR]?\d+)", s, re.IGNORECASE)) and np.isnan(out).any():
            return np.full(3, np.nan)  # an angle from a Q parameter the text does not give: the plane is not determined
        return out

    def _plane_rotation(self, form: str, s: str, at: int, active: np.ndarray | None) -> np.ndarray | None:
        """The tilted plane's orientation in the untilted workpiece system (plane_forms), None where
        a value is not determined by the text or the machine decides it (AXIAL: axis angles)."""
        if form == "AXIAL":
            return None  # axis positions: the plane is the machine's (placed in plane_solution)
        if form == "RELATIV":
            found = [k for k in ("SPA", "SPB", "SPC") if re.search(rf"(?<![A-Z]){k}", s, re.IGNORECASE)]
            if len(found) != 1:
                raise self.error(at, "PLANE RELATIV takes one angle: SPA, SPB or SPC")
            angle = self._plane_values(s, at, found, form)[0]
            return None if active is None or math.isnan(angle) else plane_forms.relative(active, found[0], angle)
        values = self._plane_values(s, at, _PLANE_FORMS[form], form)
        if any(math.isnan(v) for v in values):
            return None
        try:
            if form == "SPATIAL":
                return plane_forms.spatial(*values)
            if form == "EULER":
                return plane_forms.euler(*values)
            if form == "PROJECTED":
                return plane_forms.projected(*values)
            if form == "VECTOR":
                return plane_forms.vector(np.array(values[:3]), np.array(values[3:]))
            return plane_forms.points(np.array(values[:3]), np.array(values[3:6]), np.array(values[6:]))
        except plane_forms.PlaneError as exc:
            raise self.error(at, str(exc)) from None

    def _plane_values(self, s: str, at: int, keys: tuple, form: str) -> list[float]:
        out = []
        for key in keys:
            m = re.search(rf"(?<![A-Z0-9]){key}\s*([+-]?\s*(?:\d+\.?\d*|\.\d+|Q[LR]?\d+))", s, re.IGNORECASE)
            if m is None:
                raise self.error(at, f"PLANE {form} needs {' '.join(keys)} ({key} is missing)")
            out.append(self.value(m.group(1), at + m.start(1))[0])
        return out

    def function(self, s: str, at: int, line: int):
        up = re.sub(r"\s+", " ", s.upper())
        if up.startswith("FUNCTION RESET TCPM"):
            self.tcpm = False
        elif up.startswith("FUNCTION TCPM"):
            if "AXIS SPAT" in up:
                raise self.error(at, "FUNCTION TCPM ... AXIS SPAT: rotary words as spatial angles are not read (AXIS POS is)")
            self.tcpm = True
            self.notes["FUNCTION TCPM: rotary words are axis positions, X Y Z the tool tip (TNC 640 manual, FUNCTION TCPM)"] = None
        else:
            raise self.error(at, f"'{' '.join(up.split()[:2])}' is not read")
        return None
