"""INFORM job (.JBI) -> Toolpath: the positions of the POS section, moved to by the
MOVJ / MOVL / MOVC / MOVS lines of the INST section, with every number's span.

How each number is read (Yaskawa DX100 / YRC1000 INFORM and data transmission manuals):
- ``///RECTAN`` positions are X, Y, Z (mm) and Rx, Ry, Rz (deg): the rotation about the
  fixed X, then Y, then Z axis, R = Rz Ry Rx, which is KUKA's A B C with A = Rz, B = Ry,
  C = Rx; the IR keeps them in the "abc" form with each field's span on its own number.
- ``///POSTYPE ROBOT`` (and BASE without base axes) positions are in the robot frame;
  ``USER`` ones in user frame ``///USER n``, named ``UF#(n)``; the TCP is tool ``///TOOL n``,
  named ``TOOL#(n)``. Their values live in the controller (UFRAME.CND, TOOL.CND), not in
  the job: unknown until given (``--frame 'UF#(1)=...'``, ``--tool 'TOOL#(0)=...'``).
- ``///PULSE`` positions are joint encoder pulses: joint targets whose angles need the
  robot's pulse data (robot file ``[pulses]``); the IR keeps them unresolved.
- ``V=`` is mm/s; ``VJ=`` (% of the joint speed) and ``VR=`` (deg/s) give no TCP speed;
  ``PL=0`` stops at the point (zone 0), ``PL=1..8`` rounds the corner by a distance the
  controller's parameters set (zone unknown).
- MOVC: three consecutive MOVC lines define one circle through their points; the move
  to the first is straight (INFORM manual, MOVC). Other runs are refused. MOVS (spline) is
  refused: its curve is the controller's own.
"""

from __future__ import annotations

import re

import numpy as np

from ...ir import FIELDS, NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from .jobfile import JobFile, Position, read_job

MOTION = re.compile(r"(MOVJ|MOVL|MOVC|MOVS)[ \t]+(\S+)(.*)")
TAG = re.compile(r"(VJ|V|VR|VE|PL|CR|ACC|DEC)=(\S+)|(NWAIT)|(\+MOV[JLCS])[ \t]+(\S+)|(\S+)")
# Instructions that move positions or frames by amounts the job's text does not give.
SHIFTING = {"SFTON", "SFTOF", "MSHIFT", "MFRAME", "IMOV", "CNVRT", "SETE", "GETE", "GETS", "SETTOOL"}
CARTESIAN = {"ROBOT": 0, "BASE": 0, "USER": 1}
# RECTAN numbers -> IR fields: X Y Z, then Rx Ry Rz into C B A (o3 o2 o1)
RECTAN_FIELDS = [FIELDS.index(f) for f in ("x", "y", "z", "o3", "o2", "o1")]
JOINT_FIELDS = [FIELDS.index(f"j{i}") for i in range(1, 7)]


class InformParser:
    def __init__(self, sources: list[SourceDoc]):
        self.doc = sources[0]
        self.path = self.doc.path
        self.lines = LineIndex(self.doc.text)
        self.builder = Builder("inform", "abc", list(sources))
        self.rows: list[dict] = []
        self.notes: list[str] = []

    def parse(self) -> Toolpath:
        job = read_job(self.doc.text, self.path, self.lines)
        shifted_from = None
        for line, start, text in job.instructions:
            word = text.split(None, 1)[0].upper() if text.strip() else ""
            if word in SHIFTING:
                shifted_from = line if word != "SFTOF" else None
                self.notes.append(f"{self.path}, line {line}: {word} moves positions or frames by values the job does not give")
                continue
            match = MOTION.match(text)
            if match:
                self._motion(job, match, line, start, shifted_from)
        self._circles()
        return self._build()

    # ------------------------------------------------------------ one motion line
    def _motion(self, job: JobFile, match: re.Match, line: int, start: int, shifted_from) -> None:
        word, name, tags = match.group(1), match.group(2), match.group(3)
        row = {"word": word, "line": line, "start": start, "name": name, "resolved": True, "why": [],
               "values": np.full(NF, np.nan), "spans": np.full((NF, 3), -1, np.int64), "conf": np.full(4, np.nan),
               "speed": np.nan, "zone": np.nan, "tool": 0, "frame": 0, "pulse": False}
        self._tags(row, tags, start + match.start(3))
        if shifted_from is not None:
            row["why"].append(f"shifted (SFTON on line {shifted_from})")
        position = job.positions.get(name.upper())
        if position is None:
            what = "a position variable held by the controller" if re.fullmatch(r"L?P\d+|L?P\[.*\]", name, re.I) else "not a position of this job"
            row["why"].append(f"{name} is {what}")
            row["tool"] = self.builder.tool_index("TOOL#(?)", None)
        else:
            self._position(row, position)
        self.rows.append(row)

    def _tags(self, row: dict, tags: str, offset: int) -> None:
        for tag in TAG.finditer(tags):
            key, value = tag.group(1), tag.group(2)
            if key == "V":
                row["speed"] = float(value) if _is_number(value) else np.nan
            elif key == "PL":
                if not value.isdigit():
                    row["why"].append(f"PL={value} is not a number")
                row["zone"] = 0.0 if value == "0" else np.nan
            elif tag.group(4):
                row["why"].append(f"{tag.group(4)} {tag.group(5)} moves another axis group (external axes not read)")
            elif tag.group(6):
                raise self.lines.error(self.path, offset + tag.start(6), f"'{tag.group(6)}': a motion tag postproc does not read (VJ=, V=, VR=, VE=, PL=, CR=, ACC=, DEC=, NWAIT, +MOVJ)")
            if key == "CR":
                row["why"].append("CR= rounds the corner by a radius")

    def _position(self, row: dict, position: Position) -> None:
        state = position.state
        values, spans = position.values, position.spans
        if state.tool is not None:
            row["tool"] = self.builder.tool_index(f"TOOL#({state.tool})", None)
        else:
            row["tool"] = self.builder.tool_index("TOOL#(?)", None)
            row["why"].append(f"{position.name} has no ///TOOL")
        if state.form == "PULSE" or state.postype == "PULSE":
            row["pulse"] = True
            if len(values) != 6:
                row["why"].append(f"{position.name} has {len(values)} axes, postproc reads six")
                return
            for field, value, (a, b) in zip(JOINT_FIELDS, values, spans):
                row["spans"][field] = (0, a, b)
            row["pulse_values"] = values
            row["why"].append(f"{position.name} is in pulses: joint angles need the robot's pulse data")
            return
        if state.form != "RECTAN" or state.postype not in CARTESIAN:
            row["why"].append(f"{position.name}: ///POSTYPE {state.postype} positions are not read")
            return
        if len(values) != 6:
            raise self.lines.error(self.path, spans[0][0] if spans else 0, f"a ///RECTAN position has six numbers (X, Y, Z, Rx, Ry, Rz), this one {len(values)}")
        for field, value, (a, b) in zip(RECTAN_FIELDS, values, spans):
            row["values"][field] = value
            row["spans"][field] = (0, a, b)
        if state.postype == "USER":
            if state.user is None:
                raise self.lines.error(self.path, spans[0][0], f"{position.name}: ///POSTYPE USER without ///USER n")
            row["frame"] = self.builder.frame_index(f"UF#({state.user})", None)
        if state.rconf is not None:
            flip, arm, side, r, t, s = state.rconf[:6]
            row["conf"] = np.array([flip, arm, side, r + 2 * t + 4 * s], dtype=float)

    # -------------------------------------------------------------- circles
    def _circles(self) -> None:
        """Three consecutive MOVC lines: straight to the first, then the circle through the
        second to the third (INFORM manual, MOVC); any other run is refused."""
        i = 0
        while i < len(self.rows):
            if self.rows[i]["word"] != "MOVC":
                i += 1
                continue
            j = i
            while j < len(self.rows) and self.rows[j]["word"] == "MOVC":
                j += 1
            if j - i != 3:
                row = self.rows[i]
                raise self.lines.error(self.path, row["start"], f"{j - i} consecutive MOVC lines: postproc reads a circle of exactly three (continued arcs follow controller rules it does not model)")
            i = j

    def _build(self) -> Toolpath:
        rows = self.rows
        kinds, run = [], 0
        for row in rows:
            word = row["word"]
            if word == "MOVS":
                raise self.lines.error(self.path, row["start"], "MOVS (spline): the controller's spline through the points is not modelled; refused")
            run = run + 1 if word == "MOVC" else 0
            if word == "MOVC":  # runs are of three (_circles): straight to the first, then the circle
                kinds.append((Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END)[(run - 1) % 3])
            elif row["pulse"]:
                kinds.append(Kind.ABSJ if word == "MOVJ" else Kind.LINEAR)
            else:
                kinds.append(Kind.JOINT if word == "MOVJ" else Kind.LINEAR)
        for row in rows:
            if row["why"]:
                row["resolved"] = False
                self.notes.append(f"{self.path}, line {row['line']}: {'; '.join(row['why'])}")
        n = len(rows)
        self.builder.notes.extend(self.notes)
        if n:
            self.builder.add_block(
                np.array([r["start"] for r in rows]), kind=np.array(kinds, np.int8), line=np.array([r["line"] for r in rows], np.int32),
                file=np.zeros(n, np.int16), values=np.array([r["values"] for r in rows]), spans=np.array([r["spans"] for r in rows]),
                conf=np.array([r["conf"] for r in rows]), speed=np.array([r["speed"] for r in rows]), zone=np.array([r["zone"] for r in rows]),
                tool=np.array([r["tool"] for r in rows], np.int32), frame=np.array([r["frame"] for r in rows], np.int32),
                resolved=np.array([r["resolved"] for r in rows]), name=np.array([r["name"] for r in rows], dtype=object))
        return self.builder.build()


def _is_number(text: str) -> bool:
    return re.fullmatch(r"[-+]?(?:\d+\.?\d*|\.\d+)", text) is not None
