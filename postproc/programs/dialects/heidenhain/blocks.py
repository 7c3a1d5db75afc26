"""A Klartext program cut into blocks: block number, statement text and comment, with offsets.

TNC 640 User's Manual, "Programming fundamentals": a block is one line, optionally led by
its block number; ``;`` starts a comment, a line starting with ``*`` is a structure block
(comment); a block ending in ``~`` goes on on the next line (cycle parameters)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Block:
    line: int  # 1-based line of the block's first line
    start: int  # offset of the statement (after the block number)
    text: str  # the statement without its comment, continuation lines joined by a blank (same length kept by offsets below)
    lines: int  # how many text lines it spans


@dataclass(frozen=True)
class PlainRun:
    """Consecutive lines that are each one plain ``L`` block (read in bulk, parse.plain_run)."""

    first: int  # 0-based line index of the first
    end: int  # one past the last


def split_blocks(text: str, plain: np.ndarray | None = None) -> list[Block | PlainRun]:
    """Every block with a statement (comments, structure blocks and blank lines left out);
    lines flagged in ``plain`` (per line) come as PlainRun items, a run per stretch of them."""
    blocks: list[Block | PlainRun] = []
    lines = text.split("\n")
    n = len(lines)
    if plain is None:
        plain = np.zeros(n, bool)
    starts = np.zeros(n + 1, np.int64)
    np.cumsum(np.fromiter((len(x) + 1 for x in lines), np.int64, n), out=starts[1:])
    # the lines to look at one by one: every line not in a plain run
    todo = np.nonzero(~plain[:n])[0].tolist()
    k, i = 0, 0
    while i < n:
        while k < len(todo) and todo[k] < i:
            k += 1
        if plain[i]:
            j = todo[k] if k < len(todo) else n
            blocks.append(PlainRun(i, j))
            i = j
            continue
        raw = lines[i]
        line_start = int(starts[i])
        i += 1
        body = raw.lstrip(" \t")
        lead = len(raw) - len(body)
        if body[:1].isdigit():  # the block number (TNC writes it; a file may leave it out)
            j = 1
            while j < len(body) and body[j].isdigit():
                j += 1
            rest = body[j:].lstrip(" \t")
            lead += len(body) - len(rest)
            body = rest
        if ";" in body or body.endswith("\r"):
            body = _strip_comment(body)
        start = line_start + lead
        count = 1
        # a block ending in '~' continues on the next line(s): cycle parameter lists
        while body.rstrip().endswith("~") and i < n:
            body = body.rstrip()[:-1]
            cont = _strip_comment(lines[i])
            body = body + " " * (int(starts[i]) - (start + len(body))) + cont  # keeps offsets: text index = start + k
            i += 1
            count += 1
        stripped = body.rstrip(" \t\r")
        if stripped and stripped[0] != "*":
            blocks.append(Block(i - count + 1, start, stripped, count))
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
