"""URScript text -> logical statements, offsets kept.

URScript is line-oriented: one statement a line, a statement continuing over lines while a
bracket is open; ``#`` starts a comment to the end of the line; strings are in double or
single quotes (URScript manual, "The URScript Programming Language: Syntax"). The code
``mask`` is the text with every comment and string body blanked to spaces (same length), so
that offsets into it are offsets into the file and no word inside a comment or string is
ever read as code."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from numba import njit

_BLANKED = re.compile(r'#[^\n]*|"[^"\n]*"|\'[^\'\n]*\'')


def code_mask(text: str) -> str:
    """``text`` with comments and string bodies blanked to spaces (offsets unchanged)."""
    return _BLANKED.sub(_blank, text)


def _blank(match: re.Match) -> str:
    token = match.group(0)
    if token[0] == "#":
        return " " * len(token)
    return token[0] + " " * (len(token) - 2) + token[-1]


@dataclass(frozen=True)
class Statements:
    """Logical statements of a text: (start, end) offsets in the file, their first line."""

    start: np.ndarray
    end: np.ndarray
    line: np.ndarray


def statements(mask: str) -> Statements:
    """The non-blank logical statements of a masked text: a line, joined with the lines after
    it while a round or square bracket it opened is open."""
    raw = np.frombuffer(mask.encode("latin-1"), dtype=np.uint8)
    newlines = np.nonzero(raw == 10)[0]
    line_start = np.concatenate([[0], newlines + 1]).astype(np.int64)
    line_end = np.concatenate([newlines, [len(raw)]]).astype(np.int64)
    delta, visible = _line_facts(raw, line_start, line_end)
    depth_at_end = np.cumsum(delta)
    ends_statement = _statement_ends(depth_at_end) if depth_at_end.any() else np.ones(len(line_start), dtype=bool)
    first = np.concatenate([[0], np.nonzero(ends_statement[:-1])[0] + 1])
    last = np.nonzero(ends_statement)[0]
    if len(last) < len(first):
        last = np.concatenate([last, [len(line_start) - 1]])
    seen = np.concatenate([[0], np.cumsum(visible)])
    keep = seen[last + 1] - seen[first] > 0  # a statement of blank lines is none
    return Statements(line_start[first][keep], line_end[last][keep], (first + 1)[keep])


@njit(cache=True)
def _line_facts(raw, line_start, line_end):
    """Per line: opening minus closing brackets ( [ ) ], and whether it has a visible character
    (one compiled pass over the text)."""
    n = len(line_start)
    delta = np.zeros(n, np.int64)
    visible = np.zeros(n, np.int64)
    for i in range(n):
        d = 0
        v = 0
        for j in range(line_start[i], line_end[i]):
            c = raw[j]
            if c == 40 or c == 91:
                d += 1
            elif c == 41 or c == 93:
                d -= 1
            if c > 32:
                v = 1
        delta[i] = d
        visible[i] = v
    return delta, visible


def _statement_ends(depth_at_end: np.ndarray) -> np.ndarray:
    """(L,) True where a line closes its statement: the depth is back at (or below) the depth
    the statement started at. A short Python pass over the few lines where depth changes."""
    ends = np.ones(len(depth_at_end), dtype=bool)
    base = 0
    for i, d in enumerate(depth_at_end.tolist()):
        if d > base:
            ends[i] = False
        else:
            base = d
    return ends


def split_arguments(mask: str, start: int, end: int) -> list[tuple[int, int]]:
    """(start, end) of each top-level comma-separated argument of mask[start:end]."""
    spans, depth, at = [], 0, start
    for i in range(start, end):
        c = mask[i]
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif c == "," and depth == 0:
            spans.append((at, i))
            at = i + 1
    spans.append((at, end))
    return spans


def strip(mask: str, start: int, end: int) -> tuple[int, int]:
    """(start, end) without the blanks around mask[start:end]."""
    while start < end and mask[start].isspace():
        start += 1
    while end > start and mask[end - 1].isspace():
        end -= 1
    return start, end


def matching(mask: str, opener: int) -> int:
    """Offset of the bracket that closes the one at ``opener`` (-1 where none)."""
    depth = 0
    for i in range(opener, len(mask)):
        c = mask[i]
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
            if depth == 0:
                return i
    return -1
