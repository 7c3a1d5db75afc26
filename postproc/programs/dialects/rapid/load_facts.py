"""RAPID: the load statements a program makes, written into the IR by the parser.

``Toolpath.facts["rapid.loads"]`` (``RapidLoads``) holds every ``tooldata`` / ``loaddata``
declaration, ``GripLoad NAME;`` and ``\\TLoad:=NAME`` of the program's modules as written
(commented ones flagged: the payload check has always counted them, ``convert`` never), each
with its file, line and column; ``Toolpath.extras["rapid.grip"]`` (N,) int is the GripLoad in
force at each target (an index into ``RapidLoads.grips``, -1: none). What they mean for the
arm is the controller's (``loads.py``), which reads only these.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError

from ...emit.load_plan import Statement, in_force
from ...ir import Toolpath
from ...parse.common import LineIndex
from ...parse.keyword_scan import KeywordIndex
from ..base import NUMBER

LOADS = "rapid.loads"
GRIP = "rapid.grip"


@dataclass(frozen=True)
class Place:
    file: int  # index into Toolpath.sources
    path: str
    line: int
    column: int
    commented: bool  # a '!' before it on its line
    offset: int  # where it starts in the file's text

    @property
    def at(self) -> str:
        return f"{self.path}:{self.line}:{self.column}"

    @property
    def where(self) -> str:
        return f"{self.path}, line {self.line}"


@dataclass(frozen=True)
class Declared:
    """``tooldata NAME := [...]`` / ``loaddata NAME := [...]``."""

    kind: str  # "tooldata" or "loaddata", as the pattern names it
    name: str  # as written
    numbers: tuple[float, ...]  # every number from '[' to the ';'
    on_flange: bool  # tooldata: robhold TRUE (a stationary tool is not on the flange); loaddata: True
    place: Place


@dataclass(frozen=True)
class Used:
    """``GripLoad NAME;`` or a motion's ``\\TLoad:=NAME``."""

    name: str  # as written
    written: str  # the statement as written, for messages ("GripLoad piece", "\\TLoad:=piece")
    place: Place


@dataclass(frozen=True)
class RapidLoads:
    declared: tuple[Declared, ...]  # per file: its tooldata, then its loaddata, each in text order
    grips: tuple[Used, ...]
    tloads: tuple[Used, ...]
    grip_refused: str = ""  # where the GripLoad in force at a target cannot be told (load_plan.in_force), else ''


_DECLARATIONS = {kind: re.compile(rf"\b{kind}\s+(\w+)\s*:=\s*\[", re.IGNORECASE) for kind in ("tooldata", "loaddata")}
_ROBHOLD = re.compile(r"\s*TRUE", re.IGNORECASE)  # tooldata's first component: held by the robot (on the flange)
_GRIP = re.compile(r"\bGripLoad\s+(\w+)\s*;", re.IGNORECASE)
_TLOAD = re.compile(r"\\TLoad\s*:=\s*(\w+)", re.IGNORECASE)


def with_load_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with ``facts["rapid.loads"]`` and ``extras["rapid.grip"]``."""
    declared, grips, tloads = [], [], []
    for f, doc in enumerate(tp.sources):
        text, index = doc.text, KeywordIndex(doc.text)  # the patterns are tried only where their keyword stands
        place = _Places(tp, f)
        for kind, pattern in _DECLARATIONS.items():
            for m in index.matches(pattern, (kind,)):
                numbers = tuple(float(v) for v in re.findall(NUMBER, text[m.end() : text.find(";", m.end())]))
                on_flange = kind == "loaddata" or _ROBHOLD.match(text, m.end()) is not None
                declared.append(Declared(kind, m.group(1), numbers, on_flange, place(m.start())))
        grips += [Used(m.group(1), m.group(0).strip().rstrip(";"), place(m.start())) for m in index.matches(_GRIP, ("gripload",))]
        tloads += [Used(m.group(1), m.group(0).strip(), place(m.start())) for m in index.matches(_TLOAD, ("\\tload",))]
    grip_at, refused = _grips_in_force(tp, grips)
    loads = RapidLoads(tuple(declared), tuple(grips), tuple(tloads), refused)
    return replace(tp, facts={**tp.facts, LOADS: loads}, extras={**tp.extras, GRIP: grip_at})


def _grips_in_force(tp: Toolpath, grips: list[Used]) -> tuple[np.ndarray, str]:
    """(N,) the index in ``grips`` of the GripLoad in force at each target (-1: none), and the
    reason where that cannot be told ('' where it can). Commented statements do not count."""
    live = [k for k, g in enumerate(grips) if not g.place.commented]
    statements = [Statement(grips[k].place.file, grips[k].place.line, grips[k].place.at, None, grips[k].place.offset) for k in live]
    try:
        at = in_force(tp, statements)
    except InputError as why:  # refused only where the load is asked for (convert), as before it was read from the IR
        return np.full(len(tp), -1, dtype=int), str(why)
    return np.array(live + [-1], dtype=int)[at], ""


class _Places:
    """The ``Place`` of an offset in file ``f`` of ``tp``; the file's lines are indexed at the
    first statement found in it (most files state no load)."""

    def __init__(self, tp: Toolpath, f: int):
        self.f, self.doc, self.lines = f, tp.sources[f], None

    def __call__(self, start: int) -> Place:
        if self.lines is None:
            self.lines = LineIndex(self.doc.text)
        line, column = self.lines.position(start)
        commented = "!" in self.doc.text[start - column + 1 : start]
        return Place(self.f, self.doc.path, line, column, commented, start)
