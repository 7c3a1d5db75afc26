"""Fanuc TP (.ls ASCII listing) -> Toolpath, with the span of every number read.

The controller's rules it follows (R-30iB Operator's Manual, chapters "Program
structure", "Motion instructions" and "Position data"):

- A program is ``/PROG name``, ``/ATTR``, (``/APPL``), ``/MN`` (the statements), ``/POS``
  (the positions P[n]) and ``/END``.
- A motion ``J|L|C|A P[n] speed FINE|CNTk [options]`` goes to P[n] as /POS gives it, in
  the user frame and tool numbered by the position's own ``UF``/``UT``. Where they differ
  from UFRAME_NUM / UTOOL_NUM in force the controller stops with a frame mismatch alarm, or
  runs it in the other frame when $MCR.$UFRCHK is off: the target is unresolved. Where the
  program sets no number in force, the position's own are taken: the frame check
  ($MCR.$UFRCHK, on by default) lets it run in no other frame.
- ``C P[via]`` + ``: P[end] ...`` on the continuation line is a circle through the start,
  via and end. ``A`` (arc through consecutive A points) is read point by point: its points
  are exact, the path between them is a circle through three of them, which postproc does
  not predict (``inexact_interpolation`` says where).
- Values the program does not hold are unknown: PR[n] targets, ``Offset,PR[n]``,
  ``Tool_Offset``, ``INC``, ``Skip`` and user frames / tools (set on the pendant, or by
  ``UFRAME[n]=PR[m]``) leave the target unresolved with a note (``--frame UFRAME[n]=...``
  and ``--tool UTOOL[n]=...`` give frames and tools).
- Joint positions: J3 as the controller writes it is the forearm's angle to the
  horizontal (the J2/J3 interaction); the robot files' J3 is relative to the upper arm,
  so the IR's j3 is J3 + J2 (an offset on the j3 number: the text keeps J3).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from postproc.errors import ParseError

from ...ir import F_EXT, NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from . import flow
from .positions import NO_GROUP_1, UNTAUGHT, PositionError, Positions, read_positions
from .statements import Statement, StatementError, statements

DIALECT = "fanuc"
_SECTION = re.compile(r"^[ \t]*/(PROG|ATTR|APPL|MN|POS|END)\b[^\n]*$", re.MULTILINE)
_TARGET = r"(P|PR)\[[ \t]*(\d+|[A-Z]+\[\d+\])[ \t]*(?::[^\]\n]*)?\]"
_MOTION = re.compile(rf"[ \t]*([JLCA])[ \t]+{_TARGET}(.*)", re.DOTALL | re.IGNORECASE)
# C P[via] [options]  then, on the continuation line,  : P[end] speed FINE|CNT [options]
_VIA_END = re.compile(rf"([^\n]*)\n[ \t]*:[ \t]*{_TARGET}(.*)", re.DOTALL | re.IGNORECASE)
_GAP = re.compile(r"(?:[ \t\r]|\n[ \t]*:?)*")  # between options: blanks, and the ':' of a continuation line
_REGISTER = r"R\[[ \t]*\d+[ \t]*(?::[^\]\n]*)?\]"  # R[n] or R[n:comment]
# A speed: a number, a register or a weld schedule's speed (WELD_SPEED), then its unit.
_SPEED = re.compile(rf"[ \t]*(\d+\.?\d*|\.\d+|{_REGISTER}|max_speed|WELD_SPEED)[ \t]*(%|mm/sec|cm/min|inch/min|deg/sec|msec|sec)?", re.IGNORECASE)
_TERM = re.compile(rf"[ \t]*(FINE|CNT[ \t]*(\d+|{_REGISTER}))", re.IGNORECASE)
_BAD_FRAME = re.compile(r"[ \t]*(UFRAME|UTOOL)[ \t]*=", re.IGNORECASE)
_FRAME_NUM = re.compile(r"[ \t]*(UFRAME_NUM|UTOOL_NUM)[ \t]*=[ \t]*(\S+)[ \t]*$", re.IGNORECASE)
_FRAME_SET = re.compile(r"[ \t]*(UFRAME|UTOOL)\[[ \t]*(\d+)[ \t]*\][ \t]*=", re.IGNORECASE)
_FLOW = re.compile(r"[ \t]*(?:JMP|IF|CALL|SELECT|FOR|RUN)\b", re.IGNORECASE)
# Where execution may arrive from elsewhere than the statement before: a label, the end of a loop
# or of an IF block (R-30iB manual, "Branching instructions", "FOR/ENDFOR", "IF/ELSE/ENDIF")
_FLOW_TARGET = re.compile(r"[ \t]*(?:LBL[ \t]*\[|ENDFOR\b|ELSE\b|ENDIF\b)", re.IGNORECASE)
# Motion options (R-30iB manual, "Motion instruction options"), in the order tried: those
# that change where the robot goes by what the program does not hold (the reason), Wjnt
# (WRIST: the wrist joints interpolate, the target is exact, the path is not), and those
# that move neither target nor path (None: acceleration, output timing, corner region,
# path mode, arc / spot / weave process tags).
WRIST = "Wjnt"
_OPTIONS = [(re.compile(p, re.IGNORECASE), why) for p, why in (
    (r"Tool_Offset(?:[ \t]*,[ \t]*PR\[[^\]]*\])?", "Tool_Offset adds a position register's value (set outside the program)"),
    (r"Offset(?:[ \t]*,[ \t]*PR\[[^\]]*\])?", "Offset adds a position register's value (set outside the program)"),
    (r"VOFFSET(?:[ \t]*,[ \t]*VR\[[^\]]*\])?", "VOFFSET adds a vision register's value (set by the camera)"),
    (r"INC\b", "INC moves by the position as an increment from where the robot is"),
    (r"Skip[ \t]*,[ \t]*LBL\[[^\]]*\](?:[ \t]*,[ \t]*\S+)?", "Skip stops the motion where a condition turns true"),
    (r"Wjnt\b", WRIST),
    (r"ACC[ \t]*(?:\d+|R\[\d+\])", None),
    (r"(?:TB|TA)[ \t]+[\d.]+sec[ \t]*,[ \t]*(?:CALL[ \t]+\w+(?:\([^)]*\))?|\S+)", None),
    (r"DB[ \t]+[\d.]+mm[ \t]*,[ \t]*(?:CALL[ \t]+\w+(?:\([^)]*\))?|\S+)", None),
    (r"COORD\b", "COORD moves the target with another motion group (a positioner), which postproc does not model"),
    (r"(?:PTH|BREAK)\b", None),
    (r"(?:CR|RT_LD|AP_LD)[ \t]*\d+", None),
    (r"Arc[ \t]*(?:Start|End)[ \t]*\[[^\]]*\]", None),
    (r"Weave[ \t]*\w*[ \t]*\[[^\]]*\]", None),
    (r"Spot[ \t]*\[[^\]]*\]", None),
)]
SPEED_TO_MM_S = {"MM/SEC": 1.0, "CM/MIN": 10.0 / 60.0, "INCH/MIN": 25.4 / 60.0}
J2, J3 = 8, 9  # fields of the joint numbers J2 and J3
CNT = "fanuc.cnt"  # Toolpath.extras columns
OFF_LINE = "fanuc.off_line"


def parse_ls(sources: list[SourceDoc]) -> Toolpath:
    """The program (``sources[0]``) and the programs of its file set it calls (calls.py)."""
    reader = _Reader(sources)
    try:
        return reader.read()
    except (PositionError, StatementError) as exc:
        raise reader.lines.error(reader.doc.path, exc.offset, str(exc)) from None


class _Reader:
    def __init__(self, sources: list[SourceDoc]):
        self.sources = sources
        self.line_index = [LineIndex(doc.text) for doc in sources]
        self.tables: list[Positions] = [Positions.empty()] * len(sources)
        self._enter(0)
        self.builder = Builder(DIALECT, "wpr", list(sources))
        # CNT n of each motion (-1: FINE; NaN: CNT R[n], set outside the program): the corner
        # rounding the controller sizes from it (R-30iB manual, "Positioning path")
        self.builder.declare_extra(CNT, float, np.nan)
        # True where the controller leaves the straight line or circle to the target: an A
        # motion (an arc through consecutive points) or the Wjnt option (controller.py)
        self.builder.declare_extra(OFF_LINE, bool, False)
        self.rows: list[dict] = []
        self.notes: list[str] = []
        self.uframe: int | None = None  # UFRAME_NUM in force (None: as the controller has it)
        self.utool: int | None = None
        self.redefined: dict[str, int] = {}  # UFRAME[n] / UTOOL[n] -> line of its last assignment
        # Line of the last jump, call or label since the last J motion to a taught position, where
        # the flow is not followed: the posture an L or C motion keeps is then the one of whichever
        # motion ran before, which the text order does not give (a J motion's CONFIG sets it again).
        self.flow_line: int | None = None
        self.seq = 0  # targets read so far

    def error(self, offset: int, why: str) -> ParseError:
        return self.lines.error(self.doc.path, offset, why)

    def _enter(self, k: int) -> None:
        """Read program ``k`` of the file set from here (its text, lines and /POS)."""
        self.k, self.doc = k, self.sources[k]
        self.text, self.lines, self.positions = self.doc.text, self.line_index[k], self.tables[k]

    def _program(self, k: int) -> list[Statement]:
        """Program ``k``'s /MN statements, its /POS read into ``tables``."""
        self._enter(k)
        sections = self._sections()
        self.tables[k] = self.positions = read_positions(self.text, *sections["POS"]) if "POS" in sections else Positions.empty()
        return statements(self.text, *sections["MN"])

    def read(self) -> Toolpath:
        found = [self._program(k) for k in range(len(self.sources))]
        changes_flow = [[bool(_FLOW.match(st.text)) for st in program] for program in found]
        names = {Path(doc.path).stem.upper(): k for k, doc in enumerate(self.sources) if k}
        run = flow.order_with_calls([([st.text for st in program], flows) for program, flows in zip(found, changes_flow)], names) if any(changes_flow[0]) else None
        self._enter(0)
        if run is None:
            for st in found[0]:
                if self._statement(st) or _FLOW_TARGET.match(st.text):
                    self.flow_line = int(self.lines.line(st.start))
            if any(changes_flow[0]):
                self.notes.append(f"{self.doc.path}: the program jumps, calls or loops in ways its text does not fix (JMP, IF, CALL, FOR, ...): targets are "
                                  "listed in text order; an L or C motion after such a statement, before the next J motion, is unresolved (its posture depends on the flow)")
        else:  # jumps, counted loops and calls the text fixes: statements read as they run (a loop's motions once per pass)
            for k, i in run:
                if k != self.k:
                    self._add_rows()  # the rows read so far belong to the program left
                    self._enter(k)
                self._statement(found[k][i])
            called = sorted({Path(self.sources[k].path).name for k, _ in run if k})
            self.notes.append(f"{self.sources[0].path}: the program's jumps{' and calls' if called else ''} are fixed by its text: {len(run)} statement(s) are read "
                              f"in the order they run ({len(run) - len(set(run))} repeated by loops, {len(found[0]) - len({i for k, i in run if not k})} of the program never run"
                              f"{'; called: ' + ', '.join(called) if called else ''})")
        self._add_rows()
        self.builder.notes.extend(self.notes)
        return self.builder.build()

    def _sections(self) -> dict[str, tuple[int, int]]:
        found = [(m.group(1).upper(), m.start(), m.end()) for m in _SECTION.finditer(self.text)]
        names = [f[0] for f in found]
        if not names or names[0] != "PROG" or self.text[: found[0][1]].strip():
            raise self.error(0, "not a Fanuc TP listing: it must start with '/PROG name'")
        for needed in ("MN", "END"):
            if needed not in names:
                raise self.error(len(self.text), f"no /{needed} section: the listing is incomplete")
        if names.count("MN") > 1 or names.count("POS") > 1:
            raise self.error(found[names.index("MN", 1) if names.count("MN") > 1 else names.index("POS", names.index("POS") + 1)][1], "a section is given twice")
        end_at = found[names.index("END")]
        rest = self.text[end_at[2] :].strip()
        if rest:
            raise self.error(end_at[2] + self.text[end_at[2] :].index(rest[0]), "text after /END: the controller reads nothing there")
        out = {}
        for k, (name, _, head_end) in enumerate(found):
            nxt = found[k + 1][1] if k + 1 < len(found) else len(self.text)
            out[name] = (head_end, nxt)
        return out

    # ---------------------------------------------------------------- statements
    def _statement(self, st: Statement) -> bool:
        """Read one statement; True where it changes the flow (jump, call)."""
        body = st.text
        stripped = body.strip()
        if not stripped or stripped.startswith(("!", "//")):
            return False
        m = _MOTION.match(body)
        if m:
            self._motion(st, m)
            return False
        m = _FRAME_NUM.match(body)
        if m:
            value = m.group(2)
            number = int(value) if value.isdigit() else None  # UFRAME_NUM=R[1]: not known from the text
            if m.group(1).upper() == "UFRAME_NUM":
                self.uframe = number if number is not None else -1
            else:
                self.utool = number if number is not None else -1
            return False
        if _BAD_FRAME.match(body):
            raise self.error(st.start, "not a TP statement: UFRAME_NUM=n / UTOOL_NUM=n select a frame, UFRAME[n]=... / UTOOL[n]=... set one")
        m = _FRAME_SET.match(body)
        if m:
            self.redefined[f"{m.group(1).upper()}[{int(m.group(2))}]"] = int(self.lines.line(st.start))
            return False
        return bool(_FLOW.match(body))

    def _motion(self, st: Statement, m: re.Match) -> None:
        motion = m.group(1).upper()
        rest = m.group(4)
        rest_at = st.start + m.start(4)
        if motion == "C":
            end = _VIA_END.match(rest)
            if end is None:
                raise self.error(rest_at, "a C motion gives its end point on the next line (': P[n] speed FINE|CNT'): none here")
            via_options = self._options(end.group(1), rest_at, int(self.lines.line(rest_at)))  # e.g. Tool_Offset,PR[28] on the via point
            self._target(st, "C", m.group(2), m.group(3), st.start + m.start(2), end.group(4), rest_at + end.start(4), Kind.CIRC_VIA, via_options)
            self._target(st, "C", end.group(2), end.group(3), rest_at + end.start(2), end.group(4), rest_at + end.start(4), Kind.CIRC_END)
            return
        kind = {"J": Kind.JOINT, "L": Kind.LINEAR, "A": Kind.LINEAR}[motion]
        self._target(st, motion, m.group(2), m.group(3), st.start + m.start(2), rest, rest_at, kind)

    def _target(self, st: Statement, motion: str, reg: str, number: str, at: int, rest: str, rest_at: int, kind: Kind, own: list[str] = ()) -> None:
        """One target row; ``rest``: the speed, FINE/CNT and options that follow it (a C
        motion's via point shares its end's; ``own``: why its own options make it unknown)."""
        line = int(self.lines.line(at))
        speed_m = _SPEED.match(rest)
        if speed_m is None:
            raise self.error(rest_at, f"a {motion} motion needs its speed (e.g. 100%, 500mm/sec) after the position")
        term = _TERM.match(rest, speed_m.end())
        if term is None:
            raise self.error(rest_at + speed_m.end(), "a motion needs FINE or CNTn after its speed")
        unknown = list(own) + self._options(rest[term.end() :], rest_at + term.end(), line)
        if kind != Kind.JOINT and self.flow_line is not None:
            unknown.append(f"the posture the robot keeps here is that of the motion run before it, which depends on the jump, call or label at "
                           f"line {self.flow_line} (postproc does not follow the program's flow)")
        elif kind == Kind.JOINT and reg.upper() == "P" and number.isdigit():
            self.flow_line = None  # its CONFIG sets the posture again
        wrist = WRIST in unknown
        unknown = [why for why in unknown if why != WRIST]
        cnt = term.group(2)
        self.seq += 1  # program order: a statement a loop runs again gives its targets again, later
        row = {"kind": kind, "line": line, "order": self.seq, "motion": motion, "speed": _speed(speed_m), "zone": 0.0 if term.group(1).upper() == "FINE" else np.nan,
               "cnt": -1.0 if cnt is None else float(cnt) if cnt.isdigit() else np.nan, "notes": unknown, "off_line": wrist or motion == "A"}
        if reg.upper() == "PR" or not number.isdigit():
            row["notes"] = unknown + [f"{reg}[{number}] holds a value set outside the program"]
            row["pos"] = -1  # a register is used in the frame and tool selected when it runs
            row["frame"], row["tool"] = self._frame(self.uframe, "UFRAME"), self._frame(self.utool, "UTOOL")
            self.rows.append(row)
            return
        k = self.positions.row_of.get(int(number))
        if k is None:
            raise self.error(at, f"P[{number}] is not in /POS: the controller has no value for it")
        table = self.positions
        uf, ut = int(table.uf[k]), int(table.ut[k])
        row["pos"], row["number"] = k, int(number)
        row["notes"] = row["notes"] + self._frame_mismatch(int(number), uf, ut)
        row["frame"] = self._frame(uf if uf >= 0 else self.uframe, "UFRAME")
        row["tool"] = self._frame(ut if ut >= 0 else self.utool, "UTOOL")
        if table.state[k] == UNTAUGHT:
            row["notes"] = row["notes"] + ["the position was never taught ('********'): the controller has no value for it and stops"]
        elif table.state[k] == NO_GROUP_1:
            row["notes"] = row["notes"] + ["the position holds no group 1 (robot) value: it moves other groups only"]
        elif table.groups[k]:
            row["notes"] = row["notes"] + [f"the position also moves group {', '.join(map(str, table.groups[k]))} (a positioner or rail), which postproc does not model"]
        if not np.isnan(table.values[k, F_EXT]).all():
            row["notes"] = row["notes"] + ["the position moves extended axes E1.. of group 1 (a rail or a turntable integrated with the arm), which postproc does not model"]
        if table.joint[k] and kind == Kind.JOINT:
            row["kind"] = Kind.ABSJ
        elif table.joint[k]:
            row["notes"] = row["notes"] + [f"a {motion} motion to a joint position: postproc reads joint positions for J motions only"]
        self.rows.append(row)

    def _options(self, text: str, at: int, line: int) -> list[str]:
        """Why the options after FINE/CNT make the target unknown (none: []; WRIST for Wjnt)."""
        why = []
        pos = 0
        while True:
            pos = _GAP.match(text, pos).end()
            if pos >= len(text):
                return why
            for pattern, reason in _OPTIONS:
                m = pattern.match(text, pos)
                if m:
                    break
            else:
                raise self.error(at + pos, f"motion option '{text[pos:].split()[0]}' is not one postproc reads (R-30iB manual, 'Motion instruction options')")
            if reason is not None:
                why.append(reason)  # (WRIST too: the caller takes it out)
            pos = m.end()

    def _frame_mismatch(self, number: int, uf: int, ut: int) -> list[str]:
        """Why the target's frame is not known where the position's UF / UT differ from the
        numbers in force: the controller then stops with a frame mismatch alarm, unless
        $MCR.$UFRCHK (a system variable, not in the program) turns the check off and it runs
        the position in the frame in force."""
        out = []
        for what, have, want in (("UFRAME_NUM", self.uframe, uf), ("UTOOL_NUM", self.utool, ut)):
            if have is not None and have >= 0 and want >= 0 and have != want:
                out.append(f"P[{number}] is taught in {what[:-4]} {want} but {what}={have} is in force: the controller stops with a "
                           "frame mismatch alarm (or, with $MCR.$UFRCHK off, runs it in the other frame)")
        return out

    # -------------------------------------------------------------------- rows
    def _add_rows(self) -> None:
        rows, table = self.rows, self.positions
        n = len(rows)
        if not n:
            return
        self.rows = []
        pidx = np.array([r["pos"] for r in rows], dtype=np.int64)
        has = pidx >= 0
        k = pidx[has]
        values = np.full((n, NF), np.nan)
        spans = np.full((n, NF, 3), -1, dtype=np.int64)
        offset = np.zeros((n, NF))
        conf = np.full((n, 4), np.nan)
        values[has], conf[has] = table.values[k], table.conf[k]
        spans[has, :, 1:] = table.spans[k]
        spans[has, :, 0] = np.where(table.spans[k, :, 0] >= 0, self.k, -1)  # every number is in the program's own file
        joint = np.zeros(n, dtype=bool)
        joint[has] = table.joint[k]
        offset[joint, J3] = values[joint, J2]  # J2/J3 interaction: the robot file's J3 = J3 + J2 (the text keeps J3)
        values[joint, J3] += values[joint, J2]
        frame = np.array([r.get("frame", 0) for r in rows], dtype=np.int32)
        tool = np.array([r.get("tool", 0) for r in rows], dtype=np.int32)
        resolved = has & np.array([not r["notes"] for r in rows], dtype=bool)
        reasons: dict[str, list[int]] = {}  # why a target is unresolved -> the lines of those targets
        for r in rows:
            for why in r["notes"]:
                reasons.setdefault(why, []).append(r["line"])
        for why, lines in reasons.items():  # one note per reason: a welding program repeats one on every line
            more = f" (and {len(lines) - 1} more targets, the last at line {lines[-1]})" if len(lines) > 1 else ""
            self.notes.append(f"{self.doc.path}:{lines[0]}: {why}{more}")
        self.builder.add_block(np.array([r["order"] for r in rows], dtype=np.int64), kind=np.array([r["kind"] for r in rows], dtype=np.int8),
                               line=np.array([r["line"] for r in rows], dtype=np.int32), values=values, spans=spans, offset=offset, conf=conf,
                               speed=np.array([r["speed"] for r in rows], dtype=float), zone=np.array([r["zone"] for r in rows], dtype=float),
                               resolved=resolved, frame=frame, tool=tool, file=np.full(n, self.k, dtype=np.int16), **{CNT: np.array([r["cnt"] for r in rows], dtype=float), OFF_LINE: np.array([r["off_line"] for r in rows], dtype=bool)},
                               name=np.array([f"P[{r['number']}]" if r["pos"] >= 0 else "" for r in rows], dtype=object))

    def _frame(self, number: int | None, table: str) -> int:
        """Index of user frame / tool ``number`` (0: world / faceplate, known); None or -1:
        the number in force is not known from the program."""
        add = self.builder.frame_index if table == "UFRAME" else self.builder.tool_index
        if number == 0:
            return 0
        if number is None or number < 0:
            return add(f"{table}_NUM", None)
        name = f"{table}[{number}]"
        since = self.redefined.get(name)
        return add(name if since is None else f"{name}@line{since}", None)  # set by UFRAME[n]=... at that line


def _speed(m: re.Match) -> float:
    """mm/s of a TCP speed (NaN: %, sec, deg/sec or a register: no TCP speed from the text)."""
    unit = (m.group(2) or "").upper()
    if unit not in SPEED_TO_MM_S or not m.group(1)[0].isdigit() and m.group(1)[0] != ".":
        return np.nan
    return float(m.group(1)) * SPEED_TO_MM_S[unit]

