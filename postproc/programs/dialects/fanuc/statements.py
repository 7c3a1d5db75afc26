"""The /MN section of a Fanuc TP program (.ls): its numbered statements.

Each statement is ``  N:instruction ;`` on one line, a long one continued on lines that
start with ``:`` (R-30iB Operator's Manual, "Program structure"; a C motion writes its end
point on the continuation line). Statements are returned with their offsets; what they
mean is read in ``postproc.programs.dialects.fanuc.parse``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_START = re.compile(r"[ \t]*\d*[ \t]*:")  # the ASCII loader takes statements without their numbers too
_CONTINUE = re.compile(r"[ \t]*:")
_BLOCK_END = re.compile(r"[ \t]*-+[ \t]*;[ \t]*\r?$")  # '------ ;' closes a point logic block (TB ...,P-SPS): no instruction


@dataclass(frozen=True)
class Statement:
    start: int  # offset of the instruction (after 'N:')
    end: int  # offset of its closing ';'
    text: str  # the instruction, continuation lines joined with their newlines kept


class StatementError(ValueError):
    def __init__(self, offset: int, why: str):
        super().__init__(why)
        self.offset = offset


def statements(text: str, start: int, end: int) -> list[Statement]:
    """The statements of text[start:end] (the /MN body), in order; a line that is neither a
    numbered statement nor a continuation of one is a StatementError at its place."""
    out: list[Statement] = []
    open_at = -1  # offset of the instruction being read, -1 when none
    pos = start
    while pos < end:
        nl = text.find("\n", pos, end)
        line_end = end if nl < 0 else nl
        line = text[pos:line_end]
        if line.strip() and not (open_at < 0 and _BLOCK_END.match(line)):
            head = _START.match(line) if open_at < 0 else _CONTINUE.match(line)
            if head is None:
                why = "a statement is not closed by ';' before this line" if open_at >= 0 else "not a numbered statement ('  N:instruction ;')"
                raise StatementError(pos, why)
            if open_at < 0:
                open_at = pos + head.end()
            body = line.rstrip(" \t\r")
            if body.endswith(";"):
                close = pos + len(body) - 1
                out.append(Statement(open_at, close, text[open_at:close]))
                open_at = -1
        pos = line_end + 1
    if open_at >= 0:
        raise StatementError(open_at, "the last statement of /MN is not closed by ';'")
    return out
