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
    it while a round or square bracket it opened is open (vectorised over the lines)."""
    raw = np.frombuffer(mask.encode("latin-1"), dtype=np.uint8)
    newlines = np.nonzero(raw == 10)[0]
    line_start = np.concatenate([[0], newlines + 1])
    line_end = np.concatenate([newlines, [len(raw)]])
    depth_step = np.isin(raw, (40, 91)).astype(np.int64) - np.isin(raw, (41, 93)).astype(np.int64)
    depth = np.cumsum(depth_step)
    depth_at_end = np.where(line_end > 0, depth[np.maximum(line_end - 1, 0)] if len(depth) else 0, 0)
    # A line ends a statement where no bracket it opened is still open.
    ends_statement = _statement_ends(depth_at_end) if depth_at_end.any() else np.ones(len(line_start), dtype=bool)
    first = np.concatenate([[0], np.nonzero(ends_statement[:-1])[0] + 1])
    last = np.nonzero(ends_statement)[0]
    if len(last) < len(first):
        last = np.concatenate([last, [len(line_start) - 1]])
    start, end = line_start[first], line_end[last]
    keep = ~_blank_spans(raw, start, end)
    return Statements(start[keep], end[keep], (first + 1)[keep])


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


def _blank_spans(raw: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(S,) True where raw[start:end] holds only blanks (vectorised)."""
    visible = np.cumsum(np.concatenate([[0], (raw > 32).astype(np.int64)]))
    return visible[end] - visible[start] == 0


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
