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
from ...parse.common import Builder, LineIndex, scan_numbers
from ...parse.line_shapes import LineShapes
from .jobfile import DIGITS, NUM, JobFile, PositionState, as_arrays, c_numbers, read_job, section_lines

WORDS = ("MOVJ", "MOVL", "MOVC", "MOVS")
# The columns of a block of targets (bulk or read one by one) before they become the IR.
COLUMNS = ("order", "line", "word", "pulse", "values", "spans", "conf", "speed", "zone", "tool", "frame", "name", "resolved",
           "inform.pl", "inform.vj", "inform.pulses")
MOTION = re.compile(r"(MOVJ|MOVL|MOVC|MOVS|IMOV)[ \t]+(\S+)(.*)")
BULK_MOVE = re.compile(rf"(?P<word>MOV[JL]) (?P<name>C\d+)(?: (?P<vkey>VJ|V)=(?P<speed>{NUM}))?(?: PL=(?P<pl>\d))?\r?")
TAG = re.compile(r"(VJ|V|VR|VE|PL|CR|ACC|DEC)=(\S+)|(NWAIT)|(\+MOV[JLCS])[ \t]+(\S+).*|(UF#\(\d+\)|BF|RF|TF|UNTIL\b.*|(?:BC|EC)\d+)|(\S+)")
# Instructions after which positions are moved by values the job's text does not give:
# SFTON shifts every move until SFTOF; MFRAME redefines a user frame, SETTOOL a tool file.
CHANGING = {"SFTON": "shift", "SFTOF": "shift", "MFRAME": "user frame", "SETTOOL": "tool"}
# Program flow: postproc lists each motion once, in the order of the text.
FLOW = {"JUMP", "CALL", "WHILE", "FOR", "IFTHEN", "IFTHENEXP", "SWITCH", "RET"}
# Where execution may arrive from elsewhere than the line before: a label (*NAME), the end or
# the other branch of a block (INFORM manual, "JUMP", "*label", "WHILE/ENDWHILE", "IFTHEN/ELSE/ENDIF")
FLOW_TARGETS = ("*", "ENDWHILE", "ENDFOR", "ELSE", "ELSEIFEXP", "ENDIF", "ENDSWITCH", "CASE", "DEFAULT")
_HAS_FLOW = re.compile(r"^[ \t]*(?:JUMP|CALL|WHILE|FOR|IFTHEN|SWITCH|RET|\*)|\bIF\b", re.MULTILINE)
CARTESIAN = ("ROBOT", "BASE", "USER")
# What only INFORM has, per target (Toolpath.extras): the positioning level PL (-1: none
# written), the joint speed VJ (% of the maximum), the encoder pulses of a pulse position.
EXTRAS = (("inform.pl", np.int8, -1, ()), ("inform.vj", float, np.nan, ()), ("inform.pulses", float, np.nan, (6,)))
# RECTAN numbers -> IR fields: X Y Z, then Rx Ry Rz into C B A (o3 o2 o1)
RECTAN_FIELDS = np.array([FIELDS.index(f) for f in ("x", "y", "z", "o3", "o2", "o1")])
JOINT_FIELDS = np.array([FIELDS.index(f"j{i}") for i in range(1, 7)])


class InformParser:
    def __init__(self, sources: list[SourceDoc]):
        self.doc = sources[0]
        self.path = self.doc.path
        self.lines = LineIndex(self.doc.text)
        self.builder = Builder("inform", "abc", list(sources))
        for name, dtype, fill, shape in EXTRAS:
            self.builder.declare_extra(name, dtype, fill, shape)
        self.rows: list[dict] = []

    def parse(self) -> Toolpath:
        text = self.doc.text
        self.raw = raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
        numbers = scan_numbers(text, raw=raw)
        shapes = LineShapes(text, raw, self.lines.starts)
        moves = self._bulk_moves(shapes, text)
        job = read_job(text, self.path, self.lines, shapes, numbers, moves.line if moves is not None else np.zeros(0, np.int64))
        self.job, self.table = job, as_arrays(job.positions)
        self._require_end(job, moves.line if moves is not None else np.zeros(0, np.int64))
        self.played_in = played_frame(job)
        self.on_base_axis = on_base_axis(job)
        self._slow_moves(job)
        block = self._bulk_block(moves, numbers) if moves is not None and len(moves) else None
        return self._build(block)

    def _require_end(self, job: JobFile, bulk_lines: np.ndarray) -> None:
        """A job ends at its END (INFORM manual, END): a job without one is cut short, and
        nothing may follow it (the controller never runs it)."""
        ends = [(line, start) for line, start, text in job.instructions if text.strip().upper() == "END"]
        if not ends:
            raise self.lines.error(self.path, len(self.doc.text), "no END: the job is cut short (an INFORM job ends with END)")
        end_line = ends[0][0]
        after = [start for line, start, text in job.instructions if line > end_line and text.strip()]
        late = bulk_lines[bulk_lines + 1 > end_line]
        if after or late.size:
            at = min(after + [int(self.lines.starts[late[0]])] if late.size else after)
            raise self.lines.error(self.path, at, f"after the END on line {end_line}: the controller never runs it")

    # ------------------------------------------------------------ bulk motions
    def _bulk_moves(self, shapes: LineShapes, text: str):
        """Plain MOVJ / MOVL lines after //INST (None where the job has instructions that
        move positions, whose order the one-by-one reading follows)."""
        if any(word in text for word in ("SFTON", "MFRAME", "SETTOOL")) or _HAS_FLOW.search(text, text.find("//INST")):
            return None  # (a jump or a label: the one-by-one reading marks what the flow leaves open)
        _, inst_line = section_lines(text, self.lines)
        if inst_line < 0:
            return None
        return shapes.match(BULK_MOVE, np.arange(inst_line + 1, len(self.lines.starts)))

    def _bulk_block(self, moves, numbers) -> dict:
        """The bulk motion lines as columns; those that are not a plain Cartesian target of this
        job (a pulse position, an unknown name, ...) are read one by one instead."""
        table, raw = self.table, self.raw
        name_start, name_end = moves.span("name")
        row = table.rows_of_numbers(c_numbers(raw, name_start, name_end))
        if not len(table.state):  # no positions: every move is read one by one (and names its missing position)
            row = np.full(len(row), -1, np.int64)
        at = np.maximum(row, 0)
        state = np.where(row >= 0, table.state[at] if len(table.state) else 0, 0)
        clean_state = np.array([self._clean(s) for s in self.job.states])
        clean = (row >= 0) & clean_state[state] & ((table.count[at] if len(table.count) else 0) == 6)
        for k in np.nonzero(~clean)[0].tolist():  # one by one
            line = int(moves.line[k])
            start = int(moves.start[k])
            end = int(self.lines.starts[line + 1]) - 1 if line + 1 < len(self.lines.starts) else len(self.doc.text)
            text = self.doc.text[start:end].rstrip("\r")
            self._motion(MOTION.match(text), line + 1, start, {})
        keep = np.nonzero(clean)[0]
        row, state = row[keep], state[keep]
        n = len(keep)
        values = np.full((n, NF), np.nan)
        spans = np.full((n, NF, 3), -1, np.int64)
        values[:, RECTAN_FIELDS] = table.values[row]
        spans[:, RECTAN_FIELDS, 0] = 0
        spans[:, RECTAN_FIELDS, 1:] = table.spans[row]
        word_start, _ = moves.span("word")
        word = raw[word_start[keep] + 3] == ord("J")
        speed_start, _ = moves.span("speed")
        vkey_start, vkey_end = moves.span("vkey")
        is_v = (vkey_end - vkey_start == 1)[keep]
        at = np.searchsorted(numbers.start, speed_start[keep])
        speed = np.where(is_v & (speed_start[keep] >= 0), numbers.value[np.minimum(at, len(numbers.value) - 1)], np.nan)
        pl_start, _ = moves.span("pl")
        pl = np.where(pl_start[keep] >= 0, raw[pl_start[keep]].astype(np.int64) - 48, -1)
        joint_speed = np.where(~is_v & (speed_start[keep] >= 0), numbers.value[np.minimum(at, len(numbers.value) - 1)], np.nan)
        frames, tools, confs = self._state_columns()
        return {"order": moves.start[keep], "line": moves.line[keep] + 1, "word": np.where(word, 0, 1), "pulse": np.zeros(n, bool),
                "values": values, "spans": spans, "conf": confs[state], "speed": speed, "zone": np.where(pl == 0, 0.0, np.nan),
                "tool": tools[state], "frame": frames[state], "name": _texts(self.doc.text, name_start[keep], name_end[keep]),
                "inform.pl": pl.astype(np.int8), "inform.vj": joint_speed, "inform.pulses": np.full((n, 6), np.nan)}

    def _clean(self, state: PositionState) -> bool:
        """A state whose positions the bulk path reads: Cartesian, with a tool, played where taught."""
        if state.form != "RECTAN" or state.postype not in CARTESIAN or state.tool is None:
            return False
        if state.postype == "BASE" and self.on_base_axis:
            return False
        if state.postype == "USER" and state.user is None:
            return False
        return self.played_in is None or self.played_in == _taught_in(state)

    def _state_columns(self):
        """Frame, tool and conf of every position state (for the bulk path)."""
        states = self.job.states
        frames = np.array([self.builder.frame_index(f"UF#({s.user})", None) if s.postype == "USER" and s.user is not None else 0 for s in states], np.int32)
        tools = np.array([self.builder.tool_index(f"TOOL#({s.tool})", None) if s.tool is not None else 0 for s in states], np.int32)
        confs = np.array([_conf(s.rconf) for s in states], dtype=float).reshape(-1, 4)
        return frames, tools, confs

    # ------------------------------------------------------------ one motion line at a time
    def _slow_moves(self, job: JobFile) -> None:
        changed: dict[str, int] = {}  # what an instruction changed -> its line
        for line, start, text in job.instructions:
            indent = len(text) - len(text.lstrip())
            text, start = text[indent:], start + indent
            word = text.split(None, 1)[0].upper() if text else ""
            if word in FLOW or " IF " in f" {text} ":
                self.builder.notes.append(f"{self.path}, line {line}: {word}: program flow is not followed; each motion is listed once, in the order of the text")
                changed["flow"] = line
            elif word.startswith(FLOW_TARGETS):
                changed["flow"] = line
            if word in CHANGING:
                if word == "SFTOF":
                    changed.pop("shift", None)
                else:
                    changed[CHANGING[word]] = line
            match = MOTION.match(text)
            if match:
                self._motion(match, line, start, dict(changed))
                if match.group(1) == "MOVJ" and not self.rows[-1]["why"]:
                    changed.pop("flow", None)  # its form (RCONF) or its pulses set the posture again

    def _motion(self, match: re.Match, line: int, start: int, changed: dict[str, int]) -> None:
        word, name, tags = match.group(1), match.group(2), match.group(3)
        tags = tags.split("//", 1)[0]  # an inline comment
        row = {"word": WORDS.index(word) if word in WORDS else 1, "line": line, "order": start, "name": name, "why": [],
               "values": np.full(NF, np.nan), "spans": np.full((NF, 3), -1, np.int64), "conf": np.full(4, np.nan),
               "speed": np.nan, "zone": np.nan, "tool": 0, "frame": 0, "pulse": False,
               "inform.pl": -1, "inform.vj": np.nan, "inform.pulses": np.full(6, np.nan)}
        self._tags(row, tags, start + match.start(3))
        if "shift" in changed:
            row["why"].append(f"shifted by the SFTON on line {changed['shift']} (its amount is a variable's)")
        if "tool" in changed:
            row["why"].append(f"the tool file was rewritten by the SETTOOL on line {changed['tool']}")
        if "flow" in changed and word != "MOVJ":
            row["why"].append(f"the posture the robot keeps here is that of the motion run before it, which depends on the jump, call or label "
                              f"on line {changed['flow']} (postproc does not follow the job's flow)")
        position = self.table.row_of(name.upper())
        if word == "IMOV":
            row["why"].append(f"IMOV moves by the increment {name} holds, a variable the controller keeps")
        elif re.fullmatch(r"(?:BC|EC)\d+", name, re.I):
            row["why"].append(f"{name} moves base or station axes (not the robot's TCP)")
        elif position is None or not name.upper().startswith("C"):
            row["why"].append(self._unknown_position(name))
        else:
            self._position(row, int(position), changed)
        if row["tool"] == 0 and not row["pulse"]:
            row["tool"] = self.builder.tool_index("TOOL#(?)", None)
        self.rows.append(row)

    def _unknown_position(self, name: str) -> str:
        """Why a move to ``name`` (not a C position of this job) is not placed."""
        if not re.fullmatch(r"L?P\d+|L?P\[.*\]", name, re.I):
            return f"{name} is not a position of this job"
        number = name[1:] if name[:1].upper() == "P" and DIGITS.fullmatch(name[1:]) else None
        saved = number is not None and any(k[:1] == "P" and DIGITS.fullmatch(k[1:]) and int(k[1:]) == int(number) for k in self.table.index)
        return f"{name} is a position variable held by the controller" + (" (the job saves a value of it, which any job may change before this one runs)" if saved else "")

    def _tags(self, row: dict, tags: str, offset: int) -> None:
        for tag in TAG.finditer(tags):
            key, value = tag.group(1), tag.group(2)
            if key in ("V", "VJ"):
                row["speed" if key == "V" else "inform.vj"] = float(value) if re.fullmatch(NUM, value) else np.nan
            elif key == "PL":
                if re.fullmatch("[0-8]", value):
                    row["inform.pl"] = int(value)
                else:
                    row["why"].append(f"PL={value}: not a positioning level 0..8")
                row["zone"] = 0.0 if value == "0" else np.nan
            elif key == "CR":
                row["why"].append("CR= rounds the corner by a radius")
            elif tag.group(4):
                row["why"].append(f"{tag.group(4)} {tag.group(5)} moves another axis group (external axes not read)")
            elif tag.group(6):
                row["why"].append(_why_tag(tag.group(6)))
            elif tag.group(7):
                raise self.lines.error(self.path, offset + tag.start(7), f"'{tag.group(7)}': a motion tag postproc does not read (VJ=, V=, VR=, VE=, PL=, CR=, ACC=, DEC=, NWAIT, +MOVJ, UF#(n), BF, RF, TF, UNTIL)")

    def _position(self, row: dict, position: int, changed: dict[str, int]) -> None:
        table, name = self.table, row["name"]
        state = self.job.states[int(table.state[position])]
        count, values, spans = int(table.count[position]), table.values[position], table.spans[position]
        if state.tool is not None:
            row["tool"] = self.builder.tool_index(f"TOOL#({state.tool})", None)
        if state.form == "PULSE":
            row["pulse"] = True
            if count != 6:
                row["why"].append(f"{name} has {count} axes, postproc reads six")
                return
            row["spans"][JOINT_FIELDS, 0] = 0
            row["spans"][JOINT_FIELDS, 1:] = spans
            row["inform.pulses"] = values
            row["why"].append(f"{name} is in pulses: joint angles need the robot's pulse data")
            return
        if state.postype not in CARTESIAN:
            row["why"].append(f"{name}: ///POSTYPE {state.postype} positions are not read")
            return
        if count != 6:
            raise self.lines.error(self.path, int(spans[0, 0]), f"a ///RECTAN position has six numbers (X, Y, Z, Rx, Ry, Rz), {name} has {count}")
        if state.tool is None:
            row["why"].append(f"{name} has no ///TOOL")
        row["values"][RECTAN_FIELDS] = values
        row["spans"][RECTAN_FIELDS, 0] = 0
        row["spans"][RECTAN_FIELDS, 1:] = spans
        if state.postype == "USER":
            if state.user is None:
                raise self.lines.error(self.path, int(spans[0, 0]), f"{name}: ///POSTYPE USER without ///USER n")
            row["frame"] = self.builder.frame_index(f"UF#({state.user})", None)
            if "user frame" in changed:
                row["why"].append(f"the user frames were redefined by the MFRAME on line {changed['user frame']}")
        if state.postype == "BASE" and self.on_base_axis:
            row["why"].append(f"{name} is in the base frame of a robot on a base axis ({self.on_base_axis}): the robot's place on it is not read")
        if self.played_in is not None and self.played_in != _taught_in(state):
            row["why"].append(f"a relative job played in {self.played_in} with {name} taught in {_taught_in(state)}")
        row["conf"] = np.array(_conf(state.rconf), dtype=float)

    # -------------------------------------------------------------- the IR
    def _slow_block(self) -> dict | None:
        rows = self.rows
        if not rows:
            return None
        for row in rows:
            if row["why"]:
                self.builder.notes.append(f"{self.path}, line {row['line']}: {'; '.join(row['why'])}")
        block = {key: np.array([r[key] for r in rows]) for key in COLUMNS if key not in ("name", "resolved")}
        block["name"] = np.array([r["name"] for r in rows], dtype=object)
        block["resolved"] = np.array([not r["why"] for r in rows])
        return block

    def _build(self, bulk: dict | None) -> Toolpath:
        blocks = [b for b in (bulk, self._slow_block()) if b is not None]
        if not blocks:
            return self.builder.build()
        keys = COLUMNS  # (bulk rows are resolved: the others were read one by one)
        if len(blocks) == 1:
            cols = {key: blocks[0].get(key, np.ones(len(blocks[0]["order"]), bool)) for key in keys}
        else:
            cols = {key: np.concatenate([b[key] if key in b else np.ones(len(b["order"]), bool) for b in blocks]) for key in keys}
        if len(cols["order"]) > 1 and not bool(np.all(cols["order"][1:] >= cols["order"][:-1])):
            order = np.argsort(cols["order"], kind="stable")
            cols = {key: value[order] for key, value in cols.items()}
        kind = self._kinds(cols)
        self.builder.add_block(cols["order"], kind=kind, line=cols["line"].astype(np.int32), file=np.zeros(len(kind), np.int16),
                               values=cols["values"], spans=cols["spans"], conf=cols["conf"], speed=cols["speed"], zone=cols["zone"],
                               tool=cols["tool"].astype(np.int32), frame=cols["frame"].astype(np.int32), resolved=cols["resolved"], name=cols["name"],
                               **{name: cols[name] for name, *_ in EXTRAS})
        return self.builder.build()

    def _kinds(self, cols: dict) -> np.ndarray:
        """MOVJ: joint (to a pulse position: a joint target); MOVL: linear; three MOVC: straight
        to the first, then the circle through the second to the third (INFORM manual, MOVC)."""
        word, pulse, order = cols["word"], cols["pulse"], cols["order"]
        spline = np.nonzero(word == 3)[0]
        if spline.size:
            raise self.lines.error(self.path, int(order[spline[0]]), "MOVS (spline): the controller's spline through the points is not modelled; refused")
        circ = word == 2
        edges = np.diff(np.concatenate([[0], circ.astype(np.int8), [0]]))
        run_start, run_end = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
        bad = np.nonzero(run_end - run_start != 3)[0]
        if bad.size:
            k = int(run_start[bad[0]])
            raise self.lines.error(self.path, int(order[k]), f"{int(run_end[bad[0]] - k)} consecutive MOVC lines: postproc reads a circle of exactly three (continued arcs follow controller rules it does not model)")
        kind = np.where(word == 0, np.where(pulse, Kind.ABSJ, Kind.JOINT), Kind.LINEAR).astype(np.int8)
        for k, part in enumerate((Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END)):
            kind[run_start + k] = part
        return kind


def _why_tag(tag: str) -> str:
    """Why a target with this tag is not placed."""
    if tag.startswith("UNTIL"):
        return "UNTIL: a search move stops where an input comes"
    if tag[:2] in ("BC", "EC"):
        return f"{tag}: base or station axes move with the robot (not read)"
    return f"{tag}: the increment's coordinate system (IMOV)"


def _texts(text: str, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The texts of spans, as an object array."""
    out = np.empty(len(start), dtype=object)
    out[:] = [text[a:b] for a, b in zip(start.tolist(), end.tolist())]
    return out


def _conf(rconf) -> list[float]:
    """IR conf [flip, arm, side, R + 2 T + 4 S] of an ///RCONF (NaN where none)."""
    if rconf is None:
        return [np.nan] * 4
    flip, arm, side, r, t, s = rconf[:6]
    return [flip, arm, side, r + 2 * t + 4 * s]


def _taught_in(state: PositionState) -> str:
    return f"USER {state.user}" if state.postype == "USER" else "ROBOT"


def on_base_axis(job: JobFile) -> str | None:
    """The base axis group (BS1, ...) the job's robot rides on, from ///GROUPn; None where none:
    then the base frame is the robot frame (DX100 offline teaching interface, 4.3.1.3)."""
    for _, _, text in job.inst_headers:
        parts = text.lstrip("/").split(None, 1)
        if parts and parts[0].upper().startswith("GROUP") and len(parts) > 1:
            found = [g.strip() for g in parts[1].split(",") if g.strip().upper().startswith("BS")]
            if found:
                return found[0]
    return None


def played_frame(job: JobFile) -> str | None:
    """The frame a relative job (///ATTR with RJ) is played in (////FRAME BASE, ROBOT or
    USER n; BASE is ROBOT without base axes), or None for a standard job."""
    headers = {}
    for _, _, text in job.inst_headers:
        parts = text.lstrip("/").split(None, 1)
        if parts:
            headers[parts[0].upper()] = parts[1] if len(parts) > 1 else ""
    if "RJ" not in {a.strip().upper() for a in headers.get("ATTR", "").split(",")}:
        return None
    frame = " ".join(headers.get("FRAME", "ROBOT").upper().split())
    return "ROBOT" if frame == "BASE" else frame
