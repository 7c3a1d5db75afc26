"""URScript program -> Toolpath.

Statements are read in text order (URScript manual, "The URScript Programming Language"):
variable assignments that hold constant poses or joint lists, ``set_tcp``, the motion
functions ``movej``, ``movel``, ``movep``, ``movec``, ``servoj`` and the blocks ``def`` /
``thread`` / ``if`` / ``elif`` / ``else`` / ``while`` ... ``end``. Every number a target
takes from the text keeps its span; units are SI (m, rad, m/s) and the IR's are mm and
degrees (``scale``). What the text does not determine (a target computed at run time, a
posture after a block the program may or may not run) leaves the target unresolved with a
note naming its line: compensation refuses it, never guesses.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ...ir import F_JOINT, F_POS, NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex
from . import branches, bulk, loops
from .lexer import code_mask, matching, split_arguments, statements, strip
from .poses import M_TO_MM, RAD_TO_DEG
from .values import Evaluator, Unknown, Value

_HEAD = re.compile(
    r"""[ \t]*(?:
      (?P<def>def|thread)[ \t]+(?P<fname>\w+)
    | (?P<block>if|while|elif)\b
    | (?P<else>else)[ \t]*:
    | (?P<end>end)\b
    | (?P<move>movej|movel|movep|movec|servoj)[ \t]*\(
    | (?P<tcp>set_tcp)[ \t]*\(
    | (?:(?:global|local)[ \t]+)?(?P<var>[A-Za-z_]\w*)[ \t]*=(?!=)
    )""",
    re.VERBOSE,
)

# Positional parameters of each motion function (URScript manual, "movej", "movel", "movep",
# "movec", "servoj"), and the defaults of a, v, r where the call leaves them out.
PARAMETERS = {
    "movej": ("q", "a", "v", "t", "r"),
    "movel": ("pose", "a", "v", "t", "r"),
    "movep": ("pose", "a", "v", "r"),
    "movec": ("pose_via", "pose_to", "a", "v", "r", "mode"),
    "servoj": ("q", "a", "v", "t", "lookahead_time", "gain"),
}
DEFAULTS = {"movej": {"a": 1.4, "v": 1.05, "r": 0.0}, "movel": {"a": 1.2, "v": 0.25, "r": 0.0}, "movep": {"a": 1.2, "v": 0.25, "r": 0.0},
            "movec": {"a": 1.2, "v": 0.25, "r": 0.0}, "servoj": {"r": 0.0}}
INSTALLATION_TCP = "<installation TCP>"  # the TCP before any set_tcp: the robot's installation sets it, not the script


@dataclass
class _Block:
    kind: str  # def, thread, if, while
    line: int
    name: str = ""
    moved: bool = False  # a motion ran inside it
    joint_target: bool = False  # a joint target inside it set the posture (from there on in the block)
    assigned: set = field(default_factory=set)
    program: bool = False  # the def the controller runs as the program (see ``program_def``)
    sets_tcp: bool = False
    before: tuple = ()  # a function's (TCP, posture doubt) at its definition, restored after it: its body runs where it is called
    counted: loops.CountedLoop | None = None  # a while whose passes the text fixes (run pass by pass)
    fixed: bool = False  # an if whose branch the text fixes (branches.py): only that branch is read
    taken: bool = False  # a branch of that if has run: the others are not read
    body: tuple = ()  # (first statement index, offset) of a counted loop's body


class UrParser:
    """One pass over the statements of one .script file."""

    def __init__(self, sources: list[SourceDoc]):
        self.doc = sources[0]
        self.sources = sources
        self.mask = code_mask(self.doc.text)
        self.lines = LineIndex(self.doc.text)
        self.evaluator = Evaluator(self.mask, self._where)
        self.builder = Builder("urscript", "rotvec", list(sources), tool_names=[INSTALLATION_TCP], tools=[np.eye(4)], tool_known=[False])
        for name, (dtype, fill, shape) in EXTRAS.items():
            self.builder.declare_extra(name, dtype, fill, shape)
        self.env: dict = {}
        self.stack: list[_Block] = []
        self.tool = 0
        self.posture_doubt: str | None = None  # why the joints the robot is in are not known from the text here
        self.rows: list[dict] = []
        self.notes: list[str] = []
        self.functions: dict[str, _Block] = {}  # the program's functions and threads read so far
        self.mode: tuple[str, int] | None = None  # force mode, conveyor tracking or a path offset in force (and its line)
        self.scalars: dict[str, int | None] = {}  # integer variables the text fixes (loop counters)
        self.seq = 0  # program order of the next target (passes of a loop repeat offsets)
        self.program_at = -1
        # a thread runs beside the program and may set any variable: then only conditions of
        # literals are fixed (branches.py)
        self.threads = re.search(r"^[ \t]*thread\b", self.mask, re.MULTILINE) is not None

    def _where(self, offset: int) -> str:
        line = int(self.lines.line(offset))
        return f"line {line}, column {offset - int(self.lines.starts[line - 1]) + 1}"

    def parse(self) -> Toolpath:
        found = statements(self.mask)
        lines_of_end = self.lines.line(np.maximum(found.end - 1, found.start))
        one_line = found.start[lines_of_end == found.line]
        self.bulk = bulk.find(self.mask, self.lines.starts)
        keep = _members(self.bulk.start, one_line)  # a bulk line inside a longer statement is not one
        self.bulk = bulk.BulkLines(*(getattr(self.bulk, f)[keep] for f in bulk.BulkLines.__dataclass_fields__))
        own = ~_members(found.start, self.bulk.start)
        self.program_at = program_def(self.mask, found.start[own], found.end[own], self.bulk.start)
        self.own_start, self.own_end, self.own_line = found.start[own], found.end[own], found.line[own]
        self._run(0, len(self.own_start), 0, len(self.mask) + 1)
        if self.stack:
            raise self.lines.error(self.doc.path, len(self.doc.text), f"'{self.stack[-1].kind}' of line {self.stack[-1].line} has no 'end'")
        return self._build()

    def _run(self, first: int, last: int, lo: int, hi: int) -> None:
        """The statements ``first``..``last``-1 and the bulk lines in [lo, hi) in text order; a
        counted loop's body again for each further pass before its 'end'."""
        cursor, i = lo, first
        while i < last:
            start, end, line = int(self.own_start[i]), int(self.own_end[i]), int(self.own_line[i])
            self._flush(cursor, start)
            cursor = start
            block = self.stack[-1] if self.stack else None
            if block is not None and block.counted is not None and block.counted.end_index == i:
                for _ in range(block.counted.passes - 1):
                    self._run(block.body[0], i, block.body[1], start)
            resume = self._branch(i, start, end, line)
            if resume is None:
                self._statement(start, end, line, i)
                i += 1
            elif resume < 0:  # the branch runs: read on, its bulk lines included
                i += 1
            else:  # a branch that does not run: its statements and bulk lines are passed over
                i = min(resume, last)
                cursor = int(self.own_start[i]) if i < len(self.own_start) else hi
        self._flush(cursor, hi)

    def _branch(self, index: int, start: int, end: int, line: int) -> int | None:
        """Where reading goes on after statement ``index`` where it is an if / elif / else whose
        branch the text fixes (branches.py): -1 where its branch runs (read on), else the index
        of the next elif / else / end; None where it is no such statement (read as before)."""
        word = re.match(r"[ \t]*(if|elif|else)\b", self.mask[start:end])
        if word is None or any(b.kind in ("def", "thread", "while") and not b.program and b.counted is None for b in self.stack):
            return None  # a function runs where it is called, a loop not counted from its own end: nothing fixed here
        scalars = {} if self.threads else self.scalars
        if word.group(1) == "if":
            truth = branches.condition(self.mask, start, end, scalars)
            if truth is None:
                return None
            self.stack.append(_Block("if", line, fixed=True, taken=truth))
            self.notes.append(f"line {line}: the if's condition is {truth}: {'its first branch runs' if truth else 'its first branch does not run'}")
            return -1 if truth else branches.next_branch(self.mask, self.own_start, self.own_end, index, to_end=False)
        block = self.stack[-1] if self.stack else None
        if block is None or block.kind != "if" or not block.fixed:
            return None
        if block.taken:  # a branch before ran: the rest of the chain does not
            return branches.next_branch(self.mask, self.own_start, self.own_end, index, to_end=True)
        truth = True if word.group(1) == "else" else branches.condition(self.mask, start, end, scalars)
        if truth is None:  # from here on the chain is not fixed: read as any if (no branch before ran)
            block.fixed = False
            return None
        block.taken = truth
        return -1 if truth else branches.next_branch(self.mask, self.own_start, self.own_end, index, to_end=False)

    # ------------------------------------------------------------- statements
    def _statement(self, start: int, end: int, line: int, index: int = -1) -> None:
        head = _HEAD.match(self.mask, start, end)
        if head is None:
            first, _ = strip(self.mask, start, end)
            if not (self.mask[first].isalpha() or self.mask[first] in "_$"):
                raise self.lines.error(self.doc.path, first, f"'{self.mask[first]}' cannot start a URScript statement (a template to be filled in, not a program?)")
            self._call(start, end, line)  # another call or statement: it moves only through a function of the program
            return
        kind = head.lastgroup if head.lastgroup != "fname" else "def"
        if head.group("def"):
            self.stack.append(_Block(head.group("def"), line, head.group("fname"), program=start == self.program_at, before=(self.tool, self.posture_doubt, self.mode)))
        elif head.group("block"):
            self._open(head.group("block"), line, start, end, index)
        elif head.group("else"):
            self._open("else", line, start)
        elif head.group("end"):
            self._close(start)
        elif head.group("move"):
            self._motion(head.group("move"), head.end() - 1, end, line)
        elif head.group("tcp"):
            self._set_tcp(head.end() - 1, end, line)
        elif kind == "var":
            self._assign(head.group("var"), head.end(), end)

    def _open(self, word: str, line: int, start: int, end: int = -1, index: int = -1) -> None:
        if word in ("elif", "else"):
            if not self.stack or self.stack[-1].kind != "if":
                raise self.lines.error(self.doc.path, start, f"'{word}' without an 'if'")
            self._leave(self.stack[-1])  # the branch before may or may not have run
            self.stack[-1].joint_target = False
            return
        counted = loops.counted(self.mask, self.own_start, self.own_end, index, self.scalars) if word == "while" and index >= 0 else None
        self.stack.append(_Block(word, line, counted=counted, body=(index + 1, end)))
        if counted is not None:
            self.notes.append(f"line {line}: the while loop runs {counted.passes} times ({counted.counter} from {counted.first} while {counted.limit}): its motions are listed per pass")

    def _close(self, start: int) -> None:
        if not self.stack:
            raise self.lines.error(self.doc.path, start, "'end' without a block to close")
        block = self.stack.pop()
        if block.counted is not None or block.fixed:  # run pass by pass, or the one branch that runs: what follows is straight-line
            if self.stack:
                self.stack[-1].moved |= block.moved
                self.stack[-1].assigned |= block.assigned
            return
        if block.kind in ("if", "while"):
            self._leave(block)
        if block.kind == "while" and block.moved:
            self.notes.append(f"line {block.line}: the while loop runs a number of times the text does not fix: its motions are listed once")
        function = block.kind in ("def", "thread") and not block.program
        for name in block.assigned:  # set inside a block that may not run (or runs where it is called): unknown after it
            where = f"{block.kind} {block.name} (line {block.line}), which runs where it is called" if function else f"the {block.kind} of line {block.line}, which may or may not run"
            self.env[name] = Unknown(f"'{name}' is set inside {where}")
            self.scalars[name] = None
        if function:
            self.functions[block.name] = block
            self.tool, self.posture_doubt, self.mode = block.before  # its body ran nothing here
        if self.stack:
            self.stack[-1].assigned |= block.assigned if block.kind in ("if", "while") else set()
            self.stack[-1].moved |= block.moved

    def _call(self, start: int, end: int, line: int) -> None:
        """A call of one of the program's functions (or ``run`` of a thread) that moves or sets
        the TCP: after it the joints (or the TCP) are those it left, which this single pass over
        the text does not follow."""
        called = _CALL.match(self.mask, start, end)
        name = called.group(1) if called else ""
        if name in MOVES_OTHERWISE:
            self.posture_doubt = f"after {name} at line {line} (a motion without a target) the robot's joints are not known until the next joint target"
        elif name in MODES:
            self.mode = (name, line)
        elif name in MODE_ENDS and self.mode is not None and MODES[self.mode[0]] == name:
            self.mode = None
        block = self.functions.get(name)
        if block is None:
            return
        if block.moved:
            self.posture_doubt = f"after the call of {block.name} (line {block.line}) at line {line} the robot's joints are not known until the next joint target"
        if block.sets_tcp:
            name = f"TCP after {block.name}()@{line}"
            self.tool = self.builder.tool_index(name, None)
            self.notes.append(f"line {line}: {block.name} (line {block.line}) sets the TCP: give the one in force after it with --tool '{name}=X,Y,Z,A,B,C'")

    def _leave(self, block: _Block) -> None:
        """After an if or while whose runs the text does not fix, the joints are those before it
        or those its motions left: unknown, if it moved, until the next joint target."""
        if block.moved:
            self.posture_doubt = f"after the {block.kind} of line {block.line} (which may or may not run its motions) the robot's joints are not known until the next joint target"

    def _assign(self, name: str, start: int, end: int) -> None:
        value = self.evaluator.evaluate(start, end, self.env, scalar=True)
        if isinstance(value, Value) and re.search(rf"\b{re.escape(name)}\b", self.mask[start:end]):
            value = Unknown(f"'{name}' is computed from itself at {self._where(start)}")
        self.env[name] = value
        self.scalars[name] = _next_scalar(self.mask, name, start, end, self.scalars.get(name))
        if self.stack and not self.stack[-1].program:
            self.stack[-1].assigned.add(name)

    def _set_tcp(self, opener: int, end: int, line: int) -> None:
        close = matching(self.mask, opener)
        args = split_arguments(self.mask, opener + 1, close)
        value = self.evaluator.evaluate(*args[0], self.env) if len(args) == 1 else Unknown(f"set_tcp at line {line} takes one pose")
        name = f"set_tcp@{line}" if not isinstance(value, Value) or not value.name else value.name
        if self.stack:
            for block in self.stack:
                block.sets_tcp = True
        if isinstance(value, Value) and value.is_pose:
            self.tool = self.builder.tool_index(name, value.transform())
        else:
            self.tool = self.builder.tool_index(name, None)
            self.notes.append(f"line {line}: the TCP is not known from the text ({value.reason if isinstance(value, Unknown) else 'a joint list'}): give it with --tool {name}=X,Y,Z,A,B,C")

    def _flush(self, lo: int, hi: int) -> None:
        """The bulk lines (bulk.py) starting in [lo, hi), under the state now."""
        sel = self.bulk.between(lo, hi)
        if sel.stop == sel.start:
            return
        self._add_rows()  # the statements' targets before these first: blocks arrive in program order
        doubt = self._loop_doubt() or self.posture_doubt
        why = None if doubt is None else f"the posture is not known: {doubt}"
        if self.mode is not None:
            why = f"{self.mode[0]} (line {self.mode[1]}) is in force: the robot does not go to the programmed target"
        if why is not None:
            first, last = int(self.bulk.line[sel.start]), int(self.bulk.line[sel.stop - 1])
            self.notes.append(f"{f'line {first}' if first == last else f'lines {first}-{last}'}: {why}")
        block = bulk.rows(self.bulk, sel, self.tool, why is None)
        del block["order"]
        self.builder.add_block(np.arange(self.seq, self.seq + sel.stop - sel.start), **block)
        self.seq += sel.stop - sel.start
        if self.stack:
            self.stack[-1].moved = True

    # ----------------------------------------------------------------- motions
    def _motion(self, function: str, opener: int, end: int, line: int) -> None:
        close = matching(self.mask, opener)
        if close < 0 or close >= end:
            raise self.lines.error(self.doc.path, opener, f"{function}( is not closed")
        positional, named = self._arguments(function, opener, close)
        options = {**DEFAULTS[function], **{k: self._number(*v) for k, v in named.items() if k in ("a", "v", "r", "t")}}
        for k, key in enumerate(PARAMETERS[function]):
            if k < len(positional) and key in ("a", "v", "r", "t"):
                options[key] = self._number(*positional[k])
        targets = PARAMETERS[function][:2] if function == "movec" else PARAMETERS[function][:1]
        spans = [named[key] if key in named else positional[k] if k < len(positional) else None for k, key in enumerate(targets)]
        if any(s is None for s in spans):
            raise self.lines.error(self.doc.path, opener, f"{function} without its {' and '.join(targets)}")
        kinds = (Kind.CIRC_VIA, Kind.CIRC_END) if function == "movec" else (None,)
        for k, span in enumerate(spans):
            self._target(function, kinds[k], span, options, line, order=self.seq)
            self.seq += 1
        if self.stack:
            self.stack[-1].moved = True

    def _arguments(self, function, opener, close):
        positional, named = [], {}
        for s, e in split_arguments(self.mask, opener + 1, close):
            m = re.match(r"\s*(\w+)\s*=(?!=)", self.mask[s:e])
            if m:
                named[m.group(1)] = (s + m.end(), e)
            elif named:
                raise self.lines.error(self.doc.path, s, f"a positional argument of {function} after a named one")
            else:
                positional.append((s, e))
        unknown = set(named) - set(PARAMETERS[function])
        if unknown:
            raise self.lines.error(self.doc.path, opener, f"{function} has no parameter {', '.join(sorted(unknown))}")
        return positional, named

    def _number(self, start: int, end: int) -> float:
        start, end = strip(self.mask, start, end)
        try:
            return float(self.mask[start:end])
        except ValueError:
            return np.nan  # a variable or expression: not known from the text

    def _target(self, function, kind, span, options, line, order):
        value = self.evaluator.evaluate(*span, self.env)
        row = {"order": order, "line": line, "tool": self.tool, "speed": np.nan, "zone": options["r"] * M_TO_MM, "resolved": True, "name": "", "frame": 0,
               "values": np.full(NF, np.nan), "spans": np.full((NF, 3), -1, dtype=np.int64), "scale": np.ones(NF), "qnear": np.full(6, np.nan),
               "function": function, "accel": options.get("a", np.nan), "blend": options["r"], "time": options.get("t", 0.0), "process": function == "movep"}
        if isinstance(value, Unknown):
            row["resolved"] = False
            row["kind"] = kind if kind is not None else (Kind.ABSJ if function in ("servoj", "movej") else Kind.LINEAR)
            self.notes.append(f"line {line}: {function} target not known from the text: {value.reason}")
            self.rows.append(row)
            return
        if function in ("movej", "servoj"):
            if function == "servoj" and value.is_pose:
                raise self.lines.error(self.doc.path, int(span[0]), "servoj takes joint positions, not a pose")
            row["kind"] = Kind.JOINT if value.is_pose else Kind.ABSJ
        else:
            if not value.is_pose:
                raise self.lines.error(self.doc.path, int(span[0]), f"{function} takes a pose p[...], not a joint list (URScript manual, '{function}')")
            row["kind"] = kind if kind is not None else Kind.LINEAR
            row["speed"] = options.get("v", np.nan)
        row["name"] = value.name
        self._mode_rule(row, line)
        fields = np.r_[F_POS, 3:6] if value.is_pose else np.arange(F_JOINT.start, F_JOINT.stop)
        scale = np.r_[[M_TO_MM] * 3, [1.0] * 3] if value.is_pose else np.full(6, RAD_TO_DEG)
        row["values"][fields] = value.numbers * scale
        row["scale"][fields] = scale
        row["spans"][fields, 1:] = value.spans
        row["spans"][fields, 0] = np.where(value.spans[:, 0] >= 0, 0, -1)
        if value.is_pose:
            row["frame"] = self.builder.frame_index(value.frame_name, value.frame)
            if value.qnear is not None:
                row["qnear"] = value.qnear * RAD_TO_DEG
            self._posture_rule(row, line)
        else:
            self._joint_target()
        self.rows.append(row)

    def _joint_target(self) -> None:
        """A joint target sets the joints: the posture is known again from here (inside a
        loop only for the rest of the loop body's run)."""
        if self.stack and self.stack[-1].kind in ("while", "if", "else"):
            self.stack[-1].joint_target = True
        self.posture_doubt = None if not self._loop_doubt() else self.posture_doubt

    def _loop_doubt(self) -> str | None:
        """Why a pose target here has unknown joints: inside a while loop (its first run comes
        from before it, the next from its own end) before any joint target of its body; in a
        function or thread (it runs where it is called)."""
        for block in self.stack:
            if block.kind in ("def", "thread") and not block.program:
                return f"inside {block.kind} {block.name} (line {block.line}): it runs where it is called, from joints the text does not fix there"
        for block in reversed(self.stack):
            if block.joint_target:
                return None
            if block.kind == "while" and block.counted is None:
                return f"inside the while of line {block.line} before any joint target of its body: each run starts from where the previous one ended"
        return None

    def _mode_rule(self, row: dict, line: int) -> None:
        """Under force_mode, conveyor tracking or a path offset the controller moves off the
        programmed targets (manual, "force_mode", "track_conveyor_linear", "path_offset_enable"):
        what it reaches is not known from the text."""
        if self.mode is not None:
            row["resolved"] = False
            self.notes.append(f"line {line}: {self.mode[0]} (line {self.mode[1]}) is in force: the robot does not go to the programmed target")

    def _posture_rule(self, row: dict, line: int) -> None:
        """movel/movep/movec and movej to a pose take the inverse-kinematics solution nearest the
        current joints (URScript manual, "movel", "get_inverse_kin": qnear defaults to the
        current joints): where those are not known from the text the target is unresolved."""
        if not np.isnan(row["qnear"]).any():
            self._joint_target()  # get_inverse_kin(x, qnear=q): the solution nearest q, whatever the joints were
            return
        doubt = self._loop_doubt() or self.posture_doubt
        if doubt is not None:
            row["resolved"] = False
            self.notes.append(f"line {line}: the posture is not known: {doubt}")

    # ------------------------------------------------------------------ result
    def _add_rows(self) -> None:
        """The targets of the statements read since the last call, as one builder block."""
        rows, n = self.rows, len(self.rows)
        if not n:
            return

        def column(key, dtype, shape=()):
            return np.array([r[key] for r in rows], dtype=dtype).reshape((n,) + shape)

        self.builder.add_block(column("order", np.int64), kind=column("kind", np.int8), line=column("line", np.int32), values=column("values", float, (NF,)),
                               spans=column("spans", np.int64, (NF, 3)), scale=column("scale", float, (NF,)), speed=column("speed", float),
                               zone=column("zone", float), tool=column("tool", np.int32), frame=column("frame", np.int32),
                               resolved=column("resolved", bool), name=column("name", object),
                               **{name: column(key, dtype, shape) for (name, (dtype, _, shape)), key in zip(EXTRAS.items(), EXTRA_KEYS)})
        self.rows = []

    def _build(self) -> Toolpath:
        self._add_rows()
        self.builder.notes.extend(dict.fromkeys(self.notes))
        return self.builder.build()


# Built-in functions that move the robot without a target (URScript manual, module "motion"):
# after them the joints are not known from the text.
MOVES_OTHERWISE = frozenset({"speedj", "speedl", "servoc", "direct_torque", "freedrive_mode", "teach_mode"})
# Modes under which motions leave their programmed targets, and the call that ends each.
MODES = {"force_mode": "end_force_mode", "track_conveyor_linear": "end_conveyor_tracking", "track_conveyor_circular": "end_conveyor_tracking",
         "path_offset_enable": "path_offset_disable"}
MODE_ENDS = frozenset(MODES.values())
_CALL = re.compile(r"[ \t]*(?:run[ \t]+)?([A-Za-z_]\w*)[ \t]*\(")
_OPENS = re.compile(r"[ \t]*(?:(def|thread)[ \t]+(\w+)|(if|while)\b|(end)\b)")


def program_def(mask: str, starts: np.ndarray, ends: np.ndarray, bulk_starts: np.ndarray) -> int:
    """Offset of the def the controller runs as the program, or -1: a file whose top level is one
    def (and at most calls of it) is that def (PolyScope saves a program so; the controller runs
    it when the file is sent); otherwise the top-level statements are the program and every def
    is a function that runs where it is called. One pass over the statements that are not bulk
    lines (those are motions: at top level they make the file a program of statements)."""
    depth, top_defs, spans, others = 0, [], [], []
    for start, end in zip(starts.tolist(), ends.tolist()):
        m = _OPENS.match(mask, start, end)
        opener = m and (m.group(1) or m.group(3))
        if depth == 0 and m and m.group(1) == "def":
            top_defs.append((start, m.group(2)))
        elif depth == 0 and not (m and m.group(1)) and mask[start:end].strip():
            others.append(mask[start:end].strip())
        if opener:
            depth += 1
            if depth == 1:
                spans.append([start, len(mask)])
        elif m and m.group(4):
            depth = max(depth - 1, 0)
            if depth == 0 and spans:
                spans[-1][1] = end
    if len(top_defs) != 1:
        return -1
    name = top_defs[0][1]
    if any(not re.fullmatch(rf"{re.escape(name)}[ \t]*\([ \t]*\)", other) for other in others):
        return -1
    inside = np.zeros(len(bulk_starts), bool)
    for lo, hi in spans:
        inside |= (bulk_starts >= lo) & (bulk_starts < hi)
    return top_defs[0][0] if inside.all() else -1


def _next_scalar(mask: str, name: str, start: int, end: int, value: int | None) -> int | None:
    """The integer ``name`` holds after ``name = <mask[start:end]>``: a literal, or the value it
    held plus one (``name = name + 1``); None for anything else."""
    literal = loops.INT_LITERAL.match(mask, start, end)
    if literal:
        return int(literal.group(1))
    truth = re.fullmatch(r"[ \t]*(True|False)[ \t]*\r?", mask[start:end])
    if truth:
        return branches.TRUTH[truth.group(1)]
    if value is not None and re.fullmatch(rf"[ \t]*{re.escape(name)}[ \t]*\+[ \t]*1[ \t]*\r?", mask[start:end]):
        return value + 1
    return None


def _members(values: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    """(len(values),) True where the value is in ``sorted_set`` (ascending; np.isin sorts both)."""
    at = np.minimum(np.searchsorted(sorted_set, values), max(len(sorted_set) - 1, 0))
    return (sorted_set[at] == values) if len(sorted_set) else np.zeros(len(values), bool)


# The language's own per-target columns (Toolpath.extras): dtype, fill, shape; and the row key each is read from.
EXTRAS = {
    "urscript.qnear_deg": (float, np.nan, (6,)),  # get_inverse_kin's qnear (degrees), NaN where none
    "urscript.accel": (float, np.nan, ()),  # a= as written (m/s^2 or rad/s^2), NaN where not a number
    "urscript.blend_m": (float, np.nan, ()),  # r= blend radius, m
    "urscript.time_s": (float, np.nan, ()),  # t= move time, s (0: not given)
    "urscript.process_move": (bool, False, ()),  # movep: constant tool speed
}
EXTRA_KEYS = ("qnear", "accel", "blend", "time", "process")
