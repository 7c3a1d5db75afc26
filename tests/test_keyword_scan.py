"""The load statements are found where their keyword stands (``parse.keyword_scan``) and a
statement's routine is bounded between it and its nearest targets (``load_plan``): both give
what the plain scans over the whole text gave."""

from __future__ import annotations

import re

import numpy as np

from postproc.programs.emit.load_plan import _END, _START, _Lines, _motions_in_routine
from postproc.programs.parse.keyword_scan import KeywordIndex

PIECES = ["$LOAD = {M 5, CM {X 1}}", "$load.m = 3", "  BAS(#TOOL, 2)", "LOAD_DATA[3] = {M 7}", "GripLoad p;", "x $LOAD = 1",
          "MoveL t\\TLoad:=q;", "tooldata t := [TRUE", "mytooldata t := [", "\r", "{", "}", "; $LOAD.M = 9", " ", "$LOAD = {", "LOAD_DATA[4] = {"]
PATTERNS = [  # (pattern, keywords, anchored at a line start)
    (re.compile(r"^[ \t]*\$LOAD[ \t]*=[ \t]*\{[^}]*?\bM[ \t]+(\d+)", re.IGNORECASE | re.MULTILINE), ("$load",), True),
    (re.compile(r"^[ \t]*(?:\$LOAD[ \t]*=|\$LOAD\.M|BAS[ \t]*\([ \t]*#TOOL)", re.IGNORECASE | re.MULTILINE), ("$load", "#tool"), True),
    (re.compile(r"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{[^}]*?\bM[ \t]+(\d+)", re.IGNORECASE), ("load_data",), False),
    (re.compile(r"\btooldata\s+(\w+)\s*:=\s*\[", re.IGNORECASE), ("tooldata",), False),
    (re.compile(r"\\TLoad\s*:=\s*(\w+)", re.IGNORECASE), ("\\tload",), False),
]


def test_keyword_matches_are_finditers():
    rng = np.random.default_rng(7)
    for _ in range(1000):
        text = "".join(PIECES[i] + ("\n" if rng.random() < 0.5 else "") for i in rng.integers(0, len(PIECES), int(rng.integers(1, 12))))
        for pattern, keywords, anchored in PATTERNS:
            got = [(m.start(), m.end()) for m in KeywordIndex(text).matches(pattern, keywords, line_start=anchored)]
            assert got == [(m.start(), m.end()) for m in pattern.finditer(text)], (pattern.pattern, text)


def _whole_file_scan(lines, line, rows):
    """The routine around ``line`` read over the whole file, as load_plan did before it was asked at every parse."""
    first = next((k + 1 for k in range(line - 1, -1, -1) if _START.match(lines[k])), 0)
    last = next((k + 1 for k in range(line - 1, len(lines)) if _END.match(lines[k])), len(lines) + 1)
    return bool(((rows > first) & (rows < last)).any())


def test_a_routines_bounds_between_the_statement_and_its_nearest_targets():
    rng = np.random.default_rng(0)
    kinds = ["PROC a()", "ENDPROC", "  MoveL x;", "DEF b()", "END", "x := 1;", "  GripLoad p;", "LOCAL PROC c()", "ENDFUNC"]
    for _ in range(4000):
        n = int(rng.integers(1, 15))
        lines = [kinds[i] for i in rng.integers(0, len(kinds), n)]
        rows = np.sort(rng.integers(1, n + 1, int(rng.integers(0, 5))))
        line = int(rng.integers(1, n + 1))
        want = _whole_file_scan(lines, line, rows)
        newline = "\r\n" if rng.random() < 0.3 else "\n"
        text = newline.join(lines) + newline
        offset = sum(len(x) + len(newline) for x in lines[: line - 1]) + int(rng.integers(0, len(lines[line - 1]) + 1))  # anywhere on its line
        assert _motions_in_routine(_Lines(text, line, offset), line, rows) == want, (lines, rows, line)
        assert _motions_in_routine(_Lines(text, 1, 0), line, rows) == want, (lines, rows, line)
