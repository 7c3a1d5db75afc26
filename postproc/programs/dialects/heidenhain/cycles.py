"""Klartext blocks that set the TNC's state rather than move: TOOL DEF / TOOL CALL, cycle
definitions (Cycle 7 datum shift, 19, 32, machining cycles), PLANE, FUNCTION TCPM."""

from __future__ import annotations

import math
import re

import numpy as np

from .fields import along_z, translation


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
        self.radius = self.tool_radius.get(name, math.nan) + self._delta_radius(rest, at)
        # LN (3-D compensation) moves the tool along N by the sum of the delta values (tool table and TOOL
        # CALL): zero for a tool the program defines (no table row) called without DL / DR / DR2
        deltas = re.findall(r"\b(?:DL|DR2|DR)\s*([+-]?(?:\d+\.?\d*|\.\d+))", rest, re.IGNORECASE)
        self.ln_deltas_zero = name in self.tool_radius and all(float(v) == 0.0 for v in deltas)
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
            if sub and sub != "0":
                angles = [float(v) for v in re.findall(r"[ABC]\s*([+-]?(?:\d+\.?\d*|\.\d+))", rest, re.IGNORECASE)]
                self.tilt_line = line if any(a != 0.0 for a in angles) else 0
                self.tilt = None  # axis or spatial angles, as the machine parameters say: not read
            return None
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
        self.tilt = None
        if up.startswith("PLANE RESET"):
            self.tilt_line = 0
        else:
            self.tilt_line = line
            if up.startswith("PLANE SPATIAL"):
                self.tilt = self._spatial(s, at)
        mode = re.search(r"\b(MOVE|TURN|STAY)\b", up)
        seq = re.search(r"\bSEQ\s*([+-])", up)
        self.planes[line] = (0 if seq is None else 1 if seq.group(1) == "+" else -1, mode.group(1) if mode else "STAY", re.search(r"\b(DIST|ABST)\s*[+-]?0*\.?0*[1-9]", up[mode.end():]) is not None if mode else False)
        if mode and mode.group(1) in ("MOVE", "TURN"):
            # the TNC positions the rotary axes itself (TNC 640 manual, "PLANE: automatic positioning")
            self.positioning_rows.add(self.rows_all())
            self.unresolved_row(line, at, f"line {line}: PLANE ... {mode.group(1)} positions the rotary axes as the TNC solves the plane (SEQ+/SEQ-): "
                                "computed where a machine is given (compensate / convert), else not read")
        return None

    def _spatial(self, s: str, at: int) -> np.ndarray | None:
        """The tilted plane's orientation in the untilted workpiece system: SPA about X, then
        SPB about Y, then SPC about Z, all about the fixed axes (TNC 640 manual, "PLANE
        SPATIAL": tilting sequence A-B-C), so R = Rz(SPC) Ry(SPB) Rx(SPA); None where an
        angle is not determined by the text."""
        angles = []
        for key in ("SPA", "SPB", "SPC"):
            m = re.search(rf"{key}\s*([+-]?\s*(?:\d+\.?\d*|\.\d+|Q[LR]?\d+))", s, re.IGNORECASE)
            if m is None:
                raise self.error(at, f"PLANE SPATIAL needs {key} (all three spatial angles)")
            angles.append(self.value(m.group(1), at + m.start(1))[0])
        if any(math.isnan(a) for a in angles):
            return None
        a, b, c = np.radians(angles)
        rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
        rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
        return rz @ ry @ rx

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
