"""KRL: the payload statements a program makes, written into the IR by the parser.

``Toolpath.facts["krl.loads"]`` (``KrlLoads``) holds what the program's ``$LOAD`` statements
state (``$LOAD = {...}``, ``$LOAD.M = m``, ``$LOAD = LOAD_DATA[n]``, ``BAS(#TOOL, n)``, with
``LOAD_DATA[n]`` as declared in the program's files, e.g. $config.dat), each with its file,
line and column; ``Toolpath.extras["krl.load"]`` (N,) int is the statement in force at each
target (an index into ``KrlLoads.states``, -1: none). The KUKA controller (``loads.py``)
reads only these.

KSS 8 system variables, "$LOAD": {M mass kg (-1: the default load of the machine data),
CM frame of the centre of gravity relative to the flange {X, Y, Z mm, A, B, C deg: the
principal axes of inertia}, J {X, Y, Z} moments of inertia about them, kg m^2}.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError
from postproc.robot.frames import abc_to_quat_wxyz

from ...emit.load_plan import LoadState, Statement, in_force
from ...emit.tool_load import ToolLoad
from ...ir import Toolpath
from ...parse.common import LineIndex
from ...parse.keyword_scan import KeywordIndex
from ..base import NUMBER

LOADS = "krl.loads"
LOAD = "krl.load"


@dataclass(frozen=True)
class KrlLoads:
    # (mass kg, 'FILE, line N[ (LOAD_DATA[n])]') of every mass the program's files give $LOAD,
    # statement by statement (the payload check's)
    masses: tuple[tuple[float, str], ...] = ()
    # the whole load each $LOAD statement sets, in program order, with its file:line:column (convert's);
    # None: BAS(#TOOL, n) whose LOAD_DATA[n] is the controller's, not in the files
    states: tuple[LoadState | None, ...] = ()
    refused: str = ""  # why the load in force at a target cannot be told, else ''


_LOAD_M = re.compile(rf"^[ \t]*\$LOAD\.M[ \t]*=[ \t]*({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_AGG = re.compile(rf"^[ \t]*\$LOAD[ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_REF = re.compile(r"^[ \t]*\$LOAD[ \t]*=[ \t]*LOAD_DATA\[[ \t]*(\d+)[ \t]*\]", re.IGNORECASE | re.MULTILINE)
_BAS_TOOL = re.compile(r"^[ \t]*BAS[ \t]*\([ \t]*#TOOL[ \t]*,[ \t]*(\d+)", re.IGNORECASE | re.MULTILINE)
_LOAD_DATA = re.compile(rf"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE)
_STATEMENT = re.compile(r"^[ \t]*(?:\$LOAD[ \t]*=[ \t]*(\{|LOAD_DATA\[[ \t]*(\d+)[ \t]*\])|\$LOAD\.M[ \t]*=[ \t]*(" + NUMBER + r")"
                        r"|BAS[ \t]*\([ \t]*#TOOL[ \t]*,[ \t]*(\d+))", re.IGNORECASE | re.MULTILINE)
_DECLARED = re.compile(r"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{", re.IGNORECASE)
NAN3 = (float("nan"),) * 3


def with_load_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with ``facts["krl.loads"]`` and ``extras["krl.load"]``."""
    index = [KeywordIndex(doc.text) for doc in tp.sources]  # the patterns are tried only where their keyword stands
    if not any(ix.has("$load", "#tool") for doc, ix in zip(tp.sources, index) if doc.role != "config"):
        return replace(tp, facts={**tp.facts, LOADS: KrlLoads()}, extras={**tp.extras, LOAD: np.full(len(tp), -1, dtype=int)})
    try:
        states, at = _in_force(tp, index)
        refused = ""
    except InputError as why:  # refused only where the load is asked for (convert)
        states, at, refused = [], np.full(len(tp), -1, dtype=int), str(why)
    loads = KrlLoads(tuple(_masses(tp, index)), tuple(states), refused)
    return replace(tp, facts={**tp.facts, LOADS: loads}, extras={**tp.extras, LOAD: at})


def _masses(tp: Toolpath, index: list[KeywordIndex]) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N') of every payload the program's files state."""
    table = {int(m.group(1)): float(m.group(2)) for ix in index for m in ix.matches(_LOAD_DATA, ("load_data",))}
    out = []
    for doc, ix in zip(tp.sources, index):
        if doc.role == "config":
            continue  # LOAD_DATA declarations: only those the program selects count
        where = _Where(doc)
        for pattern in (_LOAD_M, _LOAD_AGG):
            out += [(float(m.group(1)), where(m.start())) for m in ix.matches(pattern, ("$load",), line_start=True)]
        for pattern, keyword in ((_LOAD_REF, "$load"), (_BAS_TOOL, "#tool")):
            out += [(table[int(m.group(1))], where(m.start()) + f" (LOAD_DATA[{m.group(1)}])")
                    for m in ix.matches(pattern, (keyword,), line_start=True) if int(m.group(1)) in table]
    return out


class _Where:
    """Line and column of offsets in one file; its lines are indexed at the first statement
    found in it (most files state no load)."""

    def __init__(self, doc):
        self.doc, self.lines = doc, None

    def position(self, offset: int) -> tuple[int, int]:
        if self.lines is None:
            self.lines = LineIndex(self.doc.text)
        return self.lines.position(offset)

    def __call__(self, offset: int) -> str:
        """'FILE, line N' (the payload check's messages)."""
        return f"{self.doc.path}, line {self.position(offset)[0]}"


def _aggregate(text: str, open_at: int) -> str:
    """The text of the {...} aggregate opening at ``open_at`` (nested braces included)."""
    depth = 0
    for i in range(open_at, len(text)):
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return text[open_at : i + 1]
    return text[open_at:]


def _load_of(agg: str) -> ToolLoad:
    """ToolLoad of a $LOAD aggregate; a component it leaves out (or M -1) is NaN: the controller's."""

    def fields(name):
        m = re.search(rf"\b{name}[ \t]*\{{([^}}]*)\}}", agg, re.IGNORECASE)
        got = {} if m is None else {k.upper(): float(v) for k, v in re.findall(rf"\b([XYZABC])[ \t]+({NUMBER})", m.group(1), re.IGNORECASE)}
        return [got.get(k, float("nan")) for k in "XYZABC"]

    mass = re.search(rf"\bM[ \t]+({NUMBER})", agg, re.IGNORECASE)
    m = float(mass.group(1)) if mass else float("nan")
    cm, j = fields("CM"), fields("J")
    aom = tuple(abc_to_quat_wxyz(np.array(cm[3:]))) if np.isfinite(cm[3:]).all() else (float("nan"),) * 4
    return ToolLoad(m if m >= 0 else float("nan"), tuple(cm[:3]), tuple(j[:3]), tuple(float(v) for v in aom))


def _in_force(tp: Toolpath, index: list[KeywordIndex]) -> tuple[list[LoadState | None], np.ndarray]:
    """The load each $LOAD statement sets (None: the controller's own LOAD_DATA[n]) and (N,) the
    statement in force at each target (-1: none); an InputError where that cannot be told."""
    table = {int(m.group(1)): _load_of(_aggregate(doc.text, m.end() - 1))
             for doc, ix in zip(tp.sources, index) for m in ix.matches(_DECLARED, ("load_data",))}
    statements = []
    for f, (doc, ix) in enumerate(zip(tp.sources, index)):
        if doc.role == "config":
            continue
        where = _Where(doc)
        for m in ix.matches(_STATEMENT, ("$load", "#tool"), line_start=True):
            start = m.start() + len(m.group(0)) - len(m.group(0).lstrip())
            line, column = where.position(start)
            at = f"{doc.path}:{line}:{column}"
            if m.group(1) == "{":
                load = _load_of(_aggregate(doc.text, m.end(1) - 1))
            elif m.group(3) is not None:
                load = ToolLoad(float(m.group(3)), NAN3, NAN3, (float("nan"),) * 4)
            else:
                n = int(m.group(2) or m.group(4))
                if n not in table:
                    if m.group(4):  # BAS(#TOOL, n) without LOAD_DATA[n] here: the controller's $config.dat, unknown here
                        statements.append(Statement(f, line, at, None, start))
                        continue
                    raise InputError(f"{at}: LOAD_DATA[{n}] is not in the program's files (give $config.dat with --data, or --tool-load)")
                load = table[n]
            statements.append(Statement(f, line, at, load, start))
    return [None if s.load is None else LoadState(s.load, None, s.at) for s in statements], in_force(tp, statements)
