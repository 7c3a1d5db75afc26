"""A Klartext program cut into blocks: block number, statement text and comment, with offsets.

TNC 640 User's Manual, "Programming fundamentals": a block is one line, optionally led by
its block number; ``;`` starts a comment, a line starting with ``*`` is a structure block
(comment); a block ending in ``~`` goes on on the next line (cycle parameters)."""

from __future__ import annotations

import re
from dataclasses import dataclass

_LEAD = re.compile(r"[ \t]*(?:\d+[ \t]+|\d+(?=[A-Z*;]))?", re.IGNORECASE)


@dataclass(frozen=True)
class Block:
    line: int  # 1-based line of the block's first line
    start: int  # offset of the statement (after the block number)
    text: str  # the statement without its comment, continuation lines joined by a blank (same length kept by offsets below)
    lines: int  # how many text lines it spans


def split_blocks(text: str) -> list[Block]:
    """Every block with a statement (comments, structure blocks and blank lines left out)."""
    blocks: list[Block] = []
    pos, line, n = 0, 1, len(text)
    while pos < n:
        end = text.find("\n", pos)
        end = n if end < 0 else end
        first_line = line
        lead = _LEAD.match(text, pos, end).end()
        body = _strip_comment(text[lead:end])
        start = lead
        lines = 1
        # a block ending in '~' continues on the next line(s): cycle parameter lists
        while body.rstrip().endswith("~") and end < n:
            body = body.rstrip()[:-1]
            nxt = text.find("\n", end + 1)
            nxt = n if nxt < 0 else nxt
            cont = _strip_comment(text[end + 1:nxt])
            body = body + " " * (end + 1 - (start + len(body))) + cont  # keeps offsets: text index = start + i
            end = nxt
            lines += 1
        if body.strip() and not body.lstrip().startswith("*"):
            blocks.append(Block(first_line, start, body.rstrip("\r \t"), lines))
        line += lines
        pos = end + 1
    return blocks


def _strip_comment(s: str) -> str:
    """The text before a ';' comment (Klartext has no ';' inside statements but in quoted names)."""
    if ";" not in s:
        return s.rstrip("\r")
    quoted = False
    for i, ch in enumerate(s):
        if ch == '"':
            quoted = not quoted
        elif ch == ";" and not quoted:
            return s[:i]
    return s.rstrip("\r")
