"""ABB RAPID modules -> Toolpath.

Comments (``!`` to the end of the line) are blanked with spaces first, so every offset
stays the file's. Bulk lines — MoveL/MoveJ with a literal robtarget or a named target on
one line, and one-line robtarget declarations — are recognised by compiled regular
expressions and read by the vectorised number scanner. Every other statement (they end
with ';' or are block lines, and may span lines) is parsed by ``rapid.lark``; the block
structure is checked with a stack.
"""

from __future__ import annotations

import functools
import re

import numpy as np
from lark import Token, Tree
from numba import njit

from postproc.robot.frames import make_transform, matrix_to_quat_wxyz, quat_wxyz_to_matrix, rot_x, rot_y, rot_z

from ...ir import F_EXT, NF, Kind, SourceDoc, Toolpath
from ...parse.common import Builder, LineIndex, parse_statement, scan_numbers
from ...parse.grammar import grammar, literal_number
from ...parse.line_shapes import LineShapes
from . import counters
from .instructions import CIRCULAR_LAYOUT, LAYOUTS, LINEAR_LAYOUT, SEARCH_POINT, RuntimeFacts, check_calls
from .loops import MAX_REPLAYED, Loop, element_key, evaluate, for_counter, loop_body_lines, planned_statements
from .updates import Update, Updates, apply, update_fields

NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
W = r"[ \t]*"


def _vec(n: int) -> str:
    return r"\[" + W + (W + "," + W).join([NUM] * n) + W + r"\]"


RT = r"\[" + W + _vec(3) + W + "," + W + _vec(4) + W + "," + W + _vec(4) + W + "," + W + _vec(6) + W + r"\]"
NAME = r"[A-Za-z][A-Za-z0-9_]*"
TAIL = W + r";" + W + r"\r?$"
ARGS = rf"{W},{W}(?P<speed>{NAME}){W},{W}(?P<zone>{NAME}){W},{W}(?P<tool>{NAME})(?:{W}\\WObj{W}:={W}(?P<wobj>{NAME}))?"
FLAGS = re.IGNORECASE | re.MULTILINE
RE_MOVE_LIT = re.compile(rf"^{W}(?P<mv>MoveL|MoveJ)[ \t]+(?P<lit>{RT}){ARGS}{TAIL}", FLAGS)
RE_MOVE_NAME = re.compile(rf"^{W}(?P<mv>MoveL|MoveJ)[ \t]+(?P<name>{NAME}(?:\{{{W}\d+{W}\}})?){ARGS}{TAIL}", FLAGS)
RE_DECL = re.compile(rf"^{W}(?:LOCAL[ \t]+)?(?:TASK[ \t]+)?(?:CONST|PERS|VAR)[ \t]+robtarget[ \t]+(?P<name>{NAME}){W}:={W}(?P<lit>{RT}){TAIL}", FLAGS)
RE_COMMENT = re.compile(r'("[^"\n]*")|(![^\n]*)')

# An external axis the robot does not have is written 9E9; anything this large is 'none'.
NO_AXIS_TEXT = "9E9"
NO_AXIS_ABOVE = 8.9e9

# Where the 17 numbers of a robtarget go: x y z, q1..q4, cf1 cf4 cf6 cfx, e1..e6.
_RT_FIELDS = np.array([0, 1, 2, 3, 4, 5, 6, -1, -2, -3, -4, 13, 14, 15, 16, 17, 18])
_JT_FIELDS = np.array([7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18])
_MOVE_KIND = {"MOVEL": Kind.LINEAR, "MOVEJ": Kind.JOINT, "MOVELDO": Kind.LINEAR, "MOVEJDO": Kind.JOINT, "MOVELSYNC": Kind.LINEAR, "MOVEJSYNC": Kind.JOINT,
              "MOVELGO": Kind.LINEAR, "MOVEJGO": Kind.JOINT, "MOVELAO": Kind.LINEAR, "MOVEJAO": Kind.JOINT, "SEARCHL": Kind.LINEAR,
              "TRIGGL": Kind.LINEAR, "TRIGGJ": Kind.JOINT}
_CIRC = {"MOVEC", "MOVECDO", "MOVECSYNC", "MOVECGO", "MOVECAO", "SEARCHC", "TRIGGC"}
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_OPEN = {"module_open": "ENDMODULE", "routine_open": "ENDROUTINE", "record_open": "ENDRECORD", "if_open": "ENDIF", "for_open": "ENDFOR", "while_open": "ENDWHILE", "test_open": "ENDTEST"}
_OPTIONAL = ("optarg", "optarg_pass")  # \Name[:=value] and \Name?Name (an optional argument passed on)
_CLOSE = {"module_close": "ENDMODULE", "routine_close": "ENDROUTINE", "record_close": "ENDRECORD", "endif": "ENDIF", "endfor": "ENDFOR", "endwhile": "ENDWHILE", "endtest": "ENDTEST"}
_BLOCK_WORDS = re.compile(r"^\s*(?:LOCAL\s+|TASK\s+)*(MODULE|ENDMODULE|PROC|ENDPROC|FUNC|ENDFUNC|TRAP|ENDTRAP|RECORD|ENDRECORD|IF|ELSEIF|ELSE|ENDIF|FOR|ENDFOR|WHILE|ENDWHILE|TEST|CASE|DEFAULT|ENDTEST|ERROR|BACKWARD|UNDO)\b", re.IGNORECASE)
_LABEL = re.compile(r"^\s*[A-Za-z][A-Za-z0-9_]*\s*:\s*$")
_HEAD_END = re.compile(r"(?:^|[^A-Za-z0-9_])(?:THEN|DO)$", re.IGNORECASE)
_HEADS = {"IF": "head", "ELSEIF": "head", "WHILE": "head", "FOR": "head", "CASE": ":", "DEFAULT": ":",
          "MODULE": "paren", "PROC": "paren", "FUNC": "paren", "TRAP": "paren", "ERROR": "paren", "RECORD": "paren"}


def _closer(line: str) -> str:
    """What ends the statement that starts on ``line``: ';' (an instruction or a declaration),
    'head' (THEN/DO, or ';' for a one-statement IF), ':' (CASE), 'paren' (a header whose
    parentheses must close), 'line' (any other block line, and labels)."""
    m = _BLOCK_WORDS.match(line)
    if m is None:
        return "line" if _LABEL.match(line) else ";"
    return _HEADS.get(m.group(1).upper(), "line")


# Where a line holds more than one statement: after each ';' and after THEN, DO or ELSE (a
# string's text is skipped). RAPID is free-form (RAPID kernel reference, "Basic elements":
# statements are separated by ';' or end with their block keyword, not by line ends), so
# 'IF a <= b THEN x := 0; ENDIF' on one line is the IF block of three statements.
_CUT = re.compile(r'"(?:[^"\n]|"")*"|;|(?<![A-Za-z0-9_])(?:THEN|DO|ELSE)(?![A-Za-z0-9_])', re.IGNORECASE)


def _pieces(code: str, start: int, end: int) -> list[tuple[int, int]]:
    """(start, end) offsets of the statements, or statement parts, of one line."""
    line = code[start:end]
    if ";" not in line or line.rstrip().endswith(";") and line.count(";") == 1 and not _CUT.search(line.rstrip()[:-1]):
        return [(start, end)]  # the common line: one statement (or part of one)
    cuts = [start + m.end() for m in _CUT.finditer(line) if not m.group().startswith('"')]
    bounds = [start] + [c for c in cuts if c < end] + [end]
    return [(a, b) for a, b in zip(bounds, bounds[1:]) if code[a:b].strip()]


def _complete(stripped: str, closer: str, depth: int) -> bool:
    """Whether a statement whose text so far ends with ``stripped`` is whole."""
    if closer == ";":
        return stripped.endswith(";")
    if closer == "head":
        return stripped.endswith(";") or _HEAD_END.search(stripped) is not None
    if closer == ":":
        return stripped.endswith(":") or stripped.endswith(";")
    if closer == "paren":
        return depth <= 0
    return True


def _root(node) -> str | None:
    """The data name an lvalue expression starts with (p1 in p1.trans.x, path in path{2})."""
    if isinstance(node, Tree) and node.data == "lvalue":
        return str(node.children[0])
    return None


def blank_comments(text: str) -> str:
    """The text with every comment replaced by spaces (strings kept), same length."""
    if "!" not in text:
        return text
    return RE_COMMENT.sub(lambda m: m.group(0) if m.group(1) else " " * len(m.group(0)), text)


@functools.lru_cache(maxsize=4096)
def _speed(name: str) -> float:
    m = re.fullmatch(r"v(\d+(?:\.\d+)?)", name.strip(), re.IGNORECASE)
    return float(m.group(1)) if m else np.nan


@functools.lru_cache(maxsize=4096)
def _zone(name: str) -> float:
    name = name.strip().lower()
    if name == "fine":
        return 0.0
    m = re.fullmatch(r"z(\d+(?:\.\d+)?)", name)
    return float(m.group(1)) if m else np.nan


@njit(cache=True)
def _gather_robtargets(first, num_start, num_end, num_value, fields, source, nf):
    """values (M, nf), spans (M, nf, 3), conf (M, 4) of M robtarget literals of module
    ``source`` whose 17 numbers start at number index ``first``; an external axis of 9E9 is 'none'.
    (The IR width ``nf`` is an argument: numba's on-disk cache would keep a global's old value.)"""
    m = len(first)
    # Each cell is written once (not filled, then overwritten): at 10^6 targets these are
    # 0.7 GB, and a fill first would pass over all of it twice.
    values = np.empty((m, nf))
    spans = np.empty((m, nf, 3), np.int64)
    conf = np.empty((m, 4))
    taken = np.zeros(nf, np.bool_)
    for k in range(len(fields)):
        if fields[k] >= 0:
            taken[fields[k]] = True
    for r in range(m):
        for f in range(nf):
            if not taken[f]:
                values[r, f] = np.nan
                spans[r, f, 0] = -1
                spans[r, f, 1] = -1
                spans[r, f, 2] = -1
        for k in range(len(fields)):
            i = first[r] + k
            f = fields[k]
            v = num_value[i]
            if f < 0:
                conf[r, -f - 1] = v
            elif not (f >= 13 and abs(v) >= NO_AXIS_ABOVE):
                values[r, f] = v
                spans[r, f, 0] = source
                spans[r, f, 1] = num_start[i]
                spans[r, f, 2] = num_end[i]
            else:
                values[r, f] = np.nan
                spans[r, f, 0] = -1
                spans[r, f, 1] = -1
                spans[r, f, 2] = -1
    return values, spans, conf


def _drop_absent_axes(values: np.ndarray, spans: np.ndarray) -> None:
    """External axes written 9E9 (none) become NaN without a span (in place); the same
    rule as the bulk kernel's."""
    ext = values[F_EXT]
    absent = ~(np.abs(ext) < NO_AXIS_ABOVE)  # (a number the scanner could not read too)
    ext[absent] = np.nan
    spans[F_EXT][absent] = -1


def _no_spans() -> np.ndarray:
    return np.full((NF, 3), -1, dtype=np.int64)


def _pose(numbers7: np.ndarray) -> np.ndarray:
    return make_transform(quat_wxyz_to_matrix(numbers7[3:7][None])[0], numbers7[:3])


def parse_modules(sources: list[SourceDoc]) -> Toolpath:
    """The IR of a RAPID program: its modules share one set of data (robtargets, tools,
    work objects), as the task's modules do on the controller. A program file (.pgf, role
    'pgf') among the sources holds no targets and is kept as it is."""
    builder = Builder("rapid", "quat", list(sources))
    data = _Data()
    modules = [RapidParser(doc, builder, data, index) for index, doc in enumerate(sources) if doc.role != "pgf"]
    for module in modules:  # one-line declarations first: a data module may come after its users
        module.declarations()
    for module in modules:
        module.statements()
    for module in modules:
        module.bulk_moves()
    _bind_late_declarations(builder, data)
    routines = sorted(r for m in modules for r in m.routine_lines)
    gotos = {r for m in modules if _has_goto(m.code) for r in m.routine_lines}

    def routine_of(file: int, line: int) -> tuple[int, int] | None:
        mine = [r for r in routines if r[0] == file and r[1] <= line]
        return mine[-1] if mine else None

    def frame_index(name: str, transform) -> int:  # the builder's frame of that name as the program writes it; -1: none
        written = next((n for n in builder.frame_names if n.upper() == name.upper()), None)
        if written is None and transform is None:
            return -1
        return builder.frame_index(written or name, transform)

    # a robtarget or work object passed to a routine may be changed there (INOUT): never followed
    data.updates.spoiled.update(root.upper() for _, roots, _, _ in data.facts.calls for root in roots if root)
    def tool_index(name: str, transform) -> int:  # the builder's tool of that name as the program writes it; -1: none
        written = next((n for n in builder.tool_names if n.upper() == name.upper()), None)
        if written is None and transform is None:
            return -1
        return builder.tool_index(written or name, transform)

    for name in apply(builder.blocks, data.updates, routine_of, gotos, frame_index, tool_index):
        data.facts.changed.pop(name, None)  # followed: its targets are known where they run
    _runtime_changes(builder, data.facts)
    return builder.build()


def _runtime_changes(builder: Builder, facts: RuntimeFacts) -> None:
    """Targets whose robtarget, tool or work object the program changes while it runs
    (``p1.trans.x := ...``, ``wobj1.oframe.trans := [...]``, SearchL's search point, an INOUT
    argument), and every target once a program displacement (PDispOn, EOffsSet, ...) is in
    the program, are not resolved: their declared values are not where the robot goes."""
    check_calls(facts, builder.notes)
    for where in facts.displaced:
        builder.notes.append(f"{where} displaces every later target at run time: no target is resolved")
    if not facts.changed and not facts.displaced:
        return
    changed_names = facts.changed.keys()
    tool_hit = np.array([n.upper() in changed_names for n in builder.tool_names])
    frame_hit = np.array([n.upper() in changed_names for n in builder.frame_names])
    used = {n.upper() for n in builder.tool_names + builder.frame_names} & changed_names
    for block in builder.blocks:
        n_rows = len(block["order"])
        changed = np.full(n_rows, bool(facts.displaced))
        changed |= tool_hit[np.asarray(block["tool"], np.int64)] | frame_hit[np.asarray(block["frame"], np.int64)]
        if block.get("name") is not None and n_rows:
            texts, codes = np.unique(np.asarray(block["name"], dtype=object).astype(str), return_inverse=True)
            refs = [set(_IDENT.findall(t.upper())) & changed_names for t in texts]  # one look per distinct target text
            used.update(*refs)
            changed |= np.array([bool(r) for r in refs])[codes]
        if changed.any():
            block["resolved"] = np.asarray(block["resolved"], bool) & ~changed
    for name in sorted(used):
        builder.notes.append(facts.changed[name] + " while the program runs: the targets that use it are not resolved")


def _bind_late_declarations(builder: Builder, data: "_Data") -> None:
    """Tools and work objects a move used before the module declaring them was read: RAPID
    data are visible to the whole task, whatever the order of the declarations."""
    for names, known, table, register in ((builder.tool_names, builder.tool_known, data.tools, builder.tool_index),
                                          (builder.frame_names, builder.frame_known, data.wobjs, builder.frame_index)):
        for i, name in enumerate(list(names)):
            if not known[i] and table.get(name.upper()) is not None:
                register(name, table[name.upper()])


def _literal_numbers(node) -> bool:
    """A number or an aggregate of numbers (nested, as a whole robtarget): no name, no call."""
    if not isinstance(node, Tree):
        return False
    if node.data == "aggregate":
        return all(_literal_numbers(c) for c in node.children)
    return node.data in ("number", "neg")


def _has_goto(code: str) -> bool:
    """A GOTO statement anywhere in the (comment-blanked) module. A plain substring test first:
    a case-insensitive regex with word boundaries scans a 10^6-line module ~20x slower."""
    upper = code.upper()
    return "GOTO" in upper and re.search(r"\bGOTO\b", upper) is not None


class _Data:
    """The program's named data: robtargets, tools and work objects by upper-case name."""

    def __init__(self):
        self.points: dict[str, tuple] = {}  # name -> (values, spans, conf)
        self.tools: dict[str, np.ndarray | None] = {"TOOL0": np.eye(4)}
        self.wobjs: dict[str, np.ndarray | None] = {"WOBJ0": np.eye(4)}
        self.facts = RuntimeFacts()
        self.updates = Updates()


class RapidParser:
    """One module; ``index`` is its place among the program's sources (the span source)."""

    def __init__(self, doc: SourceDoc, builder: Builder | None = None, data: _Data | None = None, index: int = 0):
        self.doc = doc
        self.index = index
        self.order_base = index << 40  # program order: module, then offset
        self.code = blank_comments(doc.text)
        self.lines = LineIndex(doc.text)
        self.raw = np.frombuffer(self.code.encode("latin-1"), dtype=np.uint8)
        self.numbers = scan_numbers(self.code, raw=self.raw)
        self.builder = Builder("rapid", "quat", [doc]) if builder is None else builder
        data = _Data() if data is None else data
        self.points, self.tools, self.wobjs, self.facts = data.points, data.tools, data.wobjs, data.facts
        self.rows: list[dict] = []
        self._shapes = None
        self.env: dict[str, float] = {}  # FOR counters bound while a loop body is replayed
        self._loops: list[Loop] = []  # FOR loops whose bodies are being read (loops.py)
        self._loop_order: int | None = None  # program order of the rows of the loop being run
        self._replayed = 0  # statements run by unrolled loops (bounded: MAX_REPLAYED)
        self._locals: dict[str, float | None] = {}  # the routine's own VAR nums: value, None if unknown (counters.py)
        self._in_routine = False
        self.updates = data.updates  # robtargets changed by constants (updates.py)
        self.routine_lines: list[tuple[int, int]] = []  # (file, line) of each PROC/FUNC/TRAP
        self._conditional = False  # inside a one-statement IF
        self._tick = 0  # statements of unrolled FOR passes run so far: their execution order (updates.py)
        self._track_locals = not _has_goto(self.code)  # a jump may run any line again

    # ------------------------------------------------------------- numbers
    def _literal(self, start: int, end: int, fields: np.ndarray):
        """values (NF,), spans (NF, 3), conf (4,) of a literal whose numbers fill ``fields`` in order."""
        sl = self.numbers.between(start, end)
        vals = self.numbers.value[sl]
        values = np.full(NF, np.nan)
        spans = np.full((NF, 3), -1, dtype=np.int64)
        conf = np.full(4, np.nan)
        if len(vals) != len(fields):
            return None
        for k, f in enumerate(fields):
            if f >= 0:
                values[f] = vals[k]
                spans[f] = (self.index, self.numbers.start[sl][k], self.numbers.end[sl][k])
            else:
                conf[-f - 1] = vals[k]
        _drop_absent_axes(values, spans)
        return values, spans, conf

    def _bulk_literals(self, starts: np.ndarray):
        """Vectorised read of many one-line robtarget literals: values (M, NF), spans, conf."""
        lo = np.searchsorted(self.numbers.start, starts)
        return _gather_robtargets(lo, self.numbers.start, self.numbers.end, self.numbers.value, _RT_FIELDS, self.index, NF)

    # --------------------------------------------------------------- parse
    def parse(self) -> Toolpath:
        """The IR of this module as a program on its own."""
        self.declarations()
        self.statements()
        self.bulk_moves()
        _runtime_changes(self.builder, self.facts)
        return self.builder.build()

    def declarations(self) -> None:
        """One-line robtarget declarations, read in bulk."""
        shapes = LineShapes(self.code, self.raw, self.lines.starts)
        self._shapes = {"decls": shapes.match(RE_DECL), "lits": shapes.match(RE_MOVE_LIT), "named": shapes.match(RE_MOVE_NAME)}
        lower = self.code.lower()
        if ("for" in lower or "while" in lower) and re.search(r"(?im)^[ \t]*(?:FOR|WHILE)\b", self.code):  # a loop body's moves run once per pass: read by the grammar
            in_loop = loop_body_lines(self.code)
            for key in ("lits", "named"):
                self._shapes[key] = self._shapes[key].subset(~in_loop[self._shapes[key].line])
        decls = self._shapes["decls"]
        if len(decls):
            values, spans, conf = self._bulk_literals(decls.span("lit")[0])
            for i, name in enumerate(decls.group("name")):
                self.points[name.upper()] = (values[i], spans[i], conf[i])

    def statements(self) -> None:
        """Every statement the bulk shapes leave, through the grammar, in module order."""
        skip = np.zeros(len(self.lines.starts), bool)
        for matches in self._shapes.values():
            skip[matches.line] = True
        self._skip = skip
        self._slow(skip)

    def bulk_moves(self) -> None:
        """One-line MoveL/MoveJ to a literal or a named target, read in bulk; then the
        targets the grammar read."""
        lits, named = self._shapes["lits"], self._shapes["named"]
        if len(lits):
            values, spans, conf = self._bulk_literals(lits.span("lit")[0])
            self._bulk_rows(lits, values, spans, conf, np.full(len(lits), "", dtype=object))
        if len(named):
            codes, texts = named.factorize("name")
            names = [t.replace(" ", "").replace("\t", "") for t in texts]
            nan_v, nan_s, nan_c = np.full(NF, np.nan), np.full((NF, 3), -1, np.int64), np.full(4, np.nan)
            found = [self.points.get(n.upper()) for n in names]
            for n, f in zip(names, found):
                if f is None:
                    self.builder.notes.append(f"target {n} is not declared as a literal robtarget in this module")
            values = np.array([f[0] if f else nan_v for f in found])[codes]
            spans = np.array([f[1] if f else nan_s for f in found])[codes]
            conf = np.array([f[2] if f else nan_c for f in found])[codes]
            self._bulk_rows(named, values, spans, conf, np.array(names, dtype=object)[codes])
        if self.rows:  # the grammar's targets, after the bulk ones (the builder sorts by order)
            cols = {k: np.array([r[k] for r in self.rows], dtype=object if k == "name" else None) for k in self.rows[0]}
            order, at = cols.pop("order"), cols.pop("at")
            self.builder.add_block(order + self.order_base, line=self.lines.line(at), file=np.full(len(order), self.index), **cols)

    def _bulk_rows(self, matches, values, spans, conf, names):
        def per_row(group, convert, dtype=None):
            codes, texts = matches.factorize(group)
            return np.array([convert(t) for t in texts], dtype=dtype)[codes]

        tool_idx = per_row("tool", lambda t: self._frame_index(t, self.tools, self.builder.tool_index), np.int32)
        wobj_idx = per_row("wobj", lambda t: self._frame_index(t or "wobj0", self.wobjs, self.builder.frame_index), np.int32)
        self.builder.add_block(
            matches.start + self.order_base,
            file=np.full(len(matches), self.index),
            kind=per_row("mv", lambda t: _MOVE_KIND[t.upper()], np.int8),
            line=matches.line + 1,
            values=values,
            spans=spans,
            conf=conf,
            speed=per_row("speed", _speed, float),
            zone=per_row("zone", _zone, float),
            tool=tool_idx,
            frame=wobj_idx,
            resolved=~np.isnan(values[:, :3]).any(axis=1),
            name=names,
        )

    @staticmethod
    def _frame_index(name: str, table: dict, register) -> int:
        """The builder's index of a tool or work object (its transform, or unknown, from the module's declarations)."""
        return register(name, table.get(name.upper()))

    # ----------------------------------------------------------- slow path
    def _statements(self, skip: np.ndarray):
        """(start offset, end offset) of each statement outside the bulk lines (``skip``, by line).

        RAPID is free-form: a statement ends with ';', or is a block line. A block head
        ends where its own syntax ends: IF/ELSEIF/WHILE/FOR at THEN/DO (an IF without THEN
        is the one-statement form and ends at ';'), PROC/FUNC/ERROR when its parentheses
        close, CASE/DEFAULT at ':'. A one-statement IF whose statement is a bulk line takes
        that line in (the bulk path has read its move)."""
        code = self.code
        pending, closer, depth = None, ";", 0
        header = False  # the %%% ... %%% block of old .prg files
        starts = self.lines.starts
        previous = -1
        for li in np.nonzero(~skip)[0].tolist():
            start = int(starts[li])
            if pending is not None and not header and li > previous + 1:
                if closer != "head":
                    raise self.lines.error(self.doc.path, pending, "statement not terminated (missing ';')")  # a bulk line came first
                yield pending, self._line_end(previous + 1)  # IF cond <newline> bulk move;
                pending = None
            previous = li
            if code.startswith("%%%", start):
                header = not header
                continue
            if header:
                continue
            line_end = self._line_end(li)
            for piece_start, end in _pieces(code, start, line_end):
                line = code[piece_start:end]
                stripped = line.strip()
                if not stripped or stripped.startswith("%%%"):
                    continue
                if pending is None:
                    first = piece_start + (len(line) - len(line.lstrip()))
                    closer, depth = _closer(line), 0
                depth += line.count("(") - line.count(")")
                if _complete(stripped, closer, depth):
                    yield (pending if pending is not None else first), end
                    pending = None
                elif pending is None:
                    pending = first
        if pending is not None:
            raise self.lines.error(self.doc.path, pending, "statement not terminated (missing ';')")

    def _line_end(self, li: int) -> int:
        end = self.code.find("\n", int(self.lines.starts[li]))
        return len(self.code) if end < 0 else end

    def _slow(self, skip: np.ndarray) -> None:
        g = grammar("rapid")
        stack: list[tuple[str, int]] = []
        for start, end in self._statements(skip):
            text = self.code[start:end]
            tree = parse_statement(g, text, self.lines, self.doc.path, start, "RAPID statement")
            if tree.children:
                self._statement(tree.children[0], start, stack)
        if stack:
            want, where = stack[-1]
            raise self.lines.error(self.doc.path, where, f"block opened here is never closed (missing {want if want != 'ENDROUTINE' else 'ENDPROC'})")

    def _statement(self, node, start: int, stack) -> None:
        kind = node.data if isinstance(node, Tree) else None
        if self._loops and self._loops[-1].kind == "while" and kind in ("while_open", "endwhile"):
            top = self._loops[-1]
            if kind == "while_open" or top.inner_whiles:
                top.inner_whiles += 1 if kind == "while_open" else -1
                top.body.append((node, start))
                return
            stack.pop()
            self._run_while(self._loops.pop(), stack)
            return
        if self._loops and kind not in ("for_open", "endfor"):
            self._loops[-1].body.append((node, start))  # run when the outermost FOR closes
            return
        if kind == "while_open" and self._straight(stack) and self._track_locals:
            stack.append(("ENDWHILE", start))
            self._loops.append(Loop(node, start, kind="while"))
            return
        if kind == "while_open":
            self._forget_locals()  # a loop listed once: its body's changes hold from its first line on
        if kind == "for_open":
            stack.append(("ENDFOR", start))
            self._loops.append(Loop(node, start))
            return
        if kind == "endfor" and self._loops and stack and stack[-1][0] == "ENDFOR":
            stack.pop()
            loop = self._loops.pop()
            if self._loops:
                self._loops[-1].body.append(loop)
            else:
                self._loop_order = loop.start  # the passes' rows keep their execution order there
                self._run_loop(loop, stack)
                self._loop_order = None
            return
        if kind in _OPEN:
            stack.append((_OPEN[kind], start))
            if kind == "routine_open":
                self._routine(node)
                self._locals, self._in_routine = {}, True
                self.routine_lines.append((self.index, int(self.lines.line(start))))
        elif kind in _CLOSE:
            if stack and stack[-1][0] != _CLOSE[kind] and any(w == _CLOSE[kind] for w, _ in stack):
                want, where = stack[-1]
                raise self.lines.error(self.doc.path, where, f"block opened here is never closed (missing {want if want != 'ENDROUTINE' else 'ENDPROC'} before line {self.lines.line(start)})")
            if not stack or stack[-1][0] != _CLOSE[kind]:
                expected = stack[-1][0] if stack else "nothing open"
                raise self.lines.error(self.doc.path, start, f"{self.code[start:start + 12].split()[0]} does not close the open block (expected {expected})")
            stack.pop()
            if kind == "routine_close":
                self._locals, self._in_routine = {}, False
        elif kind in ("elseif", "else_") and (not stack or stack[-1][0] != "ENDIF"):
            raise self.lines.error(self.doc.path, start, "ELSE outside IF")
        elif kind in ("case", "default") and (not stack or stack[-1][0] != "ENDTEST"):
            raise self.lines.error(self.doc.path, start, "CASE outside TEST")
        elif kind == "decl":
            self._decl(node, start)
        elif kind == "move":
            if not any(s[0] == "ENDROUTINE" for s in stack):
                raise self.lines.error(self.doc.path, start, "motion instruction outside a routine")
            self._move(node, start)
        elif kind == "assign" and self._local_update(node, stack):
            return
        elif kind == "assign" and self._constant_update(node, start, stack):
            return
        elif kind == "assign":
            self.facts.change(str(node.children[0].children[0]), f"{self._where(start)}: {{name}} is assigned")
            self.updates.spoiled.add(str(node.children[0].children[0]).upper())
        elif kind == "call":
            self._call(node, start)
        elif kind == "record_field" and not (stack and stack[-1][0] == "ENDRECORD"):
            self._local_update(node, stack)
            # `name arg;` outside a RECORD is a call with one argument (grammar: same shape as a field)
            name, arg = node.children[0], node.children[1]
            path, lines = self.doc.path, self.lines
            self.facts.calls.append((str(name), [str(arg)], self._where(start), lambda message: lines.error(path, start, message)))
        elif kind == "short_if":
            inner = node.children[-1]
            inner_start = self._span(inner, start)[0]
            if isinstance(inner, Tree) and inner.data == "move" and self._skip[self.lines.line(inner_start) - 1]:
                return  # IF cond <newline> a bulk move: the bulk path has read it
            self._conditional = True
            try:
                self._statement(inner, start, stack)
            finally:
                self._conditional = False

    # ------------------------------------------------ routine-local counters
    def _values(self) -> dict[str, float]:
        """Known nums now: the routine's local counters and the FOR counters bound."""
        if not self._track_locals:  # a GOTO may run a line again with other values
            return dict(self.env)
        return {**{k: v for k, v in self._locals.items() if v is not None}, **self.env}

    def _straight(self, stack) -> bool:
        """Straight-line code of a routine: no block open, no loop pass being run."""
        return [w for w, _ in stack] == ["ENDMODULE", "ENDROUTINE"] and self._loop_order is None and not self._conditional

    def _followable(self, stack) -> bool:
        """Where a constant assignment runs at a known point: straight-line code, or the body
        of FOR loops whose passes are all known (counters bound), no block open in it."""
        if self._straight(stack):
            return True
        plain = [w for w, _ in stack] == ["ENDMODULE", "ENDROUTINE"] and not self._conditional
        return plain and self._loop_order is not None and bool(self.env) and all(np.isfinite(v) for v in self.env.values())

    def _run_at(self, start: int) -> tuple[int, int]:
        """When a statement runs, as (line, tick): its line in straight-line code; in an unrolled
        loop the loop's line and a tick counting the passes' statements (updates.py compares them)."""
        if self._loop_order is None:
            return int(self.lines.line(start)), 0
        self._tick += 1
        return int(self.lines.line(self._loop_order)), self._tick

    def _forget_locals(self) -> None:
        self._locals = dict.fromkeys(self._locals)

    def _constant_update(self, node: Tree, start: int, stack) -> bool:
        """``p1.trans.z := 305;`` / ``p1.trans := [x, y, z];`` of a declared robtarget in a
        routine's straight-line code: recorded to be followed (updates.py); False otherwise."""
        lhs, rhs = node.children[0], node.children[-1]
        parts = [str(c) for c in lhs.children]
        root = parts[0].upper()
        known = root in self.points or root in self.updates.wobj_parts or root in self.updates.tool_parts
        if not (self._followable(stack) and self.routine_lines and known and (len(parts) > 1 or root in self.points)):
            return False
        s, e = self._span(rhs, start)
        sl = self.numbers.between(s, e)
        literal = _literal_numbers(rhs)
        numbers = [(float(v), (self.index, int(a), int(b))) for v, a, b in zip(self.numbers.value[sl], self.numbers.start[sl], self.numbers.end[sl])]
        kind = "wobjdata" if root in self.updates.wobj_parts else "tooldata" if root in self.updates.tool_parts else "robtarget"
        fields = update_fields(parts[1:], numbers, kind) if literal else None
        if fields is None:
            return False
        line = int(self.lines.line(start))
        self.updates.add(parts[0], Update(line, self.index, self.routine_lines[-1], fields, self._run_at(start)))
        self.facts.change(parts[0], f"{self._where(start)}: {{name}} is assigned")  # flagged unless followed (parse_modules)
        return True

    def _local_update(self, node: Tree, stack) -> bool:
        """``v := e`` / ``Incr v`` / ``Decr v`` of a local num: its value in straight-line code,
        unknown elsewhere. True when the statement was such an update (no other effect)."""
        found = counters.update_of(node, set(self._locals))
        if found is None:
            if node.data == "record_field":  # `Instr v;`: an instruction that may write its argument
                written = {str(t).upper() for t in node.children[1:] if isinstance(t, Token)} | {str(t).upper() for c in node.children[1:] if isinstance(c, Tree) for t in c.scan_values(lambda v: isinstance(v, Token))}
                for name in set(self._locals) & written:
                    self._locals[name] = None
            return False
        name, how = found
        value = counters.apply(name, how, self._values()) if self._straight(stack) else float("nan")
        self._locals[name] = None if np.isnan(value) else value
        return True

    def _run_while(self, loop: Loop, stack) -> None:
        """A WHILE of straight-line code: every pass when its count can be worked out (counters.py),
        else its body once with the local nums unknown."""
        known = {k: v for k, v in self._locals.items() if v is not None}
        planned = counters.plan(loop, known, set(self._locals))
        stack.append(("ENDWHILE", loop.start))
        if planned is None:
            self.builder.notes.append(f"{self._where(loop.start)}: the number of passes of this WHILE is not known at post time: its moves are listed once")
            self._forget_locals()
            self._run_body(loop, stack, {})
        else:
            (passes,), updates = planned
            self._loop_order = loop.start
            for _ in range(passes):
                self._run_body(loop, stack, updates)
            self._loop_order = None
        stack.pop()

    def _run_body(self, loop: Loop, stack, updates: dict) -> None:
        for k, item in enumerate(loop.body):
            if k in updates:
                name, how = updates[k]
                self._locals[name] = counters.apply(name, how, self._values())
            elif isinstance(item, Loop):
                self._run_loop(item, stack)
            else:
                self._replayed += 1
                if self._replayed > MAX_REPLAYED:
                    raise self.lines.error(self.doc.path, loop.start, f"the loops here run more than {MAX_REPLAYED:,} statements: refused (memory is bounded)")
                self._statement(item[0], item[1], stack)

    def _run_loop(self, loop: Loop, stack) -> None:
        """Every pass of a FOR body, its counter bound (loops.py); once, counter unknown,
        when the count cannot be computed."""
        name, values = for_counter(loop.node, self._values())
        if self._replayed + planned_statements(loop, self._values()) > MAX_REPLAYED:
            raise self.lines.error(self.doc.path, loop.start, f"the FOR loops here run more than {MAX_REPLAYED:,} statements: refused (memory is bounded)")
        if values is None:
            self.builder.notes.append(f"{self._where(loop.start)}: the FOR count is not known at post time: its body's moves are listed once, "
                                      f"and those that use {name} are not resolved")
            values = [float("nan")]
        saved = self.env.get(name)
        for value in values:
            self.env[name] = value
            for item in loop.body:
                if isinstance(item, Loop):
                    self._run_loop(item, stack)
                else:
                    self._replayed += 1
                    self._statement(item[0], item[1], stack)
        if saved is None:
            self.env.pop(name, None)
        else:
            self.env[name] = saved

    def _where(self, offset: int) -> str:
        return f"{self.doc.path}:{self.lines.line(offset)}"

    def _call(self, node: Tree, start: int) -> None:
        """A procedure call: kept for the checks made once every module is read (its
        arguments' data names, in case the procedure writes them)."""
        name = str(node.children[0])
        args = node.children[1].children if len(node.children) > 1 else []
        roots = [_root(a.children[0]) for a in args if a.children and not (isinstance(a.children[0], Tree) and a.children[0].data in _OPTIONAL)]
        for name in set(self._locals) & {str(t).upper() for t in node.scan_values(lambda v: isinstance(v, Token) and v.type == "NAME")}:
            self._locals[name] = None  # an argument the instruction may write
        path, lines = self.doc.path, self.lines
        self.facts.calls.append((name, roots, self._where(start), lambda message: lines.error(path, start, message)))

    def _routine(self, node: Tree) -> None:
        """PROC/FUNC parameters that the routine may write (INOUT, VAR, PERS)."""
        names = [c for c in node.children if isinstance(c, Token) and c.type == "NAME"]
        params = next((c for c in node.children if isinstance(c, Tree) and c.data == "params"), None)
        if not names:
            return
        writable = [any(isinstance(t, Token) and t.type in ("VAR", "PERS", "INOUT", "STORAGE") for t in p.children) for p in (params.children if params else [])]
        self.facts.procs[str(names[-1]).upper()] = writable  # PROC name, FUNC type name, TRAP name

    def _span(self, node, start: int) -> tuple[int, int]:
        if isinstance(node, Token):
            return start + node.start_pos, start + node.end_pos
        return start + node.meta.start_pos, start + node.meta.end_pos

    def _decl(self, node: Tree, start: int) -> None:
        tokens = [c for c in node.children if isinstance(c, Token)]
        names = [t for t in tokens if t.type == "NAME"]
        if len(names) < 2:
            return
        dtype, name = str(names[0]).lower(), str(names[1])
        init = node.children[-1]
        storage = next((str(t).upper() for t in tokens if t.type == "STORAGE"), "")
        if self._in_routine and dtype == "num" and storage == "VAR" and not any(isinstance(c, Tree) and c.data == "dims" for c in node.children):
            value = evaluate(init, self._values()) if isinstance(init, Tree) else float("nan")
            self._locals[name.upper()] = None if np.isnan(value) else value  # no initial value: not assumed
            return
        if not isinstance(init, Tree) or init.data != "aggregate":
            return
        s, e = self._span(init, start)
        has_dims = any(isinstance(c, Tree) and c.data == "dims" for c in node.children)
        if dtype == "robtarget":
            if has_dims:
                for k, elem in enumerate(c for c in init.children if isinstance(c, Tree)):
                    es, ee = self._span(elem, start)
                    lit = self._literal(es, ee, _RT_FIELDS)
                    if lit is not None:
                        self.points[f"{name.upper()}{{{k + 1}}}"] = lit
            else:
                lit = self._literal(s, e, _RT_FIELDS)
                if lit is None:
                    raise self.lines.error(self.doc.path, s, f"robtarget {name} needs 17 numbers")
                self.points[name.upper()] = lit
        elif dtype == "jointtarget":
            lit = self._literal(s, e, _JT_FIELDS)
            if lit is None:
                raise self.lines.error(self.doc.path, s, f"jointtarget {name} needs 12 numbers")
            self.points[name.upper()] = lit
        elif dtype in ("tooldata", "wobjdata"):
            text = self.code[s:e].upper()
            holds = text.lstrip("[ \t").startswith("TRUE")
            sl = self.numbers.between(s, e)
            nums = self.numbers.value[sl]
            if dtype == "tooldata":
                # robhold TRUE: the robot holds the tool (the usual case); FALSE: a stationary tool.
                self.tools[name.upper()] = None if not holds or len(nums) < 7 else _pose(nums[:7])
                if self.tools[name.upper()] is not None:
                    self.updates.tool_parts[name.upper()] = nums[:7].copy()  # tframe (updates.py)
            else:
                fixed = '""' in text.replace(" ", "")  # ufmec: no mechanical unit moves the frame
                # robhold TRUE here: the robot holds the work object (a stationary tool set-up).
                self.wobjs[name.upper()] = None if holds or len(nums) < 14 or not fixed else _pose(nums[:7]) @ _pose(nums[7:14])
                if self.wobjs[name.upper()] is not None:
                    self.updates.wobj_parts[name.upper()] = (nums[:7].copy(), nums[7:14].copy())  # uframe, oframe (updates.py)

    def _target(self, node, start: int, joint: bool = False):
        """(values, spans, conf, offset, offset_span), name of a target expression; NaN values where unknown.

        ``offset`` and ``offset_span``: for Offs(p, dx, dy, dz) the value of p's numbers and
        where they are written (the IR value is p + the offset written in the Offs call)."""
        empty = (np.full(NF, np.nan), np.full((NF, 3), -1, np.int64), np.full(4, np.nan), np.zeros(NF), _no_spans())
        if isinstance(node, Tree) and node.data == "aggregate":
            s, e = self._span(node, start)
            lit = self._literal(s, e, _JT_FIELDS if joint else _RT_FIELDS)
            if lit is None:
                raise self.lines.error(self.doc.path, s, f"a {'jointtarget' if joint else 'robtarget'} literal needs {12 if joint else 17} numbers")
            return (*lit, np.zeros(NF), _no_spans()), ""
        s, e = self._span(node, start)
        text = re.sub(r"\s+", "", self.doc.text[s:e])
        if isinstance(node, Tree) and node.data == "funcall" and str(node.children[0]).upper() == "OFFS":
            args = node.children[1].children if len(node.children) > 1 else []
            base_expr = args[0].children[0] if args else None
            (values, spans, conf, _, _), base_name = self._target(base_expr, start) if base_expr is not None else (empty, "")
            values, spans = values.copy(), spans.copy()
            offset = np.zeros(NF)
            offset_span = _no_spans()
            for k in range(3):
                arg = args[k + 1].children[0] if len(args) > k + 1 else None
                a_s, a_e = self._span(arg, start) if arg is not None else (0, 0)
                sl = self.numbers.between(a_s, a_e)
                literal = isinstance(arg, Tree) and arg.data in ("number", "neg") and sl.stop - sl.start == 1
                computed = evaluate(arg, self._values()) if arg is not None and not literal else float("nan")
                if literal and not np.isnan(values[k]) and not np.isnan(self.numbers.value[sl][0]):
                    delta = float(self.numbers.value[sl][0])
                    offset[k] = values[k]
                    offset_span[k] = spans[k]
                    spans[k] = (self.index, self.numbers.start[sl][0], self.numbers.end[sl][0])
                    values[k] = values[k] + delta
                elif not np.isnan(computed) and not np.isnan(values[k]):
                    # Offs(p, i*10, ...) in an unrolled loop: p's own number is what the text
                    # holds (IR = p.x + offset); passes that need different p.x are refused on write-back.
                    offset[k] = computed
                    values[k] = values[k] + computed
                else:
                    values[k] = np.nan  # an offset the parser cannot evaluate
                    spans[k] = -1
            return (values, spans, conf, offset, offset_span), text
        if isinstance(node, Tree) and node.data == "funcall" and str(node.children[0]).upper() == "RELTOOL":
            return self._reltool(node, start, empty), text
        if isinstance(node, Tree) and node.data == "lvalue":
            key = element_key(node, self._values()) if "{" in text else None
            found = self.points.get(key or text.upper())
            if found is not None:
                return (*found, np.zeros(NF), _no_spans()), text
        self.builder.notes.append(f"{self.doc.path}:{self.lines.line(s)}: target {text} cannot be evaluated from the program text")
        return empty, text

    def _reltool(self, node: Tree, start: int, empty):
        """RelTool(p, dx, dy, dz [Rx] [Ry] [Rz]): offset and turn in the tool frame of p.

        The result is reported but not editable (its numbers mix through p's rotation)."""
        args = node.children[1].children if len(node.children) > 1 else []
        if len(args) < 4:
            return empty
        (values, _, conf, _, _), _ = self._target(args[0].children[0], start)
        deltas = [literal_number(a.children[0]) for a in args[1:4]]
        turns = {"RX": 0.0, "RY": 0.0, "RZ": 0.0}
        for a in args:
            for o in a.children:
                if isinstance(o, Tree) and o.data == "optarg" and len(o.children) > 1:
                    turns[str(o.children[0]).upper()] = literal_number(o.children[1])
        if np.isnan(values[:7]).any() or np.isnan(deltas).any() or np.isnan(list(turns.values())).any():
            return empty
        rot = quat_wxyz_to_matrix(values[3:7][None])[0]
        out = np.full(NF, np.nan)
        out[:3] = values[:3] + rot @ np.array(deltas)
        turned = rot @ rot_x(np.radians(turns["RX"])) @ rot_y(np.radians(turns["RY"])) @ rot_z(np.radians(turns["RZ"]))
        out[3:7] = matrix_to_quat_wxyz(turned[None])[0]
        return out, _no_spans(), conf, np.zeros(NF), _no_spans()

    def _move(self, node: Tree, start: int) -> None:
        mv = str(node.children[0]).upper()
        args = node.children[1].children
        # Positional arguments: those that do not start with an optional \Name argument.
        positional = [a for a in args if a.children and not (isinstance(a.children[0], Tree) and a.children[0].data in _OPTIONAL)]
        options = {}
        for a in args:
            for o in a.children:
                if isinstance(o, Tree) and o.data in _OPTIONAL:  # \WObj?wobj: the caller's, where it gave one
                    key = str(o.children[0]).upper()
                    options[key] = o.children[1] if len(o.children) > 1 else None
        targets, at_speed, at_zone, at_tool = LAYOUTS.get(mv, CIRCULAR_LAYOUT if mv in _CIRC else LINEAR_LAYOUT)
        if len(positional) <= max(at_tool or 0, at_speed, targets[-1]):
            raise self.lines.error(self.doc.path, start, f"{mv} needs target(s), speed, zone and tool")
        kinds = [Kind.CIRC_VIA, Kind.CIRC_END] if mv in _CIRC else [Kind.ABSJ if mv in ("MOVEABSJ", "MOVEEXTJ") else _MOVE_KIND.get(mv, Kind.LINEAR)]
        if mv in SEARCH_POINT:  # the search point is written with where the signal came (SearchL, 'SearchPoint')
            root = _root(positional[SEARCH_POINT[mv]].children[0])
            if root:
                self.facts.change(root, f"{self._where(start)}: {{name}} is written by {mv.title()}")
                self.updates.spoiled.add(root.upper())
        speed_node, tool_node = positional[at_speed], positional[at_tool] if at_tool is not None else None
        zone_node = positional[at_zone] if at_zone is not None else None
        speed = _speed(self._text(speed_node, start))
        if "V" in options and options["V"] is not None:
            speed = literal_number(options["V"])
        zone = _zone(self._text(zone_node, start)) if zone_node is not None else np.nan
        if "Z" in options and options["Z"] is not None:
            zone = literal_number(options["Z"])
        tool = self._text(tool_node.children[0], start) if tool_node is not None else "tool0"  # MoveExtJ moves no robot tool
        wobj = self._text(options["WOBJ"], start) if options.get("WOBJ") is not None else "wobj0"
        tool_idx = self._frame_index(tool, self.tools, self.builder.tool_index)
        wobj_idx = self._frame_index(wobj, self.wobjs, self.builder.frame_index)
        for k, tnode in zip(kinds, [positional[i] for i in targets]):
            (values, spans, conf, offset, offset_span), name = self._target(tnode.children[0], start, joint=k == Kind.ABSJ)
            usable = ~np.isnan(values[7:13]).any() if k == Kind.ABSJ else ~np.isnan(values[:3]).any()
            at = self._span(node, start)[0]
            run_line, run_tick = self._run_at(start)
            self.rows.append(dict(order=at if self._loop_order is None else self._loop_order, at=at, kind=int(k), values=values, spans=spans, conf=conf, offset=offset, name=name, speed=speed, zone=zone,
                                  tool=tool_idx, frame=wobj_idx, resolved=bool(usable), offset_span=offset_span, run_line=run_line, run_tick=run_tick))

    def _text(self, node, start: int) -> str:
        s, e = self._span(node, start)
        return self.doc.text[s:e].strip()
