"""Klartext (Heidenhain TNC conversational) to the IR, executed as the TNC runs it.

Rules, each from the TNC 640 User's Manual (Klartext programming), by section:
- "Path contours - Cartesian coordinates": L X Y Z A B C (absolute; I.. incremental from the
  previous position), modal axis values; C X Y DR+/DR- a circle about the pole CC (DR+
  counterclockwise); CR X Y R DR a circle of radius R (R+ at most 180 degrees, R- more); CT a
  circle tangent to the previous element; CC without coordinates: the last position.
- "Path contours - polar coordinates": LP PR PA / CP PA DR about the pole CC, PA from the
  +X axis (tool axis Z), counterclockwise positive; IPR / IPA incremental; CP keeps the
  distance from the pole.
- "Feed rate F": F is modal; FMAX (rapid traverse) acts only in its own block; M103 F (a
  plunging feed factor) and F in an INCH program (its unit) are refused.
- "Radius compensation": RL/RR move the tool by its radius beside the contour; the path then
  depends on the tool table's radius, which the text does not give: such targets are read
  as programmed and flagged unresolved (never guessed).
- "Subprograms and program-section repeats": LBL n ... CALL LBL n REP k runs the section k
  more times; CALL LBL n without REP runs LBL n to LBL 0 and returns; FN 9..12 IF .. GOTO
  LBL jump; M2/M30 and END PGM end the run.
- "Q parameters" (qparams.py); FN 18 SYSREAD gives values the text does not determine.
- "Cycles for coordinate transformation", Cycle 7 DATUM SHIFT: absolute values from the
  workpiece preset, incremental from the shift in force; #n (datum table) is on the control.
- "Tool call": TOOL CALL n Z S DL DR; the tool length is in the control's tool table (TOOL
  DEF n L R in the program defines it, TNC 4xx programs), DL is added to it.
- "PLANE SPATIAL": the working plane turned by SPA about X, then SPB about Y, then SPC about Z
  (fixed axes), about the datum in force: a frame; its rotary solution (SEQ, MOVE/TURN/STAY)
  is the TNC's, so its targets stay flagged. Cycle 19's angles are axis or spatial angles as
  the machine parameters say: flagged.
- "Miscellaneous functions for rotary axes": M128 / FUNCTION TCPM keep the tool tip at the
  programmed X Y Z while the rotary axes turn (rotary words are axis positions with AXIS POS);
  M126 takes the shortest way round (the end angle is the programmed one).
Targets whose position depends on what the text does not determine (radius compensation,
tilted working plane, machining cycles, values read from the control) are kept, flagged
unresolved, with a note: inspect shows them, compensate refuses them by file:line:column.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np

from postproc.errors import ParseError

from ...ir import F_ARC, FIELDS, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from ...parse.line_shapes import LineMatches
from . import radius_comp
from .blocks import Block, PlainRun, split_blocks
from .bulk import BulkReading
from .contours import Contours
from .cycles import StateBlocks
from .fields import AXES, COLUMNS, SIDE
from .plane_solution import plane_extras
from .qparams import ASSIGN_RE, FN_RE, FormulaError, evaluate, fn_as_formula
from .words import PathWords, WordError, read_words

MAX_BLOCKS_RUN = 50_000_000  # a loop that never ends is refused at its jump, not run forever
_PATH = re.compile(r"(LN|LP|L|CC|CR|CT|CP|C)(?![A-Z])", re.IGNORECASE)
_REFUSED_STATEMENTS = {
    "APPR": "approach contour (APPR): the path the TNC builds depends on the tool radius; not read",
    "DEP": "departure contour (DEP): the path the TNC builds depends on the tool radius; not read",
    "RND": "corner rounding (RND): the arc the TNC inserts is not read",
    "CHF": "chamfer (CHF): the corner the TNC cuts is not read",
    "FL": "FK free contour programming: not read", "FC": "FK free contour programming: not read",
    "FPOL": "FK free contour programming: not read", "FCT": "FK free contour programming: not read",
    "FLT": "FK free contour programming: not read",
    "CALL PGM": "CALL PGM runs another program file, which is not read",
    "SEL PGM": "SEL PGM selects another program file, which is not read",
    "SPL": "spline blocks (SPL) are not read",
}


class KlartextReader(BulkReading, Contours, StateBlocks):
    """One run of a Klartext program: the state the TNC keeps, block by block."""

    def __init__(self, doc: SourceDoc, dialect: str = "heidenhain"):
        self.doc = doc
        self.text = doc.text
        self.lines = LineIndex(doc.text)
        self.b = Builder(dialect, "none", [doc], tool_names=["<none>"], frame_names=["PRESET"], frame_known=[False])
        self.plain: LineMatches | None = None
        self.blocks = split_blocks(doc.text, self._plain_lines())
        self.labels = self._labels()
        self.q: dict[str, float] = {}
        self.q_origin: dict[str, int] = {}  # parameter -> line where it became unknown (FN 18)
        self.scale = 1.0  # mm per program unit
        self.feed_scale = 1.0
        self.pos = np.full(6, np.nan)  # X Y Z A B C, program frame
        self.unknown = np.zeros(6, bool)  # the value came from a parameter the text does not determine
        self.feed = math.nan
        self.feed_unknown = False
        self.pole = np.full(2, np.nan)
        self.polar = [math.nan, math.nan]  # last PR, PA
        self.tangent = None  # direction (unit XY) at the end of the last contour element (CT)
        self.comp = "R0"
        self.comp_line = 0
        self.tool = 0
        self.radius = math.nan  # compensation value of the tool in force (R + DR), mm; NaN: not in the program
        self.tool_radius: dict[str, float] = {"T0": 0.0}  # TOOL DEF n R.. (T0: the zero tool, L=0 R=0)
        self.ln_deltas_zero = False  # the tool in force has no delta values (LN then moves to X Y Z as written)
        self.frame = ("PRESET", None)  # (name, transform on the preset): registered when a target uses it
        self.shift = np.zeros(3)
        self.tilt_line = 0  # line of the tilting (PLANE / CYCL DEF 19) in force, 0: none
        self.tilt: np.ndarray | None = None  # its rotation where the text gives it (PLANE SPATIAL)
        self.tcpm = False
        self.planes: dict[int, tuple[int, str, bool]] = {}  # PLANE line -> (SEQ +1/-1/0, MOVE/TURN/STAY, a DIST or feed given after it)
        self.positioning_rows: set[int] = set()  # rows of PLANE ... MOVE/TURN: the TNC turns the rotary axes there
        self.notes: dict[str, None] = {}
        self.numbers = None  # every number of the text, scanned once when a plain run needs it
        self.segments: list[tuple[np.ndarray, np.ndarray]] = []  # (rows table, cells) read in bulk, in order with the rows
        self.rows_before = 0  # rows already moved into segments
        self.rows: list[tuple] = []  # per target: the COLUMNS
        self.cells: list[tuple] = []  # per number read: row, field, value, start, end (-1: not a plain number)
        self.cycle_defined = 0  # line of the last machining cycle defined (CYCL DEF n, not 7/19/32/9)
        self.cycl7_line = 0
        self.tolerance_line = 0

    # ------------------------------------------------------------- driver
    def _labels(self) -> dict[str, int]:
        out = {}
        for i, blk in enumerate(self.blocks):
            if isinstance(blk, PlainRun) or blk.text[:3].upper() != "LBL":
                continue
            m = re.match(r"\s*LBL\s*(\d+|\"[^\"]*\"|\S+)\s*$", blk.text, re.IGNORECASE)
            if m:
                out.setdefault(m.group(1).upper(), i)
        return out

    def error(self, offset: int, message: str) -> ParseError:
        return self.lines.error(self.doc.path, offset, message)

    def _require_frame(self) -> None:
        """A program opens with BEGIN PGM and closes with END PGM (TNC 640 manual,
        "Programming fundamentals": the control writes both; a file without them is cut off
        or not a Klartext program)."""
        texts = [(b.text, b.start) for b in self.blocks if isinstance(b, Block)]
        if not texts or not texts[0][0].upper().startswith("BEGIN PGM"):
            raise self.error(texts[0][1] if texts else 0, "a Klartext program starts with BEGIN PGM name MM|INCH")
        if not (isinstance(self.blocks[-1], Block) and self.blocks[-1].text.upper().startswith("END PGM")):
            raise self.error(len(self.text.rstrip()), "the program ends without END PGM (cut off?): the TNC runs a program only whole")

    def run(self) -> Toolpath:
        self._require_frame()
        pc, stack, repeats, executed, last_jump = 0, [], {}, 0, 0
        blocks = self.blocks
        while pc < len(blocks):
            executed += 1
            if executed > MAX_BLOCKS_RUN:
                raise self.error(blocks[last_jump].start, f"more than {MAX_BLOCKS_RUN} blocks run: the program's jumps do not end (the last jump is here)")
            blk = blocks[pc]
            if isinstance(blk, PlainRun):
                self.plain_run(blk)
                pc += 1
                continue
            jump = self.block(blk, pc)
            if jump is None:
                pc += 1
            elif jump == "end":
                break
            else:
                kind, arg = jump
                last_jump = pc
                if kind == "goto":
                    pc = arg
                elif kind == "call":
                    stack.append(pc + 1)
                    pc = arg
                    if len(stack) > 8:  # TNC 640 manual: subprograms nest up to 8 levels (19 on newer)
                        raise self.error(blk.start, "subprogram calls nested deeper than 8")
                elif kind == "return":
                    if stack:
                        pc = stack.pop()
                    else:
                        pc += 1
                elif kind == "repeat":
                    label, count = arg
                    left = repeats.get(pc, count)
                    if left > 0:
                        repeats[pc] = left - 1
                        pc = label
                    else:
                        repeats.pop(pc, None)
                        pc += 1
        return self.build()

    # ------------------------------------------------------------- blocks
    def block(self, blk: Block, index: int):
        s = blk.text.lstrip()
        at = blk.start + len(blk.text) - len(s)
        head = s.split(None, 1)[0].upper() if s.split() else ""
        m = _PATH.match(s)
        if m and (len(s) == m.end() or not s[m.end()].isalnum() or m.group(1).upper() in ("L", "C") and s[m.end()] in "+- "):
            return self.path_block(blk, m.group(1).upper(), at, m.end())
        up = s.upper()
        if up.startswith(("BEGIN PGM", "END PGM")):
            return self.pgm(blk, up, at)
        if up.startswith("BLK FORM") or up.startswith("STOP") or up.startswith(("FN 15", "FN15", "FN 16", "FN16")):
            return None  # workpiece blank for the graphics; program stop; printing: no motion
        if up.startswith("TOOL DEF"):
            return self.tool_def(s, at)
        if up.startswith("TOOL CALL"):
            return self.tool_call(s, at, blk.line)
        if up.startswith(("CYCL DEF", "CYCLE DEF")):
            return self.cycle_def(s, at, blk.line)
        if up.startswith("CYCL CALL"):
            return self.cycle_call(at, blk.line)
        if up.startswith("PLANE"):
            return self.plane(s, at, blk.line)
        if up.startswith("FUNCTION"):
            return self.function(s, at, blk.line)
        if up.startswith("LBL"):
            return ("return", None) if re.match(r"LBL\s*0\s*$", up) else None
        if up.startswith("CALL LBL"):
            return self.call_label(s, at)
        if re.match(r"FN\s*(9|10|11|12)\s*:", up):
            return self.conditional(s, at)
        if re.match(r"FN\s*\d+\s*:", up) or re.match(r"Q[LR]?\d+\s*=", up):
            return self.assign(s, at, blk.line)
        if re.match(r"M\d", up):
            words = self.words(s, at, 0)
            return self.m_functions(words, blk.line, at)
        for key, why in _REFUSED_STATEMENTS.items():
            if up.startswith(key) and (len(up) == len(key) or not up[len(key)].isalpha()):
                raise self.error(at, why)
        raise self.error(at, f"'{head}' is not a Klartext block this reader knows")

    def words(self, s: str, at: int, start: int) -> PathWords:
        try:
            return read_words(s, start, at)
        except WordError as exc:
            raise self.error(exc.at, str(exc)) from None

    def pgm(self, blk: Block, up: str, at: int):
        if up.startswith("END PGM"):
            return "end"
        unit = up.split()[-1]
        if unit == "INCH":
            # positions in inches; the feed's inch unit is not read (refused at the first F: feed_scale NaN)
            self.scale, self.feed_scale = 25.4, math.nan
        elif unit != "MM":
            raise self.error(at + len(blk.text.lstrip()) - len(unit), "BEGIN PGM needs the unit MM or INCH at its end")
        return None

    def call_label(self, s: str, at: int):
        m = re.match(r"CALL LBL\s*(\d+|\"[^\"]*\"|\S+)(?:\s+REP\s*(\d+)(?:\s*/\s*\d+)?)?\s*$", s, re.IGNORECASE)
        if not m:
            raise self.error(at, "CALL LBL needs a label (and REP count)")
        label = m.group(1).upper()
        if label not in self.labels:
            raise self.error(at, f"label {m.group(1)} is not in the program")
        if m.group(2) is not None:
            return ("repeat", (self.labels[label] + 1, int(m.group(2))))
        return ("call", self.labels[label] + 1)

    def conditional(self, s: str, at: int):
        m = re.match(r"FN\s*(9|10|11|12)\s*:\s*IF\s+(.+?)\s+(EQU|NE|GT|LT)\s+(.+?)\s+GOTO\s+LBL\s*(\S+)\s*$", s, re.IGNORECASE)
        if not m:
            raise self.error(at, "FN 9..12 needs IF a EQU|NE|GT|LT b GOTO LBL n")
        a, used_a = self.value(m.group(2), at + m.start(2))
        b, used_b = self.value(m.group(4), at + m.start(4))
        if math.isnan(a) or math.isnan(b):
            raise self.error(at, f"the jump depends on {self.unknown_cause(used_a + used_b)}: the program's flow is not determined by its text")
        take = {"EQU": a == b, "NE": a != b, "GT": a > b, "LT": a < b}[m.group(3).upper()]
        label = m.group(5).upper()
        if label not in self.labels:
            raise self.error(at + m.start(5), f"label {m.group(5)} is not in the program")
        return ("goto", self.labels[label] + 1) if take else None

    def unknown_cause(self, used: list[str]) -> str:
        names = [u for u in used if math.isnan(self.q.get(u, math.nan))]
        parts = [f"{u} (read from the control by FN 18 at line {self.q_origin[u]})" if u in self.q_origin else f"{u} (never set in this program)" for u in dict.fromkeys(names)]
        return ", ".join(parts) or "a value the text does not determine"

    def value(self, text: str, at: int) -> tuple[float, list[str]]:
        try:
            return evaluate(text, self.q)
        except FormulaError as exc:
            raise self.error(at + exc.at, str(exc)) from None

    def assign(self, s: str, at: int, line: int):
        sysread = re.match(r"FN\s*18\s*:\s*SYSREAD\s+(Q[LR]?\d+)\s*=", s, re.IGNORECASE)
        if sysread:  # a value of the running control (TNC 640 manual, "FN 18: SYSREAD"): not in the text
            self.q[sysread.group(1).upper()] = math.nan
            self.q_origin[sysread.group(1).upper()] = line
            return None
        m = FN_RE.match(s)
        if m:
            number = int(m.group(1))
            try:
                rhs = fn_as_formula(number, m.group(3), 0)
            except FormulaError as exc:
                raise self.error(at, str(exc)) from None
            self.q[m.group(2).upper()] = self.value(rhs if number else m.group(3), at + m.start(3))[0]
            return None
        if re.match(r"FN\s*(14)\s*:", s, re.IGNORECASE):
            raise self.error(at, "FN 14 ERROR: the program stops here with an error message")
        if re.match(r"FN\s*\d+\s*:", s, re.IGNORECASE):
            raise self.error(at, f"{s.split(':')[0].strip()} is not read (it reads or writes the control's data)")
        m = ASSIGN_RE.match(s)
        name = m.group(1).upper()
        v, used = self.value(m.group(2), at + m.start(2))
        self.q[name] = v
        self.q_origin.pop(name, None)
        from_control = [u for u in used if u in self.q_origin]
        if math.isnan(v) and from_control:  # unknown because of an FN 18 value: say which
            self.q_origin[name] = self.q_origin[from_control[0]]
        return None

    def m_functions(self, words: PathWords, line: int, at: int):
        for number, where in words.m:
            if number in (2, 30):
                return "end"
            if number == 128:
                self.tcpm = True
                self.notes["M128: rotary words are axis positions, X Y Z the tool tip (TNC 640 manual, M128)"] = None
            elif number == 129:
                self.tcpm = False
            elif number == 126:
                self.notes["M126: rotary axes take the shortest way to the programmed angle (TNC 640 manual, M126); the end angles are the programmed ones"] = None
            elif number in (99, 89):
                if self.cycle_defined:
                    self.unresolved_row(line, where, f"line {line}: M{number} runs the machining cycle defined at line {self.cycle_defined}: its moves are not read")
            elif number in (91, 92):
                pass  # handled on the motion (machine datum)
            elif number == 103:
                raise self.error(where, "M103 F: the TNC lowers the plunging feed by a factor (TNC manual, M103): not read")
            elif number == 140:
                raise self.error(where, "M140 retracts along the tool axis to a distance the text does not give (MB): not read")
        return None

    # ------------------------------------------------------------- motion
    def path_block(self, blk: Block, kind: str, at: int, keyword_end: int):
        words = self.words(blk.text.lstrip(), at, keyword_end)
        line = blk.line
        self._feed(words)
        if words.comp is not None:
            self.comp, self.comp_line = words.comp, line
        machine_datum = any(n in (91, 92) for n, _ in words.m)
        if any(n == 128 for n, _ in words.m):
            self.tcpm = True  # M128 acts from the start of its block, M129 at its end (TNC 640 manual, M functions)
        if kind == "CC":
            self.set_pole(words, at)
            return self.m_functions(words, line, at)
        start = self.pos.copy()
        vals: dict[int, float] = {}  # field -> value of the block's own words (and arc data)
        spans: dict[int, tuple[int, int, int]] = {}  # field -> (source, start, end) of a plain number
        arc = None
        if kind in ("L", "LN"):
            moved = self.cartesian(words, vals, spans, at)
            if kind == "LN":
                self.ln_note(line)
        elif kind in ("C", "CR", "CT"):
            moved = self.cartesian(words, vals, spans, at)
            arc = self.circle(kind, words, start, vals, spans, at)
        else:  # LP, CP
            moved = self.polar_move(kind, words, start, vals, spans, at)
            if kind == "CP":
                arc = "CP"
        if not moved and not words.m:
            return None
        if moved or kind != "L":
            self.row(kind, words, vals, spans, line, at, arc, machine_datum, start)
        return self.m_functions(words, line, at)

    def ln_note(self, line: int) -> None:
        """LN X Y Z NX NY NZ (TX TY TZ): X Y Z are the compensated end point; the TNC moves the tool
        along N by the sum of the delta values (tool table and TOOL CALL), and under M128 / TCPM
        turns the rotary axes to T (or perpendicular to the surface without T); without M128 T is
        ignored (TNC 640 manual, "Three-dimensional tool compensation")."""
        if self.tcpm:
            self.notes[f"line {line}: LN under M128 / TCPM: the TNC turns the rotary axes to the tool orientation T (or normal to the surface), "
                       "a solution of its own: not read"] = None
        elif not self.ln_deltas_zero:
            self.notes[f"line {line}: LN: the TNC moves the tool along N by the tool's delta values (tool table and TOOL CALL), which the text "
                       "does not give (a tool from the tool table) or are not zero: not read"] = None
        else:
            self.notes["LN without M128: the tool moves to X Y Z (no delta values: TOOL DEF tool, no DL / DR / DR2); N and T change nothing "
                       "(TNC 640 manual, three-dimensional tool compensation)"] = None

    def _feed(self, words: PathWords) -> None:
        if words.feed_other:
            key, where = words.feed_other
            raise self.error(where, f"{key}: a feed from the tool table or per revolution / tooth, which the text does not give in mm/min")
        if words.feed is not None:
            if math.isnan(self.feed_scale):
                raise self.error(words.feed.start, "F in an INCH program: its unit is not read (give the program in MM)")
            self.feed = self.value(words.feed.text, words.feed.start)[0] * self.feed_scale

    def cartesian(self, words: PathWords, vals, spans, at: int) -> bool:
        moved = False
        for letter, k in AXES.items():
            w = words.words.get(letter)
            if w is None:
                continue
            v = float(w.text) if w.plain else self.value(w.text, w.start)[0]
            i = "XYZABC".index(letter)
            unit = self.scale if i < 3 else 1.0
            v *= unit
            new = self.pos[i] + v if w.incremental else v
            self.unknown[i] = math.isnan(v)
            self.pos[i] = new
            moved = True
            if w.plain and not w.incremental:
                vals[k] = new
                spans[k] = (0, w.start, w.end)
            else:
                vals[k] = new  # from a Q parameter or an increment: read, not rewritable in place (no span)
        for extra in ("U", "V", "W", "PR", "PA"):  # parallel axes; polar words belong to LP / CP
            if extra in words.words:
                raise self.error(words.words[extra].start, f"{extra} is not read in this block")
        return moved

    def unresolved_row(self, line: int, at: int, note: str) -> None:
        self.notes[note] = None
        self.add_row(int(Kind.RAPID), line, math.nan, False, -1, {}, {})

    def row(self, kind: str, words: PathWords, vals: dict, spans: dict, line: int, at: int, arc, machine_datum: bool, start) -> None:
        # values: the block's own words (NaN for modal axes it leaves out, which splice may add
        # at insert_at); the position and rotary angles in force are kept beside them
        rapid = words.rapid
        resolved = self._state_resolved(line, machine_datum)
        if rapid:
            k = Kind.RAPID
        elif arc is None:
            k = Kind.LINEAR
        else:
            dr = arc[2] if arc != "CP" else words.dr
            k = Kind.ARC_CCW if dr == "+" else Kind.ARC_CW
        if kind == "LN":
            resolved = resolved and self.ln_deltas_zero and not self.tcpm
        feed = math.nan if rapid else self.feed
        insert = at + len(kind) if kind in ("L", "LN") else -1
        self.add_row(int(k), line, feed, resolved, insert, vals, spans)
        self.tangent = self._tangent(k, start, arc)

    def _frame_index(self) -> int:
        """The frame of the next target: the preset, the datum shift on it, a PLANE SPATIAL
        tilt about the shifted datum (TNC 640 manual: Cycle 7 before tilting shifts in the
        untilted system)."""
        name, transform = self.frame
        if self.tilt_line and self.tilt is not None:
            tilt = np.eye(4)
            tilt[:3, :3] = self.tilt
            if name == "PRESET":
                transform = tilt  # on the preset itself
            elif transform is not None:
                transform = transform @ tilt  # else: on a shift the text does not give, still unknown
            name = f"{name}+PLANE SPATIAL@line{self.tilt_line}"
        return 0 if name == "PRESET" else self.b.frame_index(name, transform, False)

    def _state_resolved(self, line: int, machine_datum: bool) -> bool:
        """False (with a note) where the modal state leaves the position to what the text does not give."""
        resolved = True
        if self.comp in ("RL", "RR") and math.isnan(self.radius):
            resolved = False
            self.notes[f"line {self.comp_line}: radius compensation {self.comp}: the TNC cuts beside the contour by the tool table's radius, which the text does not give "
                       "(TOOL DEF n L.. R.. in the program gives it); those targets are read as programmed"] = None
        if self.tilt_line:
            resolved = False
            self.notes[f"line {self.tilt_line}: tilted working plane: positions are in the tilted plane, whose rotary-axis solution (SEQ+/SEQ-) is the TNC's: not read"] = None
        if machine_datum:
            resolved = False
            self.notes[f"line {line}: M91/M92: coordinates in the machine datum, which the text does not give"] = None
        if self.unknown.any():
            resolved = False
            self.notes[f"line {line}: position from a Q parameter the text does not determine"] = None
        return resolved

    def rows_all(self) -> int:
        """Rows read so far, in segments and in the row list."""
        return self.rows_before + len(self.rows)

    def add_segment(self, table: np.ndarray, cells: np.ndarray) -> None:
        self._flush()
        self.segments.append((table, cells))
        self.rows_before += len(table)

    def _flush(self) -> None:
        if self.rows or self.cells:
            self.segments.append((np.array(self.rows, float).reshape(-1, COLUMNS), np.array(self.cells, float).reshape(-1, 5)))
            self.rows_before += len(self.rows)
            self.rows, self.cells = [], []

    def add_row(self, kind: int, line: int, feed: float, resolved: bool, insert: int, vals: dict, spans: dict) -> None:
        r = self.rows_all()
        p = self.pos
        self.rows.append((kind, line, feed, self.tool, self._frame_index(), resolved, insert, p[0], p[1], p[2], p[3], p[4], p[5], self.tcpm,
                          SIDE[self.comp], self.radius))
        for f, v in vals.items():
            self.cells.append((r, f, v) + (spans[f][1:] if f in spans else (-1, -1)))

    # ------------------------------------------------------------- IR
    def build(self) -> Toolpath:
        self._flush()
        table = np.concatenate([t for t, _ in self.segments]) if self.segments else np.zeros((0, COLUMNS))
        cells = np.concatenate([c for _, c in self.segments]) if self.segments else np.zeros((0, 5))
        n = len(table)
        kind = table[:, 0].astype(np.int8)
        rows, fields = cells[:, 0].astype(np.int64), cells[:, 1].astype(np.int64)
        values = np.full((n, len(FIELDS)), np.nan)
        values[rows, fields] = cells[:, 2]
        spans = np.full((n, len(FIELDS), 3), -1, np.int64)
        plain = cells[:, 3] >= 0
        spans[rows[plain], fields[plain]] = np.c_[np.zeros(int(plain.sum()), np.int64), cells[plain, 3:5].astype(np.int64)]
        arcs = (kind == Kind.ARC_CW) | (kind == Kind.ARC_CCW)
        scale = np.ones((n, len(FIELDS)))
        scale[:, :3] = self.scale
        scale[:, F_ARC] = self.scale
        insert = table[:, 6].astype(np.int64)
        block = dict(kind=kind, line=table[:, 1].astype(np.int32), values=values, spans=spans, scale=scale, speed=table[:, 2],
                     tool=table[:, 3].astype(np.int32), frame=table[:, 4].astype(np.int32), resolved=table[:, 5].astype(bool),
                     feed_mode=np.full(n, 94, np.int8), insert_at=np.stack([np.where(insert >= 0, 0, -1), insert], axis=1))
        if arcs.any():
            arc = np.full((n, 3), np.nan)
            arc[arcs] = (17, 1, 1)  # XY plane (tool axis Z), centre absolute, one turn
            block["arc"] = arc
        self.b.add_block(np.arange(n), **block)  # execution order (a repeated section comes again)
        self.b.notes.extend(self.notes)
        if self.tolerance_line:
            self.b.notes.append(f"line {self.tolerance_line}: CYCL DEF 32 TOLERANCE: the TNC smooths the path within the tolerance")
        tp = self.b.build(orientation=False)
        ext = tp.ext.copy()
        side, radius = table[:, 14], table[:, 15]
        ext[:, :3] = table[:, 10:13]
        tcpm = table[:, 13].astype(bool)
        resolved = tp.resolved & ~self._mixed_tcpm(tcpm, ext[:, :3], table[:, 1])
        extras = {"heidenhain.tcpm": tcpm, **plane_extras(self.planes, self.positioning_rows, tp.frame_names, tp.frame)}
        tp = replace(tp, position=table[:, 7:10].copy(), ext=ext, resolved=resolved, notes=tuple(self.b.notes), extras=extras)
        if ((side != 0) & ~np.isnan(radius)).any():  # RL / RR with the radius in the program: the path the TNC cuts
            tp = radius_comp.follow(tp, side, radius)
        return tp

    def _mixed_tcpm(self, tcpm: np.ndarray, angles: np.ndarray, lines: np.ndarray) -> np.ndarray:
        """(N,) targets with rotary positions but without M128 / TCPM in a program that uses it
        elsewhere: there X Y Z are not the tool tip (TNC 640 manual, M128), and a five-axis
        reading takes one meaning for the whole program: flagged, with a note."""
        mixed = ~tcpm & tcpm.any() & (np.nan_to_num(angles) != 0.0).any(axis=1)
        if mixed.any():
            self.b.notes.append(f"line {int(lines[np.argmax(mixed)])}: rotary axes turned without M128 / FUNCTION TCPM in a program that uses it elsewhere: "
                                "X Y Z there are not the tool tip; not read as five-axis")
        return mixed


def read_klartext(doc: SourceDoc) -> Toolpath:
    return KlartextReader(doc).run()
