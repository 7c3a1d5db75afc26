"""The code of VAL3 programs (.pgx): the motions they execute, in order, with the places
of their arguments.

A .pgx is XML holding ``<Program name="...">`` elements whose ``<Code><![CDATA[ ... ]]>``
is the VAL3 source (VAL3 reference manual, "Programs"). postproc follows the statements
from ``begin`` to ``end``: ``movej``/``movel``/``movec`` with points, tools and motion
descriptors from the data file (or ``appro(point, {x,y,z,rx,ry,rz})`` of one), and
``call program()`` into another program of the application. What makes the motions
depend on the run (a motion inside ``if``/``while``/``for``/``do``/``switch``, a call with
arguments, an assignment or ``link`` to a point, frame or tool, a motion instruction
postproc does not model) is a ParseError at its place: nothing is guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from postproc.errors import ParseError

from ...parse.common import LineIndex
from .data import index_text

_PROGRAM = re.compile(r"<Program\b[^>]*?\bname\s*=\s*\"(\w+)\"[^>]*>", re.IGNORECASE)
_CODE = re.compile(r"<Code\s*>\s*<!\[CDATA\[(.*?)\]\]>", re.DOTALL | re.IGNORECASE)
_LINE = re.compile(r"[^\n]*")
_WORD = re.compile(r"[ \t]*([A-Za-z_]\w*)")
_MOTION = re.compile(r"\b(movej|movel|movec)\s*\(")
_OTHER_MOTION = re.compile(r"\b(?!(?:movej|movel|movec)\b)(move\w+|alterMove\w*|alterBegin|alterEnd|link|setFrame)\s*\(")
_NAME_REF = r"([A-Za-z_]\w*)[ \t]*(?:\[[ \t]*(\d+)[ \t]*\])?"
# the bulk of a program: one movej / movel to a named point, nothing else on the line
_PLAIN = re.compile(rf"[ \t]*(?:([A-Za-z_]\w*)[ \t]*=[ \t]*)?(movej|movel)[ \t]*\([ \t]*{_NAME_REF}[ \t]*,[ \t]*{_NAME_REF}[ \t]*,[ \t]*{_NAME_REF}[ \t]*\)[ \t]*\r?$")
_PLAIN_LINES = re.compile("^" + _PLAIN.pattern.replace("\\r?$", "(?=\\r?$)"), re.MULTILINE)  # the same lines, found in a text
_TASK = re.compile(r"\b(taskCreate|taskCreateSync)\b")
_CALL = re.compile(r"[ \t]*call[ \t]+(\w+)[ \t]*\(([^)]*)\)")
_ASSIGN = re.compile(r"[ \t]*([A-Za-z_]\w*)[ \t]*(?:\[[^\]]*\])?[ \t]*(?:\.[ \t]*\w+[ \t]*)*=(?!=)")
_ASSIGN_LINE = re.compile(r"^" + _ASSIGN.pattern, re.MULTILINE)
_REF = re.compile(r"[ \t]*([A-Za-z_]\w*)[ \t]*(?:\[[ \t]*(\d+(?:[ \t]*,[ \t]*\d+)*)[ \t]*\])?[ \t]*$")
_APPRO = re.compile(r"[ \t]*appro[ \t]*\((.*)\)[ \t]*$", re.DOTALL)
_LITERAL = re.compile(r"[ \t]*\{([^{}]*)\}[ \t]*$")

OPENS = {"if": "endIf", "while": "endWhile", "for": "endFor", "do": "until", "switch": "endSwitch"}
CLOSES = {v: k for k, v in OPENS.items()}
GEOMETRY = ("pointRx", "pointRs", "jointRx", "jointRs", "frame", "tool", "trsf", "mdesc")


class Ref(NamedTuple):
    """A data element named in the code: ``name[key]`` (key 0 where no index is written)."""

    name: str
    key: str  # "0" where no index is written; "1,2" in a two-dimensional array
    offset: int  # where the argument starts in the program's file

    @property
    def label(self) -> str:
        return f"{self.name}[{self.key}]"


class PointArg(NamedTuple):
    ref: Ref
    approach: tuple[float, ...] | None = None  # appro(point, {x, y, z, rx, ry, rz}): the trsf


class Motion(NamedTuple):
    word: str  # movej, movel or movec
    file: int  # the program's source index
    offset: int  # the statement's offset in that file
    points: tuple[PointArg, ...]  # one, or movec's via and target
    tool: Ref
    mdesc: Ref


class PlainMotions(NamedTuple):
    """A run of plain motion lines (``_PLAIN``: the bulk of a program) as columns: one row
    per line, each tool and descriptor once (``tools[tool_code[i]]``)."""

    file: int
    movej: np.ndarray  # (M,) bool: movej, else movel
    offset: np.ndarray  # (M,) where each statement (its movej / movel) starts
    point_name: list[str]
    point_key: list[str]
    point_at: np.ndarray  # (M,) where each point argument starts
    tool_code: np.ndarray
    tools: list[Ref]
    mdesc_code: np.ndarray
    mdescs: list[Ref]

    def __len__(self) -> int:
        return len(self.offset)

    def motion(self, i: int) -> Motion:
        """Row i as the Motion the statement-by-statement reading makes of it."""
        point = PointArg(Ref(self.point_name[i], self.point_key[i], int(self.point_at[i])))
        return Motion("movej" if self.movej[i] else "movel", self.file, int(self.offset[i]), (point,), self.tools[self.tool_code[i]], self.mdescs[self.mdesc_code[i]])


@dataclass
class Programs:
    """Every program of the application's sources: name -> (source index, code start, code end)."""

    code: dict[str, tuple[int, int, int]] = field(default_factory=dict)


def find_programs(texts: list[tuple[int, str]]) -> Programs:
    """The programs in the given (source index, .pgx text) pairs."""
    found = Programs()
    for index, text in texts:
        starts = list(_PROGRAM.finditer(text))
        for i, m in enumerate(starts):
            end = starts[i + 1].start() if i + 1 < len(starts) else len(text)
            code = _CODE.search(text, m.end(), end)
            if code:
                found.code.setdefault(m.group(1), (index, code.start(1), code.end(1)))
    return found


def called_programs(text: str) -> list[str]:
    """Names of the programs a .pgx text calls (``call name(...)``), in order, once each."""
    return list(dict.fromkeys(m.group(1) for m in re.finditer(r"\bcall[ \t]+(\w+)[ \t]*\(", text)))


class CodeReader:
    """Walks the programs from one entry program, calls followed, and lists its motions."""

    bulk = True  # False: every line statement by statement (the tests compare the two readings)

    def __init__(self, paths: list[str], texts: list[str], programs: Programs, types: dict[str, str]):
        self.paths, self.texts, self.programs, self.types = paths, texts, programs, types
        self.lines = {i: LineIndex(t) for i, t in enumerate(texts) if t is not None}
        self.motions: list[Motion | PlainMotions] = []
        self._touched: dict[str, bool] = {}
        self._refs: dict[tuple, Ref] = {}  # (name, index) of a tool or descriptor -> its Ref at first use

    def error(self, file: int, offset: int, message: str) -> ParseError:
        return self.lines[file].error(self.paths[file], offset, message)

    def run(self, name: str, stack: tuple[str, ...] = (), where: tuple[int, int] | None = None) -> list[Motion | PlainMotions]:
        if name not in self.programs.code:
            if where is None:
                raise ParseError(self.paths[0], 1, 1, f"no program '{name}' in this file")
            raise self.error(*where, f"program '{name}' is not in the application's folder ({name}.pgx): its motions are not known")
        if name in stack:
            raise self.error(*where, f"'{name}' calls itself (through {' -> '.join(stack)}): how often it runs is not known from the text")
        file, start, end = self.programs.code[name]
        depth: list[tuple[str, int]] = []
        text = self.texts[file]
        motions, types = self.motions, self.types
        # Plain motion lines are matched in one pass; what lies between them is read
        # statement by statement (blocks, calls, anything else), in program order. The gap
        # between two plain lines is their '\n' (or '\r\n'), unless a statement lies there.
        plain = list(_PLAIN_LINES.finditer(text, start, end)) if self.bulk else []
        starts = np.array([m.start() for m in plain] + [end], np.int64)
        ends = np.array([start] + [m.end() for m in plain], np.int64)
        assigned = np.array([m.group(1) is not None and types.get(m.group(1)) in GEOMETRY for m in plain] + [True], bool)
        cuts = np.flatnonzero((starts - ends > 2) | assigned | np.append(True, assigned[:-1]))
        for i, j in zip(cuts[:-1].tolist(), cuts[1:].tolist()):  # plain[i:j]: no statement between
            self._lines(file, text, int(ends[i]), int(starts[i]), depth, stack + (name,))
            if depth or assigned[i]:
                for m in plain[i:j]:
                    self._lines(file, text, m.start(), m.end(), depth, stack + (name,))
            else:
                motions.append(self._plain(file, plain[i:j]))
        self._lines(file, text, int(ends[-1]), end, depth, stack + (name,))
        return motions

    def _plain(self, file: int, plain: list[re.Match]) -> PlainMotions:
        """Plain motion lines as columns. A tool or descriptor is one Ref per name, at its first
        use (where an error about it is reported: the first motion that uses it)."""
        _, word, point, point_key, tool, tool_key, mdesc, mdesc_key = zip(*(m.groups() for m in plain))
        tool_code, tools = self._shared_refs(plain, tool, tool_key, 5)
        mdesc_code, mdescs = self._shared_refs(plain, mdesc, mdesc_key, 7)
        return PlainMotions(file, np.array(word) == "movej", np.array([m.start(2) for m in plain], np.int64), list(point), [k or "0" for k in point_key],
                            np.array([m.start(3) for m in plain], np.int64), tool_code, tools, mdesc_code, mdescs)

    def _shared_refs(self, plain: list[re.Match], names: tuple, keys: tuple, group: int) -> tuple[np.ndarray, list[Ref]]:
        distinct: dict[tuple, int] = {}
        codes = np.array([distinct.setdefault(pair, len(distinct)) for pair in zip(names, keys)], np.int64)
        _, first = np.unique(codes, return_index=True)  # codes count up from 0 in order of first use
        refs = [self._refs.get(pair) or self._refs.setdefault(pair, Ref(pair[0], pair[1] or "0", plain[row].start(group)))
                for pair, row in zip(distinct, first.tolist())]
        return codes, refs

    def _lines(self, file: int, text: str, start: int, end: int, depth: list, stack: tuple[str, ...]) -> None:
        """Read the statements of text[start:end] one line at a time."""
        for m in _LINE.finditer(text, start, end):
            line = _strip_comment(m.group(0))
            if line.strip():
                self._statement(file, m.start(), line, depth, stack)

    def _statement(self, file: int, offset: int, line: str, depth: list, stack: tuple[str, ...]) -> None:
        first = _WORD.match(line)
        word = first.group(1) if first else ""
        if word in OPENS:
            depth.append((word, offset + first.start(1)))
            return
        if word in CLOSES or word in ("else", "case", "default", "begin", "end"):
            if word in CLOSES and depth:
                depth.pop()
            return
        call = _CALL.match(line)
        if call:
            if call.group(1) in self.programs.code and not self._touches(call.group(1), ()):
                return  # a program that neither moves nor changes a point, frame or tool
            self._inside_block(file, offset + _lead(line), depth, "call")
            if call.group(2).strip():
                raise self.error(file, offset + call.start(2), f"call {call.group(1)}(...) with arguments: the motions may depend on them")
            self.run(call.group(1), stack, (file, offset + call.start(1)))
            return
        assign = _ASSIGN.match(line)
        if assign and self.types.get(assign.group(1)) in GEOMETRY:
            raise self.error(file, offset + assign.start(1), f"{assign.group(1)} ({self.types[assign.group(1)]}) is assigned at run time: the motions do not go to the data file's values")
        task = _TASK.search(line)
        if task:
            raise self.error(file, offset + task.start(1), f"{task.group(1)} runs a program as a task beside this one: when its motions run, and in which order with these, is not known from the text")
        for other in _OTHER_MOTION.finditer(line):
            raise self.error(file, offset + other.start(1), f"{other.group(1)}() is not modelled by postproc (the motions or frames it makes are not known from the data)")
        for motion in _MOTION.finditer(line):
            self._inside_block(file, offset + motion.start(), depth, motion.group(1))
            self.motions.append(self._motion(file, offset, line, motion))

    def _touches(self, name: str, seen: tuple[str, ...]) -> bool:
        """True where program ``name`` (or one it calls) may move the arm or change the
        data motions use: a motion, a task, an assignment to a point, frame, tool or
        descriptor, or a call into a program that is not in the application."""
        if name in seen:
            return False  # already being looked at higher up
        if name not in self._touched:
            file, start, end = self.programs.code[name]
            code = "\n".join(_strip_comment(line) for line in self.texts[file][start:end].split("\n"))
            direct = bool(_MOTION.search(code) or _OTHER_MOTION.search(code) or _TASK.search(code)) or any(
                self.types.get(m.group(1)) in GEOMETRY for m in _ASSIGN_LINE.finditer(code))
            callees = [m.group(1) for m in re.finditer(r"\bcall[ \t]+(\w+)", code)]
            self._touched[name] = direct or any(c not in self.programs.code or self._touches(c, seen + (name,)) for c in callees)
        return self._touched[name]

    def _inside_block(self, file: int, offset: int, depth: list, what: str) -> None:
        if depth:
            block, at = depth[-1]
            raise self.error(file, offset, f"{what} inside '{block}' (line {int(self.lines[file].line(at))}): whether and how often it runs is not known from the text")

    def _motion(self, file: int, offset: int, line: str, m: re.Match) -> Motion:
        args = _arguments(line, m.end())
        if args is None:
            raise self.error(file, offset + m.start(), f"{m.group(1)}( is not closed on its line")
        want = 4 if m.group(1) == "movec" else 3
        if len(args) != want:
            raise self.error(file, offset + m.start(), f"{m.group(1)} takes {want} arguments, this one has {len(args)}")
        points = tuple(self._point(file, offset, text, start) for text, start in args[:-2])
        tool = self._ref(file, offset, *args[-2], "tool")
        mdesc = self._ref(file, offset, *args[-1], "motion descriptor")
        return Motion(m.group(1), file, offset + m.start(), points, tool, mdesc)

    def _ref(self, file: int, offset: int, text: str, start: int, what: str) -> Ref:
        m = _REF.match(text)
        if not m:
            raise self.error(file, offset + start + _lead(text), f"this {what} is computed at run time: only a variable of the data file (name or name[index]) is known from the text")
        return Ref(m.group(1), index_text(m.group(2) or "0"), offset + start + m.start(1))

    def _point(self, file: int, offset: int, text: str, start: int) -> PointArg:
        appro = _APPRO.match(text)
        if not appro:
            return PointArg(self._ref(file, offset, text, start, "point"))
        inner = _arguments(appro.group(1) + ")", 0)
        if inner is None or len(inner) != 2:
            raise self.error(file, offset + start + _lead(text), "appro(point, trsf) with other arguments")
        literal = _LITERAL.match(inner[1][0])
        numbers = _numbers(literal.group(1)) if literal else None
        if numbers is None:
            raise self.error(file, offset + start + appro.start(1) + inner[1][1] + _lead(inner[1][0]), "appro's trsf is computed at run time: only a literal {x, y, z, rx, ry, rz} is known from the text")
        ref = self._ref(file, offset, inner[0][0], start + appro.start(1) + inner[0][1], "point")
        return PointArg(ref, numbers)


def _strip_comment(line: str) -> str:
    """The line without its // comment (outside a string), same offsets."""
    if "//" not in line:
        return line
    quoted = False
    for i, ch in enumerate(line):
        if ch == '"':
            quoted = not quoted
        elif not quoted and line.startswith("//", i):
            return line[:i]
    return line


def _lead(text: str) -> int:
    return len(text) - len(text.lstrip())


def _arguments(line: str, start: int) -> list[tuple[str, int]] | None:
    """The top-level comma-separated arguments from ``start`` (just after '(') to the
    matching ')': (text, offset in ``line``) each; None where the parenthesis is not closed."""
    args, level, begin = [], 0, start
    for i in range(start, len(line)):
        ch = line[i]
        if ch in "([{":
            level += 1
        elif ch in ")]}":
            if level == 0:
                args.append((line[begin:i], begin))
                return args if any(a.strip() for a, _ in args) else []
            level -= 1
        elif ch == "," and level == 0:
            args.append((line[begin:i], begin))
            begin = i + 1
    return None


def _numbers(text: str) -> tuple[float, ...] | None:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        return None
    return values if len(values) == 6 else None
