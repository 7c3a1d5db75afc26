"""KUKA KRL: a .src program with its .dat (and, when present, $config.dat) -> Toolpath.

Lines whose shape is plain bulk data — a move with an inline aggregate
(``LIN {X 1,Y 2,...} C_DIS``), a move to a named point (``PTP XP1``), a point declaration
(``DECL E6POS XP1={...}``) or an array element (``path[12]={...}``) — are recognised by
compiled regular expressions over the whole text and their numbers are read by the
vectorised scanner. Every other line is parsed by the lark grammar ``krl.lark``; the
block structure (DEF/END, IF/ENDIF, ...) is checked with a stack. ``;FOLD`` / ``;ENDFOLD`` are
comments the smartPAD editor folds on; the controller ignores them, and real files cross
them with DEF/END (BAS.SRC) or leave one unbalanced ($config.dat): they are not blocks.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
from lark import Token, Tree

from postproc.robot.frames import abc_to_matrix, abc_to_quat_wxyz, make_transform, matrix_to_abc

from ...ir import NF, Kind, SourceDoc, Toolpath
from ...parse import scan_kernel
from ...parse.common import Builder, LineIndex, Numbers, _ranges, parse_statement, scan_numbers
from ...parse.grammar import grammar, literal_number
from ...parse.line_shapes import LineShapes
from ...parse.name_table import NameTable
from . import calls as call_walk
from .bounds import NamedFor
from .bounds import planned as plan_named_for
from .counters import Assign, CounterLoop, declared_ints
from .counters import plan as plan_counter_loop
from .executed import anchor_offsets, per_call
from .functions import Caller
from .inline_forms import CORRECTION_SWITCHES, FRAME_COMMANDS, Fdat, MachineFrames, declared_fdats, frames_from_fdat, parse_fdat
from .inline_window import Window, code_of
from .jumps import Goto, forward_ranges, skipped, why_not_straight
from .loops import ForLoop, executed_rows, for_values, indexed_by_counter
from .modules import base_name, visibility
from .passes import Passes, followable
from .state import BAS_KEEPS_FRAMES, FRAME_KEYS, Event, Point, Replay, Timeline, _lvalue_text, number

NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
FLD = rf"[A-Za-z][A-Za-z0-9]?[ \t]+{NUM}"
AGG = rf"\{{[ \t]*{FLD}(?:[ \t]*,[ \t]*{FLD})*[ \t]*\}}"
TAIL = r"[ \t]*(?:;[^\n]*)?\r?$"
APPROX = r"(?:[ \t]+(?P<ap>C_DIS|C_PTP|C_VEL|C_ORI|C_SPL))?"
NAME = r"[A-Za-z_$][\w$]*"
FLAGS = re.IGNORECASE | re.MULTILINE
# One pass finds both bulk move shapes: an inline aggregate or a named point.
RE_MOVE = re.compile(rf"^[ \t]*(?P<mv>SPTP|SLIN|PTP|LIN)(?:[ \t]*(?P<agg>{AGG})|[ \t]+(?P<name>{NAME}(?:\[[ \t]*\d+[ \t]*\])?)){APPROX}{TAIL}", FLAGS)
RE_DECL = re.compile(rf"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(?P<type>E6POS|POS|FRAME|E6AXIS|AXIS)[ \t]+(?P<name>{NAME})[ \t]*=[ \t]*(?P<agg>{AGG}){TAIL}", FLAGS)
RE_ELEM = re.compile(rf"^[ \t]*(?P<name>{NAME}\[[ \t]*\d+[ \t]*\])[ \t]*=[ \t]*(?P<agg>{AGG}){TAIL}", FLAGS)


# Aggregate field names -> IR field (0-18) or conf column (100 + k).
_FIELD_CODES = {"X": 0, "Y": 1, "Z": 2, "A": 3, "B": 4, "C": 5, "S": 100, "T": 101}
_FIELD_CODES.update({f"A{i}": 6 + i for i in range(1, 7)})
_FIELD_CODES.update({f"E{i}": 12 + i for i in range(1, 7)})
_LOOKUP = np.full(65536, -1, dtype=np.int16)
for _name, _code in _FIELD_CODES.items():
    key = ord(_name[0]) if len(_name) == 1 else ord(_name[0]) * 256 + ord(_name[1])
    _LOOKUP[key] = _code
    lower = _name.lower()
    key = ord(lower[0]) if len(lower) == 1 else ord(lower[0]) * 256 + ord(lower[1])
    _LOOKUP[key] = _code

_MOVE_KIND = {"PTP": Kind.JOINT, "SPTP": Kind.JOINT, "LIN": Kind.LINEAR, "SLIN": Kind.LINEAR, "SPL": Kind.LINEAR}
_BLOCK_OPEN = {"def": "END", "deffct": "ENDFCT", "defdat": "ENDDAT", "if_open": "ENDIF", "for_open": "ENDFOR", "while_open": "ENDWHILE", "loop_open": "ENDLOOP", "repeat_open": "UNTIL", "switch_open": "ENDSWITCH", "spline_open": "ENDSPLINE"}
_BLOCK_CLOSE = {"endif": "ENDIF", "endfor": "ENDFOR", "endwhile": "ENDWHILE", "endloop": "ENDLOOP", "until": "UNTIL", "endswitch": "ENDSWITCH", "endspline": "ENDSPLINE"}


def _key(name: str) -> str:
    """KRL names are case-insensitive and may have blanks inside brackets (XP[ 1 ])."""
    return name.upper().replace(" ", "").replace("\t", "")


class Symbols:
    """Named points and frames: name -> row of values (NF), spans (NF, 3), conf (4), insert (2).

    Rows are kept in blocks as they arrive (a .dat may declare a million points), joined
    once when first read. Bulk declarations are looked up by ``NameTable`` (vectorised);
    the few the grammar reads go to a dict that takes precedence, since they are read
    after every bulk line. A later declaration of a name wins, as in the controller."""

    def __init__(self):
        self.bulk = NameTable()
        self._bulk_rows: list[np.ndarray] = []  # global row of each bulk name
        self.overlay: dict[str, int] = {}
        self.blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.count = 0
        self._joined: tuple | None = None
        self._bulk_global: np.ndarray | None = None

    def _add_rows(self, values, spans, conf, insert) -> np.ndarray:
        block = (np.asarray(values).reshape(-1, NF), np.asarray(spans).reshape(-1, NF, 3), np.asarray(conf).reshape(-1, 4), np.asarray(insert).reshape(-1, 2))
        self.blocks.append(block)
        self._joined = None
        rows = np.arange(self.count, self.count + len(block[0]))
        self.count += len(rows)
        return rows

    def add_many(self, names: list[str], values, spans, conf, insert):
        rows = self._add_rows(values, spans, conf, insert)
        self.overlay.update(zip(map(_key, names), rows.tolist()))

    def add_spans(self, raw: np.ndarray, name_spans: np.ndarray, values, spans, conf, insert):
        """Rows whose names are spans of a text's bytes (bulk declarations)."""
        self.bulk.add_spans(raw, name_spans)
        self._bulk_rows.append(self._add_rows(values, spans, conf, insert))
        self._bulk_global = None

    def table(self):
        """values (M, NF), spans (M, NF, 3), conf (M, 4), insert (M, 2) of every row, plus a last row for 'not declared'."""
        if self._joined is None:
            missing = (np.full((1, NF), np.nan), np.full((1, NF, 3), -1, np.int64), np.full((1, 4), np.nan), np.full((1, 2), -1, np.int64))
            parts = self.blocks + [missing]
            self._joined = tuple(np.concatenate([p[k] for p in parts]) for k in range(4))
        return self._joined

    def _global(self, local: np.ndarray) -> np.ndarray:
        """Rows of the bulk name table -> rows of the joined table (not declared -> count)."""
        if self._bulk_global is None:  # joined once: the grammar's lines look names up one by one
            self._bulk_global = np.concatenate(self._bulk_rows + [np.zeros(1, np.int64)])
        out = self._bulk_global[np.minimum(local, len(self._bulk_global) - 1)]
        return np.where(local >= self.bulk.count, self.count, out)

    def rows_of_spans(self, raw: np.ndarray, spans: np.ndarray) -> np.ndarray:
        """Row of each named span; ``count`` where the name is not declared."""
        rows = self._global(self.bulk.rows_of_spans(raw, spans))
        if self.overlay:
            table = NameTable()
            keys = list(self.overlay)
            table.add(keys)
            local = table.rows_of_spans(raw, spans)
            found = local < len(keys)
            rows[found] = np.array([self.overlay[k] for k in keys])[local[found]]
        return rows

    def rows(self, names: list[str]) -> np.ndarray:
        """Row of each name in ``table()``; ``count`` where it is not declared (one vectorised
        lookup: a FOR over a 30,000-element array looks its elements up at once)."""
        rows = self._global(self.bulk.rows(names)) if names else np.zeros(0, np.int64)
        if self.overlay:
            over = np.array([self.overlay.get(_key(n), -1) for n in names], np.int64)
            rows = np.where(over >= 0, over, rows)
        return rows

    def get(self, name: str):
        i = self.overlay.get(_key(name))
        if i is None:
            i = int(self._global(self.bulk.rows([name]))[0])
        if i == self.count:
            return None
        values, spans, conf, insert = self.table()
        return values[i], spans[i], conf[i], insert[i]


def _field_codes(raw: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """IR field code of each number from the one- or two-character name before it."""
    p = scan_kernel.prev_nonblank(raw, starts - 1)
    c1 = raw[p].astype(np.int64)
    c0 = np.where(p >= 1, raw[np.maximum(p - 1, 0)], 32).astype(np.int64)
    cm = np.where(p >= 2, raw[np.maximum(p - 2, 0)], 32).astype(np.int64)
    alnum = lambda c: ((c | 32) >= 97) & ((c | 32) <= 122) | ((c >= 48) & (c <= 57))  # noqa: E731
    single = alnum(c1) & ~alnum(c0)
    double = ((c1 >= 48) & (c1 <= 57)) & alnum(c0) & ~alnum(cm)
    key = np.where(single, c1, np.where(double, c0 * 256 + c1, 0))
    return np.where(single | double, _LOOKUP[key], -1)


class _Doc:
    """One source file: its text, lines, numbers and field codes, computed once."""

    def __init__(self, doc: SourceDoc, index: int):
        self.doc = doc
        self.index = index
        self.text = doc.text
        self.lines = LineIndex(doc.text)
        self.numbers: Numbers = scan_numbers(doc.text)
        self.raw = raw = np.frombuffer(doc.text.encode("latin-1"), dtype=np.uint8)
        self._shapes: LineShapes | None = None
        self.codes = _field_codes(raw, self.numbers.start) if len(raw) else np.zeros(0, dtype=np.int16)

    def shapes(self) -> LineShapes:
        if self._shapes is None:
            self._shapes = LineShapes(self.text, self.raw, self.lines.starts)
        return self._shapes

    def aggregates(self, agg_start: np.ndarray, agg_end: np.ndarray):
        """Values (M, NF), spans (M, NF, 3), conf (M, 4), insert (M, 2) of M aggregates, vectorised."""
        m = len(agg_start)
        values = np.full((m, NF), np.nan)
        spans = np.full((m, NF, 3), -1, dtype=np.int64)
        conf = np.full((m, 4), np.nan)
        insert = np.stack([np.full(m, self.index), agg_end - 1], axis=1).astype(np.int64)
        nums = self.numbers
        lo = np.searchsorted(nums.start, agg_start)
        hi = np.searchsorted(nums.start, agg_end)
        rows = np.repeat(np.arange(m), hi - lo)
        idx = _ranges(lo, hi)
        code = self.codes[idx]
        # One flat index per number (row, field) and one scatter per array: a field written
        # twice in one aggregate keeps its last number, as element-wise fancy assignment does.
        f = (code >= 0) & (code < 100)
        at, num = rows[f] * NF + code[f], idx[f]
        values.reshape(-1)[at] = nums.value[num]
        spans.reshape(-1, 3)[at] = np.stack([np.full(len(num), self.index, np.int64), nums.start[num], nums.end[num]], axis=1)
        c = code >= 100
        conf.reshape(-1)[rows[c] * 4 + code[c] - 100] = nums.value[idx[c]]
        return values, spans, conf, insert


def _frame_of(values: np.ndarray) -> np.ndarray:
    """FRAME / POS aggregate values -> 4x4 (missing components are 0)."""
    v = np.nan_to_num(values[:6])
    return make_transform(abc_to_matrix(v[3:6][None])[0], v[:3])


class KrlParser:
    """Parses a program's files: the program first, then its data lists (.dat, $config.dat)."""

    def __init__(self, docs: list[SourceDoc]):
        self.docs = [_Doc(d, i) for i, d in enumerate(docs)]
        self.builder = Builder("krl", "abc", docs)
        self.symbols = Symbols()
        self.events: list[tuple[int, str, object]] = []  # (offset in src, key, value): speed and approximation
        self.changes: list[Event] = []  # points and frames the program changes (see state.py)
        self.timeline = Timeline()
        self._jump_ranges: list[tuple[int, int]] | None = None  # lines of the first DEF a forward GOTO may skip (jumps.py)
        self._jump_why = ""
        self._has_goto = False  # a GOTO of the first DEF that may change what is in force at a target (jumps.py)
        self._gotos: list[Goto] = []
        self._labels: dict[tuple[int | None, str], list[int]] = {}
        self._defs = 0  # DEFs of the program file seen so far: only the first runs straight through
        self.slow_targets: list[tuple] = []
        self.tool_relative: set[tuple[int, int]] = set()  # (file, line) of LIN_REL / PTP_REL ... #TOOL
        self._approx_blocks: list[tuple[np.ndarray, np.ndarray]] = []
        self._inline = _InlineFormState(self.docs)
        self._routine_names: set[str] | None = None  # DEF names of the program file, read at the first call
        self._for_open: list[tuple[int, str, list[int] | None]] = []  # FORs of the program file being read: (line, counter, values)
        self.for_loops: list[ForLoop] = []
        self._counter_open: list[CounterLoop] = []  # WHILE / REPEAT of the program file being read
        self._named_bounds: dict[int, list] = {}  # FOR line -> bound trees naming a variable (bounds.py)
        self._named_fors: list[NamedFor] = []
        self._counter_loops: list[CounterLoop] = []
        self._assigns: list[Assign] = []  # assignments of the program file to plain names (counters.py)
        self._depth = 0  # blocks open around the statement being read (the DEF not counted)
        self.routines: list[call_walk.Routine] = []  # DEF ... END of the program file
        self.calls: list[call_walk.Call] = []  # calls of the program file (other than BAS)
        self._visits: list[call_walk.Visit] = []  # executed copies of the routines (calls.py)
        self._visible: set[str] | None = None  # names another module's data list being read makes visible (modules.py)
        self._for_depth: dict[int, int] = {}  # FOR line -> blocks open around it in its routine
        self._passes = Passes([], 1)  # FORs whose changes are followed pass by pass (passes.py)
        self._hidden: dict[str, str] = {}  # NAME -> file:line of a declaration another module cannot see

    # ---------------------------------------------------------------- data
    def _declarations(self, d: _Doc) -> np.ndarray:
        """Bulk point declarations and array elements of one file; returns the lines they fill.
        In the program an element assignment runs in order: the grammar reads it (an Event).
        Another module's data list gives only what it makes visible and no local name hides."""
        done = np.zeros(len(d.lines.starts), bool)
        for regex in (RE_DECL, RE_ELEM) if d.index else (RE_DECL,):
            matches = d.shapes().match(regex)
            if len(matches) and self._visible is not None:
                done[matches.line] = True
                matches = matches.subset(self._visible_mask(d, matches))
            if not len(matches):
                continue
            values, spans, conf, insert = d.aggregates(*matches.span("agg"))
            self.symbols.add_spans(d.raw, matches.spans["name"], values, spans, conf, insert)
            done[matches.line] = True
        return done

    # ----------------------------------------------------------- statements
    def _visible_mask(self, d: _Doc, matches) -> np.ndarray:
        """Declarations of another module's data list another module sees, not hidden by a local name."""
        names = matches.group("name")
        seen = np.array([base_name(n) in self._visible for n in names], dtype=bool)
        return seen & (self.symbols.rows_of_spans(d.raw, matches.spans["name"]) == self.symbols.count)

    def _sees(self, name: str) -> bool:
        """A name of the file being read may be declared: always in the program's own files;
        in another module's data list when GLOBAL there and not declared locally."""
        return self._visible is None or (base_name(name) in self._visible and self.symbols.get(name) is None)

    def _module_data(self) -> None:
        """Other modules' data lists (--data, modules.py): their GLOBAL points of PUBLIC lists,
        after the program's own files (a local name hides a global one)."""
        for d in self.docs[1:]:
            if d.doc.role != "module":
                continue
            self._visible, hidden = visibility(d.text)
            for name, line in hidden.items():
                self._hidden.setdefault(name, f"{d.doc.path}:{line}")
            self._slow_lines(d, skip=self._declarations(d), is_program=False)
        self._visible = None

    def parse(self) -> Toolpath:
        src = self.docs[0]
        own = [d for d in self.docs[1:] if not d.doc.role.startswith("module")]
        data_lines = {}
        for d in own:
            data_lines[d.index] = self._declarations(d)
        src_decl = self._declarations(src)
        for d in own:
            self._slow_lines(d, skip=data_lines[d.index], is_program=False)
        self._module_data()
        moves = src.shapes().match(RE_MOVE)
        inline = moves.subset(moves.present("agg"))
        named = moves.subset(~moves.present("agg"))
        skip = src_decl.copy()
        skip[moves.line] = True
        self._jump_ranges = self._first_def_jumps(src)
        self._slow_lines(src, skip=skip, is_program=True)
        self._judge_jumps(src)
        self._plan_counter_loops(src)
        self._plan_named_fors(src)
        self._follow_calls(src)
        self._follow_passes(src)
        caller = Caller([d.doc for d in self.docs])
        self.timeline = Replay(self._declared, lambda ev: self._read_agg(src, ev), lambda ev, current: self._frame_value(src, ev, current), caller).run(self.changes, not self._has_goto)
        self.builder.notes.extend(dict.fromkeys(f"{src.doc.path}:{n}" for n in caller.notes))
        self._bulk_moves(src, inline, named)
        return self._finish()

    def _slow_lines(self, d: _Doc, skip: np.ndarray, is_program: bool) -> None:
        g = grammar("krl")
        stack: list[tuple[str, int]] = []
        text = d.text
        starts = d.lines.starts
        for start in starts[~skip].tolist():
            end = text.find("\n", start)
            end = len(text) if end < 0 else end
            raw_line = text[start:end]
            code, _ = _split_comment(raw_line)
            if not code.strip():
                continue
            tree = parse_statement(g, code, d.lines, d.doc.path, start, "KRL statement")
            if not tree.children:
                continue
            self._where = self._context(stack, start)
            if is_program and self._jump_ranges and skipped(self._jump_ranges, int(d.lines.line(start))):
                self._where = (self._where[0], False, self._where[2])  # a GOTO may skip it (jumps.forward_ranges)
            self._depth = sum(want not in ("END", "ENDFCT", "ENDDAT", "ENDFOLD") for want, _ in stack)
            self._statement(d, tree.children[0], start, stack, is_program)
        if stack:
            want, where = stack[-1]
            raise d.lines.error(d.doc.path, where, f"block opened here is never closed (missing {want})")

    def _context(self, stack, start: int) -> tuple[int, bool, bool]:
        """(offset from which a change made here may apply, straight-line in its routine?, in a
        subprogram?) of a statement: inside a block the controller may run it before or again
        after any line of the outermost block; a subprogram's changes run where it is called
        (calls.py follows the frames; any other change there counts at any time)."""
        blocks = [where for want, where in stack if want not in ("END", "ENDFCT", "ENDDAT", "ENDFOLD")]
        return (blocks[0], False, self._defs > 1) if blocks else (start, True, self._defs > 1)

    def _close(self, d: _Doc, stack, keyword: str, offset: int) -> None:
        if stack and stack[-1][0] == keyword:
            stack.pop()
            return
        if any(want == keyword for want, _ in stack):
            # It closes an outer block: the inner one was never closed.
            want, where = stack[-1]
            raise d.lines.error(d.doc.path, where, f"block opened here is never closed (missing {want} before line {d.lines.line(offset)})")
        expected = stack[-1][0] if stack else "nothing open"
        raise d.lines.error(d.doc.path, offset, f"{keyword} without its opening block (expected {expected})")

    def _statement(self, d: _Doc, node, start: int, stack, is_program: bool) -> None:
        kind = node.data if isinstance(node, Tree) else None
        if kind == "header":
            kw = node.children[0]
            word = str(kw).split()[-1].upper()
            if word in ("DEF", "DEFFCT", "DEFDAT"):
                self._defs += d.index == 0 and word != "DEFDAT"
                stack.append(({"DEF": "END", "DEFFCT": "ENDFCT", "DEFDAT": "ENDDAT"}[word], start))
                if d.index == 0 and word != "DEFDAT":
                    self._routine_opens(d, start)
            else:
                self._close(d, stack, word, start + kw.column - 1)
                if d.index == 0 and word in ("END", "ENDFCT") and self.routines and self.routines[-1].end < 0:
                    end = d.text.find("\n", start)
                    self.routines[-1].end = len(d.text) if end < 0 else end + 1
            return
        if kind in _BLOCK_OPEN:
            stack.append((_BLOCK_OPEN[kind], start))
            self._stack_now = stack
            if is_program:
                self._loop_open(d, node, kind, start)
            return
        if kind in ("else_", "case", "default"):
            if not stack or stack[-1][0] not in ("ENDIF", "ENDSWITCH"):
                raise d.lines.error(d.doc.path, start, f"{kind.rstrip('_').upper()} outside IF/SWITCH")
            return
        if kind in _BLOCK_CLOSE:
            self._close(d, stack, _BLOCK_CLOSE[kind], start + _first_column(node) - 1)
            if kind == "endfor" and is_program and self._for_open:
                line, counter, values = self._for_open.pop()
                end = int(d.lines.line(start))
                if values is not None and _leaves_early(d.text, line, end):  # passes may not all run
                    values = None
                    self.builder.notes.append(f"{d.doc.path}:{line}: the number of passes of this FOR is not known at post time "
                                              "(its body has EXIT, RETURN or GOTO): the motions in its body are listed once")
                self.for_loops.append(ForLoop(line, end, counter, values))
                if line in self._named_bounds:
                    exprs = self._named_bounds.pop(line)
                    names = {_lvalue_text(n) for e in exprs for n in e.iter_subtrees() if n.data == "lvalue"}
                    self._named_fors.append(NamedFor(self.for_loops[-1], exprs, names))
            elif kind in ("endwhile", "until") and is_program and self._counter_open:
                loop = self._counter_open.pop()
                loop.last_line = int(d.lines.line(start))
                loop.condition = loop.condition if kind == "endwhile" else next((c for c in node.children if isinstance(c, Tree)), None)
                self._counter_loops.append(loop)
            return
        if kind == "decl":
            self._decl(d, node, start)
            return
        if kind in ("goto", "label") and d.index == 0:  # judged when the whole file is read (jumps.py)
            name, line = str(node.children[-1] if kind == "goto" else node.children[0]).upper(), int(d.lines.line(start))
            routine = len(self.routines) - 1 if self.routines else None
            if kind == "goto":
                in_loop = any(want in ("ENDFOR", "ENDWHILE", "ENDLOOP", "UNTIL") for want, _ in stack)
                self._gotos.append(Goto(line, name, in_loop, routine))
            else:
                self._labels.setdefault((routine, name), []).append(line)
            return
        if kind == "call" and is_program:
            head = node.children[0] if node.children else None
            name = None
            if isinstance(head, Token) and head.type == "NAME" and str(head).upper() != "BAS":
                name = str(head).upper()
            elif isinstance(head, Token) and (handler := re.search(r"\bDO[ \t]+([A-Za-z_$][\w$]*)[ \t]*\(", str(head), re.IGNORECASE)):
                name = handler.group(1).upper()  # INTERRUPT / TRIGGER ... DO NAME(): runs at a time the text does not give (calls.py)
            if name is not None:
                self.calls.append(call_walk.Call(start, name, self._where, int(d.lines.line(start))))
                if name not in self._file_routines():  # another module may set FDAT_ACT or switch BAS.SRC's corrections on
                    self._inline.fdat_act, self._inline.initmov_ran = None, False
            self._bas(d, node, start)
            return
        if kind == "assignment":
            self._assignment(d, node, start)
            return
        if kind == "motion" and is_program:
            self._motion(d, node, start)
            return
        if kind == "motion":
            raise d.lines.error(d.doc.path, start, "motion statement in a data file")

    def _file_routines(self) -> set[str]:
        if self._routine_names is None:
            defs = re.finditer(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT[ \t]+\w+)?[ \t]+(\w+)", self.docs[0].text, re.IGNORECASE | re.MULTILINE)
            self._routine_names = {m.group(1).upper() for m in defs}
        return self._routine_names

    def _routine_opens(self, d: _Doc, start: int) -> None:
        """A DEF / DEFFCT of the program file; a subprogram starts with FDAT_ACT not known
        (it is set by whoever calls it)."""
        m = re.match(r"[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT[ \t]+\w+)?[ \t]+(\w+)", d.text[start:start + 300], re.IGNORECASE)
        self.routines.append(call_walk.Routine(m.group(1) if m else "?", start, -1))
        if self._defs > 1:
            self._inline.fdat_act = None

    def _plan_counter_loops(self, src: _Doc) -> None:
        """WHILE / REPEAT over a counter run pass by pass (counters.py); any other listed once, noted."""
        if not self._counter_loops:
            return
        lines = src.text.split("\n")
        main = self.routines[0] if self.routines else None
        local_ints = declared_ints(src.text[main.start:main.end if main.end > 0 else len(src.text)]) if main else set()
        calls_text = [(c.line, _split_comment(lines[c.line - 1])[0]) for c in self.calls]
        for loop in self._counter_loops:
            body = [_split_comment(code)[0] for code in lines[loop.first_line:loop.last_line - 1]]
            planned, why = plan_counter_loop(loop, self._assigns, local_ints, body, calls_text) if not self._has_goto else (None, "the program has a GOTO that may jump")
            if planned is not None:
                self.for_loops.append(planned)
                continue
            self.builder.notes.append(f"{src.doc.path}:{loop.first_line}: the number of passes of this {loop.kind} is not known at post time "
                                      f"({why}): the motions in its body are listed once")

    def _plan_named_fors(self, src: _Doc) -> None:
        """FOR I = 1 TO N with N set to a constant: run pass by pass (bounds.py); any other listed once, noted."""
        if not self._named_fors:
            return
        lines = src.text.split("\n")
        main = self.routines[0] if self.routines else None
        local_ints = declared_ints(src.text[main.start:main.end if main.end > 0 else len(src.text)]) if main else set()
        calls_text = [(c.line, _split_comment(lines[c.line - 1])[0]) for c in self.calls]
        for named in self._named_fors:
            loop, why = plan_named_for(named, self._assigns, local_ints, calls_text, self._has_goto)
            if loop is not None and _leaves_early(src.text, loop.first_line, loop.last_line):
                loop, why = None, "its body has EXIT, RETURN or GOTO"
            if loop is not None:
                self.for_loops[self.for_loops.index(named.loop)] = loop
                continue
            self.builder.notes.append(f"{src.doc.path}:{named.loop.first_line}: the number of passes of this FOR is not known at post time "
                                      f"({why}): the motions in its body are listed once")

    def _first_def_jumps(self, src: _Doc) -> list[tuple[int, int]] | None:
        """The lines the first DEF's GOTOs may skip (jumps.forward_ranges); None where they are
        not all forward to top-level labels (then no change of that DEF is straight-line)."""
        text = src.text
        m = re.search(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT[ \t]+\w+)?[ \t]", text, re.IGNORECASE | re.MULTILINE)  # as _routine_opens
        if m is None or "GOTO" not in text.upper():
            return None
        end = re.search(r"^[ \t]*END(?:FCT)?\b", text[m.end():], re.IGNORECASE | re.MULTILINE)
        first = text.count("\n", 0, m.start()) + 1
        last = text.count("\n", 0, m.end() + end.start()) + 1 if end else text.count("\n") + 1
        code_lines = [_split_comment(line)[0] for line in text.split("\n")]
        ranges, why = forward_ranges(code_lines, first, last)
        self._jump_why = why
        return ranges

    def _judge_jumps(self, src: _Doc) -> None:
        """A GOTO that may change what is in force at a target (jumps.py): in the first DEF no
        change is straight-line code; in a subprogram, none of that routine's."""
        code_lines = [_split_comment(line)[0] for line in src.text.split("\n")] if self._gotos else []
        for goto in self._gotos:
            why = why_not_straight(goto, self._labels, code_lines)
            if why is None:
                continue
            if goto.routine in (None, 0) and self._jump_ranges:
                self.builder.notes.append(f"{src.doc.path}:{goto.line}: GOTO {goto.label}: {why}: the lines it skips are taken as maybe run "
                                          "(every jump of the first DEF is forward to a label outside any block)")
                continue
            if goto.routine in (None, 0):
                self._has_goto = True
            else:
                self.routines[goto.routine].jumps = True
            self.builder.notes.append(f"{src.doc.path}:{goto.line}: GOTO {goto.label}: {why}: the changes of points and frames in its routine are not taken as straight-line code")

    def _follow_calls(self, src: _Doc) -> None:
        """The program's events at their places in execution order (calls.py): a subprogram's
        frame changes where it is called; after a call to a routine not in the file (or
        recursive, or an INTERRUPT/TRIGGER handler) $BASE and $TOOL are unknown."""
        if len(self.routines) < 2 and not self.calls:
            return
        for r in self.routines:
            r.end = len(src.text) if r.end < 0 else r.end
        handler_names = call_walk.handlers(src.text)
        try:
            self._visits, recursive = call_walk.walk(self.routines, self.calls, handler_names)
        except OverflowError:  # too many executed copies: no call followed, the old rule (any time)
            self.builder.notes.append(f"{src.doc.path}: the calls run more than {call_walk.MAX_VISITS:,} subprogram copies: frames changed in subprograms are not followed")
            handler_names = {r.name.upper() for r in self.routines[1:]}
            self._visits, recursive = call_walk.walk(self.routines, self.calls, handler_names)
        reached = {v.routine for v in self._visits}
        for call in call_walk.unknown_calls(self.routines, self.calls, recursive, handler_names):
            offset, exact, anytime = call.where
            for key in FRAME_KEYS:
                self.changes.append(Event(offset, call.offset, key, False, line=call.line, anytime=anytime))
            if call_walk.routine_of(self.routines, call.offset) in reached:
                self.builder.notes.append(f"{src.doc.path}:{call.line}: {call.callee}() is not a subprogram of this file that is followed "
                                          "(another module, a system routine, a recursive call or an INTERRUPT/TRIGGER handler): $BASE and $TOOL after it are unknown")
        self.changes = call_walk.remap(self.changes, self._visits, self.routines, FRAME_KEYS, handler_names)

    def _follow_passes(self, src: _Doc) -> None:
        """The first DEF's FORs whose body changes are replayed pass by pass (passes.py)."""
        if self._has_goto or not self.for_loops:
            return
        main = self.routines[0] if self.routines else None
        first = (int(src.lines.line(main.start)), int(src.lines.line(max(main.end - 1, main.start)))) if main else (1, len(src.lines.starts))
        loops = followable(src.text, self.for_loops, self.calls, self._for_depth, src.lines.starts, first)
        self._passes = Passes(loops, call_walk.SCALE if self._visits else 1)
        self.changes = self._passes.events(self.changes)

    def _run_at(self, offset: int) -> list[int]:
        """Where a statement of the program file runs (virtual offsets, calls.py), once per
        executed copy of its routine; the offset itself when calls are not followed."""
        return call_walk.virtual_offsets(self._visits, self.routines, offset) if self._visits else [offset]

    def _loop_open(self, d: _Doc, node: Tree, kind: str, start: int) -> None:
        """A FOR of the program file is unrolled at the end when its count is literal (loops.py);
        any other loop keeps its body once, noted."""
        line = int(d.lines.line(start))
        if kind == "for_open":
            exprs = [c for c in node.children if isinstance(c, Tree)]
            bounds = [number(e, lambda _: float("nan")) for e in exprs] + ([] if len(exprs) > 2 else [1.0])
            counter = str(next(c for c in node.children if isinstance(c, Token) and c.type == "NAME")).upper()
            values = for_values(*bounds[:3])
            self._for_open.append((line, counter, values))
            self._for_depth[line] = self._depth  # 0: not inside another block (passes.py)
            if values is not None:
                return
            names = {_lvalue_text(n) for e in exprs for n in e.iter_subtrees() if n.data == "lvalue"} if d.index == 0 else set()
            if names and None not in names:  # FOR I = 1 TO N: decided when the whole program is read (bounds.py)
                self._named_bounds[line] = exprs
                return
        if kind in ("while_open", "repeat_open"):  # run when its counter is known (counters.py), decided at the end
            self._for_depth[line] = self._depth
            condition = next((c for c in node.children if isinstance(c, Tree)), None) if kind == "while_open" else None
            straight = self._defs == 1 and sum(want not in ("END", "ENDFCT", "ENDDAT", "ENDFOLD") for want, _ in self._stack_now) == 1
            self._counter_open.append(CounterLoop(kind.split("_")[0].upper(), line, -1, condition, straight))
            return
        if kind in ("for_open", "loop_open"):
            self.builder.notes.append(f"{d.doc.path}:{line}: the number of passes of this {kind.split('_')[0].upper()} is not known at post time: "
                                      "the motions in its body are listed once")

    # ------------------------------------------------------------ semantics
    def _decl(self, d: _Doc, node: Tree, start: int) -> None:
        for decl in node.children:
            if isinstance(decl, Tree) and decl.data == "declarator" and len(decl.children) >= 2:
                value = decl.children[-1]
                if isinstance(value, Tree) and value.data == "aggregate" and self._sees(str(decl.children[0])):
                    v, sp, c, ins = self._agg(d, value, start)
                    self.symbols.add_many([str(decl.children[0])], [v], [sp], [c], [ins])

    def _agg(self, d: _Doc, node: Tree, start: int):
        """An aggregate of the statement at ``start`` (tree positions are relative to it)."""
        s, e = start + node.meta.start_pos, start + node.meta.end_pos
        v, sp, c, ins = d.aggregates(np.array([s]), np.array([e]))
        # Status and Turn may be written as bits ('B010') or hex ('H22').
        for key, base, digits in re.findall(r"\b([ST])[ \t]+'([BbHh])([0-9A-Fa-f]+)'", d.text[s:e]):
            c[0][0 if key.upper() == "S" else 1] = int(digits, 2 if base.upper() == "B" else 16)
        return v[0], sp[0], c[0], ins[0]

    def _declared(self, key: str) -> Point | None:
        found = self.symbols.get(key)
        return None if found is None else Point(*(np.array(v) for v in found))

    def _read_agg(self, d: _Doc, ev: Event) -> Point:
        return Point(*self._agg(d, ev.rhs, ev.line_offset))

    def _frame_value(self, d: _Doc, ev: Event, current) -> tuple[str, np.ndarray | None]:
        """(name, transform) of a frame expression; the transform is None when unknown."""
        if ev.rhs == "$NULLFRAME":  # TOOL(0) of BAS.SRC
            return "$NULLFRAME", np.eye(4)
        if isinstance(ev.rhs, str):  # BAS(#BASE, n): BASE_DATA[n]
            point = current(ev.rhs)
            known = point is not None and point.known and not np.isnan(point.values[:6]).all()
            return ev.rhs, _frame_of(point.values) if known else None
        if isinstance(ev.rhs, Tree) and ev.rhs.data == "lvalue" and _lvalue_text(ev.rhs) == "$NULLFRAME":
            return "$NULLFRAME", np.eye(4)  # the system's zero frame {X 0, Y 0, Z 0, A 0, B 0, C 0}
        transform, ok, name = self._eval_frame(d, ev.rhs, ev.line_offset, current, ev.env)
        return name, transform if ok else None

    def _eval_frame(self, d: _Doc, node, start: int, current=None, env=None) -> tuple[np.ndarray, bool, str]:
        """A frame expression (aggregate, named frame, a:b) -> (transform, resolved, name);
        ``env``: the FOR counters of the pass (BASE_DATA[I])."""
        if isinstance(node, Tree) and node.data == "geo":
            total, ok, names = np.eye(4), True, []
            for part in node.children:
                t, r, n = self._eval_frame(d, part, start, current, env)
                total, ok = total @ t, ok and r
                names.append(n)
            return total, ok, ":".join(names)
        if isinstance(node, Tree) and node.data == "aggregate":
            v, _, _, _ = self._agg(d, node, start)
            return _frame_of(v), True, self._text(d, node, start)
        key = _lvalue_text(node, env) if isinstance(node, Tree) and node.data == "lvalue" else None
        name = key if env and key else self._text(d, node, start)
        point = current(key) if current is not None and key else self._declared(name)
        if point is None or not point.known or np.isnan(point.values[:6]).all():
            return np.eye(4), False, name
        return _frame_of(point.values), True, name

    def _text(self, d: _Doc, node, start: int) -> str:
        s, e = _node_span(node)
        return d.text[start + s : start + e].strip()

    def _assignment(self, d: _Doc, node: Tree, start: int, where: tuple[int, bool, bool] | None = None) -> None:
        lhs = self._text(d, node.children[0], start).upper().replace(" ", "")
        rhs = node.children[1]
        if d.index != 0:
            if isinstance(rhs, Tree) and rhs.data == "aggregate" and self._sees(lhs):
                v, sp, c, ins = self._agg(d, rhs, start)
                self.symbols.add_many([lhs], [v], [sp], [c], [ins])
            return
        self._change(d, node.children[0], rhs, start, where or self._where)
        if where is None and re.fullmatch(r"[A-Z_]\w*", lhs):
            offset, exact, anytime = self._where
            self._assigns.append(Assign(lhs, int(d.lines.line(start)), self._text(d, rhs, start), exact and not anytime, self._depth, len(self.routines) - 1))
        if lhs.split(".")[0] == "FDAT_ACT":
            self._inline.assign_fdat_act(lhs, rhs, self._text(d, rhs, start), (where or self._where)[1])
        if lhs == "$VEL.CP":
            self.events.append((start, "vel", literal_number(rhs)))
        elif lhs == "$APO.CDIS":
            self.events.append((start, "apo", literal_number(rhs)))

    def _change(self, d: _Doc, lvalue: Tree, rhs, start: int, where: tuple[int, bool, bool]) -> None:
        """An assignment of the program: an Event for the point or frame it may change."""
        text = _lvalue_text(lvalue)
        offset, exact, anytime = where
        line = int(d.lines.line(start))
        rhs_text = self._text(d, rhs, start)
        if text is None:  # an element with a computed index, or deeper: the whole array (or variable) may change
            self.changes.append(Event(offset, start, str(lvalue.children[0]).upper() + "[", False, line=line, anytime=anytime))
            return
        key, _, field = text.partition(".")
        if "." in field:  # XP1.X.Y: not a position component
            field = "?"
        self.changes.append(Event(offset, start, key, exact, field, rhs, rhs_text, line, anytime))

    def _bas(self, d: _Doc, node: Tree, start: int) -> None:
        """BAS(#BASE, n) and BAS(#TOOL, n) set $BASE = BASE_DATA[n] / $TOOL = TOOL_DATA[n]
        (KUKA BAS.SRC); any other BAS command that may touch the frames makes them unknown."""
        m = re.match(r"(?i)\s*BAS\s*\(\s*#(\w+)\s*(?:,\s*([^)]*?))?\s*\)\s*$", str(node.children[0]) if node.children else "")
        if not m or m.group(1).upper() in BAS_KEEPS_FRAMES:
            return
        offset, exact, anytime = self._where
        line = int(d.lines.line(start))
        command, arg = m.group(1).upper(), (m.group(2) or "").strip()
        if command == "INITMOV" and exact and not anytime:
            self._inline.initmov_ran = True
        if command in FRAME_COMMANDS:
            self._frames_from_fdat(d, start, line)
            return
        number = re.fullmatch(r"\d+", arg)
        for key, table in (("$BASE", "BASE_DATA"), ("$TOOL", "TOOL_DATA")):
            if command == key[1:] and number and int(arg) > 0:
                self.changes.append(Event(offset, start, key, exact, "", f"{table}[{int(arg)}]", f"{table}[{int(arg)}]", line, anytime))
            elif command not in ("BASE", "TOOL") or command == key[1:]:
                self.changes.append(Event(offset, start, key, False, line=line, anytime=anytime))

    def _frames_from_fdat(self, d: _Doc, start: int, line: int) -> None:
        """BAS(#PTP_PARAMS / #CP_PARAMS / #FRAMES): $TOOL and $BASE from FDAT_ACT (inline_forms.py)."""
        offset, exact, anytime = self._where
        tool, base, why = self._inline.frames()
        for key, rhs in (("$TOOL", tool), ("$BASE", base)):
            self.changes.append(Event(offset, start, key, exact and rhs is not None, "", rhs, rhs or "", line, anytime))
        if why and exact and not anytime:
            self.builder.notes.append(f"{d.doc.path}:{line}: BAS sets $TOOL and $BASE from FDAT_ACT, which cannot be followed here: {why}")

    def _motion(self, d: _Doc, node: Tree, start: int) -> None:
        move = str(node.children[0]).upper()
        targets = [c for c in node.children if isinstance(c, Tree) and c.data == "target"]
        approx = any(isinstance(c, Tree) and c.data == "approx" for c in node.children)
        relative = move.endswith("_REL")
        base_move = move.replace("_REL", "")
        frame_word = next((str(c.children[0]).upper() for c in node.children if isinstance(c, Tree) and c.data == "rel_frame"), None)
        if frame_word is not None and (not relative or base_move not in ("LIN", "PTP")):
            raise d.lines.error(d.doc.path, start, f"{frame_word} after {move}: only LIN_REL and PTP_REL take #BASE or #TOOL (KSS 8.3 'LIN_REL', 'PTP_REL')")
        if frame_word == "#TOOL":
            self.tool_relative.add((d.index, int(d.lines.line(start))))
        if base_move in ("CIRC", "SCIRC"):
            kinds = [Kind.CIRC_VIA, Kind.CIRC_END]
        else:
            kinds = [_MOVE_KIND[base_move]]
        if len(targets) != len(kinds):
            raise d.lines.error(d.doc.path, start, f"{move} takes {len(kinds)} target(s), got {len(targets)}")
        self._with_clause(d, node, start)
        for k, tnode in zip(kinds, targets):
            expr = tnode.children[0]
            if isinstance(expr, Tree) and expr.data == "aggregate":
                v, sp, c, ins = self._agg(d, expr, start)
                name = ""
            else:
                name = self._text(d, expr, start)
                found = self.symbols.get(name)
                if found is None:
                    v, sp, c, ins = np.full(NF, np.nan), np.full((NF, 3), -1, np.int64), np.full(4, np.nan), np.array([-1, -1])
                    self.builder.notes.append(f"{d.doc.path}:{d.lines.line(start)}: {self._undeclared(name)}")
                else:
                    v, sp, c, ins = found
            self.slow_targets.append((start, int(k), v, sp, c, ins, name, approx, relative))

    def _with_clause(self, d: _Doc, node: Tree, start: int) -> None:
        """``WITH $BASE = .., $TOOL = ..``: the values hold for this motion (KSS 8 spline
        motions); what the controller has after it is not read here, so it is unknown."""
        for clause in (c for c in node.children if isinstance(c, Tree) and c.data == "with_clause"):
            for assignment in (c for c in clause.children if isinstance(c, Tree)):
                key = _lvalue_text(assignment.children[0])
                if key in FRAME_KEYS or (key or "").split(".")[0] in FRAME_KEYS:
                    self._assignment(d, assignment, start, self._where)
                    offset, exact, anytime = self._where
                    self.changes.append(Event(offset + 1 if exact else offset, start + 1, key.split(".")[0], False, line=int(d.lines.line(start)), anytime=anytime))

    def _bulk_moves(self, src: _Doc, inline, named) -> None:
        for moves in (inline, named):
            if not len(moves):
                continue
            codes, words = moves.factorize("mv")
            kinds = np.array([_MOVE_KIND[w.upper()] for w in words])[codes]
            approx = moves.present("ap")
            if moves is inline:
                values, spans, conf, insert = src.aggregates(*moves.span("agg"))
                names = np.full(len(moves), "", dtype=object)
            else:
                rows = self.symbols.rows_of_spans(src.raw, moves.spans["name"])
                missing = rows == self.symbols.count
                for text in sorted(set(moves.subset(missing).group("name"))):
                    self.builder.notes.append(self._undeclared(text))
                values, spans, conf, insert = (column[rows] for column in self.symbols.table())
                names = np.array(moves.group("name"), dtype=object)
            self._collect(moves.start, kinds, values, spans, conf, insert, names, approx, line=moves.line + 1)

    def _undeclared(self, name: str) -> str:
        where = self._hidden.get(base_name(name))
        if where is None:
            return f"point {name} is not declared in the given files"
        return (f"point {name} is not declared in the given files: {where} declares it without GLOBAL or in a data list "
                "that is not PUBLIC, which other modules do not see (KSS 8 'Data lists')")

    def _collect(self, offsets, kinds, values, spans, conf, insert, names, approx, relative=None, line=None):
        self.builder.add_block(
            offsets,
            kind=kinds,
            values=values,
            spans=spans,
            conf=conf,
            insert_at=insert,
            name=np.array(names, dtype=object),
            relative=np.zeros(len(offsets), bool) if relative is None else relative,
            line=self.docs[0].lines.line(offsets) if line is None else line,
        )
        self._approx_blocks.append((offsets, approx))

    def _changed_points(self, tp: Toolpath, virtual: np.ndarray) -> Toolpath:
        """Targets naming a point the program changes take its state where they run (one
        state per executed row; a row no call reaches: not known)."""
        tl = self.timeline
        names = np.asarray(tp.target_name, dtype=object)
        named = np.nonzero(names != "")[0] if (tl.points or tl.arrays) and len(tp) else np.zeros(0, np.int64)
        if not len(named):
            return tp
        keys = np.char.upper(np.char.replace(np.char.replace(names[named].astype(str), " ", ""), "\t", ""))
        changed = np.isin(keys, list(tl.points))
        for prefix in tl.arrays:
            changed |= np.char.startswith(keys, prefix)
        if not changed.any():
            return tp
        values, spans, conf, insert = tp.values.copy(), tp.spans.copy(), tp.conf.copy(), tp.insert_at.copy()
        for k in np.nonzero(changed)[0].tolist():
            r = int(named[k])
            point = tl.point_at(str(keys[k]), int(virtual[r])) if virtual[r] >= 0 else Point.unknown()
            if point is not None:
                values[r], spans[r], conf[r], insert[r] = point.values, point.spans, point.conf, point.insert
        return replace(tp, values=values, spans=spans, conf=conf, insert_at=insert, joints=values[:, 7:13].copy(), ext=values[:, 13:19].copy())

    def _finish(self) -> Toolpath:
        self._collect_slow_targets()
        offsets = np.concatenate([b[0] for b in self._approx_blocks]) if self._approx_blocks else np.zeros(0, np.int64)
        approx = np.concatenate([b[1] for b in self._approx_blocks]) if self._approx_blocks else np.zeros(0, bool)
        perm = np.argsort(offsets, kind="stable")  # the builder orders targets the same way
        offsets, approx = offsets[perm], approx[perm]
        tp = self.builder.build(orientation=False)
        tp, offsets, approx, virtual, envs = self._executed(tp, offsets, approx)
        tp = self._changed_points(tp, virtual)
        frame, tool, speed, cdis = self._program_state(offsets, virtual)
        frame, tool = self._inline_windows(offsets, virtual, frame, tool)
        tp = replace(tp, frame=frame, tool=tool, speed=speed, zone=np.where(approx, cdis, 0.0), **self._tables())
        tp = self._unroll(tp, envs)  # before the poses: partial aggregates and _REL increments follow execution order
        in_tool = np.array([(int(f), int(ln)) in self.tool_relative for f, ln in zip(tp.file, tp.line)], bool) if self.tool_relative else None
        pose, values = _absolute_poses(tp.values, tp.relative, in_tool)
        orientation = np.full((len(tp.values), 4), np.nan)
        ok = ~np.isnan(pose[:, 3:6]).any(axis=1)
        if ok.any():
            orientation[ok] = abc_to_quat_wxyz(pose[ok, 3:6])
        declared = ~np.isnan(values).all(axis=1)
        joint_only = ~np.isnan(values[:, 7:13]).any(axis=1) & np.isnan(values[:, :3]).all(axis=1)
        return replace(
            tp,
            values=values,
            kind=np.where(joint_only, np.int8(Kind.ABSJ), tp.kind).astype(np.int8),
            position=pose[:, :3],
            orientation=orientation,
            resolved=declared,
        )

    def _inline_windows(self, offsets: np.ndarray, virtual: np.ndarray, frame: np.ndarray, tool: np.ndarray):
        """Rows whose frame or tool is unknown but whose own inline form sets both from an FDAT
        the given files prove (inline_window.py) take those frames; not a routine no call from
        the first DEF reaches (virtual offset -1: run from elsewhere, after code not read here)."""
        b, src = self.builder, self.docs[0]
        unknown = ~(np.array(b.frame_known, bool)[frame] & np.array(b.tool_known, bool)[tool]) & (virtual >= 0)
        if not unknown.any() or "fdat_act" not in src.text.lower():
            return frame, tool
        config = next((d.text for d in self.docs if d.doc.role == "config"), None)
        window = Window.read(src.text, config, [d.text for d in self.docs[1:] if d.doc.role.startswith("module")])
        if window.why_not is not None:
            self.builder.notes.append(f"{src.doc.path}: inline forms after a jump or a call are not read where they stand: {window.why_not}")
            return frame, tool
        code_lines = [code_of(x) for x in src.text.split("\n")]
        frame, tool, read_here = frame.copy(), tool.copy(), set()
        lines = src.lines.line(offsets)
        for row in np.nonzero(unknown)[0].tolist():
            line = int(lines[row])
            fold = window.fdat_of(code_lines, line)
            found = self._window_frames(window, fold[0] if fold else None)
            if found is None:
                continue
            read_here.add(f"{src.doc.path}:{fold[1]}: BAS sets")
            (tool_name, tool_t), (base_name_, base_t) = found
            tool[row] = self._register_exact(b.tool_index, b.tool_names, b.tools, b.tool_known, tool_name, tool_t, line)
            frame[row] = self._register_exact(b.frame_index, b.frame_names, b.frames, b.frame_known, base_name_, base_t, line)
        b.notes[:] = [n for n in b.notes if not n.startswith(tuple(read_here))]  # that BAS is read where it stands
        return frame, tool

    def _window_frames(self, window: Window, fdat_text: str | None):
        """((tool name, flange_T_tcp), (base name, base_T_frame)) FRAMES() sets from that FDAT; None if not exact."""
        if fdat_text is None:
            return None
        fdat = parse_fdat(fdat_text) if fdat_text.startswith("{") else self._inline.fdats.get(fdat_text.upper())
        tool, base, _ = frames_from_fdat(fdat, self._inline.machines, True)
        out = []
        for rhs in (tool, base):
            if rhs is None or rhs.split("[")[0] in window.changed:
                return None
            if rhs in ("$NULLFRAME", "$WORLD"):
                if rhs == "$WORLD" and not window.world:
                    return None
                out.append((rhs, np.eye(4)))
                continue
            point = self._declared(rhs)
            if point is None or not point.known or np.isnan(point.values[:6]).any():
                return None
            out.append((rhs, _frame_of(point.values)))
        return out

    @staticmethod
    def _register_exact(register, names, values, known, name: str, transform: np.ndarray, line: int) -> int:
        """The index of a known frame; a name already held with another value (or unknown) gets the line."""
        i = names.index(name) if name in names else None
        if i is not None and not (known[i] and np.allclose(values[i], transform, rtol=0, atol=0)):
            name = f"{name} (inline form on line {line})"
        return register(name, transform, True)

    def _tables(self) -> dict:
        """The builder's frame and tool tables and notes as they are now (registered after build)."""
        b = self.builder
        return dict(tools=np.array(b.tools, dtype=float).reshape(-1, 4, 4), tool_names=tuple(b.tool_names),
                    frames=np.array(b.frames, dtype=float).reshape(-1, 4, 4), frame_names=tuple(b.frame_names),
                    frame_known=np.array(b.frame_known, dtype=bool), tool_known=np.array(b.tool_known, dtype=bool), notes=tuple(b.notes))

    def _loop_split(self) -> tuple[list[ForLoop], list[ForLoop]]:
        """FORs of subprograms (run first, by their own lines) and of the first DEF (run after
        the calls are placed). A subprogram's FOR whose body calls a routine is listed once."""
        if not self._visits:
            return [], self.for_loops
        main, src = self.routines[0], self.docs[0]
        first = int(src.lines.line(main.start)), int(src.lines.line(max(main.end - 1, main.start)))
        sub = [lp for lp in self.for_loops if not first[0] <= lp.first_line <= first[1]]
        called = [lp for lp in sub if lp.values is not None and any(lp.first_line < c.line < lp.last_line for c in self.calls)]
        for lp in called:
            self.builder.notes.append(f"{src.doc.path}:{lp.first_line}: this FOR of a subprogram calls a routine in its body: "
                                      "its motions are listed once (not run pass by pass)")
        return [lp for lp in sub if lp not in called], [lp for lp in self.for_loops if lp not in sub]

    def _executed(self, tp: Toolpath, offsets: np.ndarray, approx: np.ndarray):
        """Rows in execution order: once per executed copy of their routine (executed.py),
        every FOR pass run (loops.py); returns the rows' real and virtual offsets (where
        they run, passes.py) and their loop counters."""
        sub_loops, self._main_loops = self._loop_split()
        rows, envs, virtual = np.arange(len(tp)), [{}] * len(tp), offsets.copy()
        if self._visits:
            rows, envs = self._rows_or_refuse(tp, sub_loops, None)
            src = self.docs[0]
            spans = [(int(src.lines.starts[lp.first_line - 1]), int(src.lines.starts[lp.last_line - 1])) for lp in sub_loops if lp.values is not None]
            picked, virtual = per_call(offsets[rows], self._visits, self.routines, spans)
            rows, envs = rows[picked], [envs[i] for i in picked.tolist()]
            tp, offsets, approx = tp.take(rows), offsets[rows], approx[rows]
        if not any(lp.values is not None for lp in self._main_loops):  # a long CAM file: no copy of its rows
            return tp, offsets, approx, virtual, envs
        lines = self.docs[0].lines.line(anchor_offsets(virtual, offsets)) if self._visits else None
        more_rows, more = self._rows_or_refuse(tp, self._main_loops, lines)
        envs = [{**envs[r], **m} for r, m in zip(more_rows.tolist(), more)]
        virtual = self._passes.rows(virtual[more_rows], envs)
        return tp.take(more_rows), offsets[more_rows], approx[more_rows], virtual, envs

    def _rows_or_refuse(self, tp: Toolpath, loops: list[ForLoop], lines):
        try:
            return executed_rows(tp, loops, lines)
        except OverflowError as exc:
            d = self.docs[0]
            raise d.lines.error(d.doc.path, int(d.lines.starts[int(exc.args[0]) - 1]), "the FOR loops here run more than 1,000,000 motions: refused")

    def _unroll(self, tp: Toolpath, envs: list[dict]) -> Toolpath:
        """Targets NAME[I] of a FOR pass read as the element of that pass (loops.py)."""
        tl = self.timeline
        changed = set(tl.arrays) | {k.split("[")[0] + "[" for k in tl.points if "[" in k}
        if any(envs):  # some row runs in a FOR pass
            tp = indexed_by_counter(tp, envs, self.symbols, changed)
            tp = replace(tp, joints=tp.values[:, 7:13].copy(), ext=tp.values[:, 13:19].copy())  # NAME[I] may be an E6AXIS
        by_counter = [n for n in set(tp.target_name) if re.search(r"\[\s*[A-Za-z_]\w*\s*\]$", n or "")]  # NAME[I]: few names
        now_known = {n for n in by_counter if not np.isnan(tp.values[np.array(tp.target_name, dtype=object) == n]).all(axis=1).any()}
        if now_known:  # NAME[I] read per pass: no longer 'not declared'
            tp = replace(tp, notes=tuple(n for n in tp.notes if not any(f"point {k} is not declared" in n for k in now_known)))
        return tp

    def _collect_slow_targets(self) -> None:
        """The targets the grammar read, as one block."""
        if not self.slow_targets:
            return
        columns = list(zip(*self.slow_targets))  # offset, kind, values, spans, conf, insert, name, approx, relative
        self._collect(*(np.array(c) for c in columns[:6]), list(columns[6]), np.array(columns[7]), np.array(columns[8]))

    def _program_state(self, offsets: np.ndarray, virtual: np.ndarray):
        """Frame and tool index, speed (mm/s) and approximation distance at each target: the
        last $BASE / $TOOL (where the row runs: ``virtual``) / $VEL.CP / $APO.CDIS before it."""
        n = len(offsets)
        frame, tool = np.zeros(n, np.int32), np.zeros(n, np.int32)
        speed, cdis = np.full(n, np.nan), np.zeros(n)
        events = sorted(self.events, key=lambda e: e[0])
        for key in ("$BASE", "$TOOL", "vel", "apo"):
            if key in FRAME_KEYS:
                ev = [(o, f) for o, f in self.timeline.frames[key]]
            else:
                ev = [(o, v) for o, k, v in events if k == key]
            if not ev:
                continue
            if key in FRAME_KEYS:
                register = self.builder.frame_index if key == "$BASE" else self.builder.tool_index
                ids = np.array([register(f.name, None if f.pose is None else f.transform(), f.pose is not None) for _, f in ev])
                (frame if key == "$BASE" else tool)[:] = self._frame_ids(key, virtual, offsets, np.array([o for o, _ in ev]), ids, register)
                continue
            at = np.searchsorted(np.array([o for o, _ in ev]), offsets, side="right") - 1
            has = at >= 0
            if key == "vel":
                speed[has] = np.array([v for _, v in ev], dtype=float)[at[has]] * 1000.0  # $VEL.CP is m/s; the IR keeps mm/s
            else:
                cdis[has] = np.array([v for _, v in ev], dtype=float)[at[has]]
        return frame, tool, speed, cdis

    def _frame_ids(self, key: str, virtual: np.ndarray, offsets: np.ndarray, starts: np.ndarray, ids: np.ndarray, register) -> np.ndarray:
        """The frame (or tool) index in force where each row runs: the last change before it;
        a target of a subprogram run by no call from the first DEF gets an unknown one."""
        k = np.searchsorted(starts, virtual, side="right") - 1
        out = np.where(k >= 0, ids[np.maximum(k, 0)], 0)
        for i in np.nonzero(virtual < 0)[0].tolist():
            r = call_walk.routine_of(self.routines, int(offsets[i]))
            name = self.routines[r].name if r is not None else "?"
            out[i] = register(f"{key} in {name}, which no call from the first DEF reaches (or an INTERRUPT/TRIGGER handler): not known", None, False)
        return out


class _InlineFormState:
    """FDAT_ACT as the main DEF's straight-line code sets it, and whether BAS.SRC's
    corrections are known to be off (see inline_forms.py). A call of a routine of another
    module makes both unknown (FDAT_ACT and the switches are globals it may set)."""

    def __init__(self, docs: list[_Doc]):
        src = docs[0].text
        self.initmov_ran = False
        self.fdat_act = None
        self.anytime = self.corrections_touched = False
        self.fdats: dict = {}
        self.machines = MachineFrames(None)
        if "fdat_act" not in src.lower():  # no inline form: nothing to follow (a 10^6-line CAM file skips the scans)
            return
        for d in (d for d in docs if d.doc.role == "module"):  # another module's: its GLOBAL FDATs only; local names win
            seen, _ = visibility(d.text)
            self.fdats.update({k: v for k, v in declared_fdats([d.text]).items() if k in seen})
        self.fdats.update(declared_fdats([d.text for d in docs if not d.doc.role.startswith("module")]))
        for name in list(self.fdats):  # FP1.TOOL_NO = ...: that FDAT is not followed
            if re.search(rf"^[ \t]*{re.escape(name)}[ \t]*\.[ \t]*\w+[ \t]*=", src, re.IGNORECASE | re.MULTILINE):
                self.fdats[name] = None
        self.machines = MachineFrames(next((d.text for d in docs if d.doc.role == "config"), None))
        defs = list(re.finditer(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT)?[ \t]", src, re.IGNORECASE | re.MULTILINE))
        tail = src[defs[1].start():] if len(defs) > 1 else ""
        # FDAT_ACT set in a subprogram may be set before any line of the main DEF runs.
        self.anytime = bool(re.search(r"^[ \t]*FDAT_ACT\b[^=\n]*=", tail, re.I | re.M))
        self.corrections_touched = bool(re.search(rf"^[ \t]*(?:{'|'.join(CORRECTION_SWITCHES)})[ \t]*=", src, re.I | re.M))

    def assign_fdat_act(self, lhs: str, rhs, rhs_text: str, exact: bool) -> None:
        if not exact:
            self.fdat_act = None
        elif lhs == "FDAT_ACT":
            aggregate = isinstance(rhs, Tree) and rhs.data == "aggregate"
            self.fdat_act = parse_fdat(rhs_text) if aggregate else self.fdats.get(rhs_text.upper().replace(" ", ""))
        elif self.fdat_act is not None and lhs in ("FDAT_ACT.TOOL_NO", "FDAT_ACT.BASE_NO") and re.fullmatch(r"[+-]?\d+", rhs_text.strip()):
            field = "tool_no" if lhs.endswith("TOOL_NO") else "base_no"
            self.fdat_act = Fdat(**{**self.fdat_act.__dict__, field: int(rhs_text)})
        else:
            self.fdat_act = None

    def frames(self):
        return frames_from_fdat(None if self.anytime else self.fdat_act, self.machines, self.initmov_ran and not self.corrections_touched)


def _absolute_poses(values: np.ndarray, relative: np.ndarray, in_tool: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(N, 6) X Y Z A B C of every target, and the IR values with absolute components.

    A partial aggregate ({X 10}) keeps the other components of the previous Cartesian
    target; LIN_REL / PTP_REL components are increments from the previous target (the IR
    holds absolute values; the emitter turns them back into increments). ``in_tool``: rows
    written ``... #TOOL``, whose increments are in the tool frame at the previous target
    (KSS 8.3 'LIN_REL': "#TOOL: the coordinates of the target position refer to the
    coordinate system of the current tool"; #BASE, the default, to the current base): the
    target is the previous pose times the increment's frame, and where the previous pose
    is not known neither is the target."""
    n = len(values)
    cart = ~np.isnan(values[:, :3]).all(axis=1)
    pose = values[:, :6].copy()
    for col in range(6):
        column = np.where(cart, pose[:, col], np.nan)
        last = np.where(~np.isnan(column), np.arange(n), -1)
        np.maximum.accumulate(last, out=last)
        pose[:, col] = np.where(cart & (last >= 0), column[np.maximum(last, 0)], np.nan)
    if relative.any():
        for i in np.nonzero(relative)[0]:
            prev = pose[i - 1] if i > 0 else np.zeros(6)
            if in_tool is not None and in_tool[i]:  # the first motion's start (where the robot is) is not in the text
                pose[i] = _tool_frame_step(prev if i > 0 else np.full(6, np.nan), np.nan_to_num(values[i, :6]))
            else:
                pose[i] = np.nan_to_num(prev) + np.nan_to_num(values[i, :6])
    values = values.copy()
    values[relative, :6] = np.where(np.isnan(values[relative, :6]), np.nan, pose[relative])
    if in_tool is not None and in_tool.any():
        # a tool-frame step moves every component: the IR holds them all (the text keeps its own)
        values[in_tool, :6] = pose[in_tool]
    return pose, values


def _tool_frame_step(prev: np.ndarray, step: np.ndarray) -> np.ndarray:
    """X Y Z A B C of ``prev`` (base frame) moved by ``step`` given in its own tool frame."""
    if np.isnan(prev).any():
        return np.full(6, np.nan)
    moved = make_transform(abc_to_matrix(prev[3:6]), prev[:3]) @ make_transform(abc_to_matrix(step[3:6]), step[:3])
    return np.concatenate([moved[:3, 3], matrix_to_abc(moved[:3, :3])])


def _leaves_early(text: str, first: int, last: int) -> bool:
    """Whether the lines between ``first`` and ``last`` (1-based, exclusive) hold an EXIT,
    RETURN or GOTO (KSS 8 SI: EXIT leaves the loop, RETURN the routine): not every pass may run."""
    body = text.split("\n")[first:last - 1]
    return any(re.search(r"\b(?:EXIT|RETURN|GOTO)\b", _split_comment(code)[0], re.IGNORECASE) for code in body)


def _split_comment(line: str) -> tuple[str, str | None]:
    """Code and comment (from the first ';' outside a string)."""
    if ";" not in line:
        return line.rstrip("\r"), None
    in_string = False
    for i, ch in enumerate(line):
        if ch == '"':
            in_string = not in_string
        elif ch == ";" and not in_string:
            return line[:i], line[i:].rstrip("\r")
    return line.rstrip("\r"), None


def _node_span(node) -> tuple[int, int]:
    if isinstance(node, Token):
        return node.start_pos, node.end_pos
    return node.meta.start_pos, node.meta.end_pos


def _first_column(node) -> int:
    if isinstance(node, Token):
        return node.column
    return node.meta.column if not node.meta.empty else 1
