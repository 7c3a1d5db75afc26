"""Chunked reading of long G-code programs (postproc.jobs.stream): which lines may be cut
between, and the block that restates the state at a cut.

Body lines change nothing but the position: G0/G1 moves with X Y Z A B C, I J K (tool axis
under G43.5) and F words,
M, S, T and N words, comments. Anything else (G90/G91, G20/G21, work offsets, G43, arcs,
canned cycles, parameters, O-words) ends the part of the program that is cut into chunks.
"""

from __future__ import annotations

import re

import numpy as np

from ...ir import Kind, Toolpath
from ..base import StreamRules, plain_number

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)"
_COMMENT = r"(?:\([^()\n]*\)|;[^\n]*)"
_WORD = rf"(?:[XYZABCFIJKxyzabcfijk][ \t]*{_NUM}|[MmTtNn][ \t]*\d+|[Ss][ \t]*{_NUM}|[Gg]0?[01](?![\d.]))"
MOVE = re.compile(rf"[ \t]*(?:{_WORD}[ \t]*)*[XYZxyz][ \t]*{_NUM}[ \t]*(?:{_WORD}[ \t]*)*(?:{_COMMENT}[ \t]*)*\r?$")
# Checked on every line of a long program, so without backtracking (about 1.5 us a line):
# only these letters and G0/G1, the parser reads the words.
_G01 = r"[Gg]0?[01](?![\d.])"
BODY = re.compile(rf"(?:(?:[ \t\d.+\-XYZABCFIJKMSTNxyzabcfijkmstn]+|{_G01}|\([^()\n]*\)|;[^\n]*)*\r?\n)*")
# BODY reads digits only as \d, but for the G0 / G1 of its motion words: where every G of a
# chunk is one of those, the G word's shape (digits written 0) says as much.
_SHAPE_BODY = re.compile(BODY.pattern.replace(_G01, r"[Gg]0?0(?![\d.])"))


def restate(last: Toolpath, carried: np.ndarray) -> str | None:
    """One absolute block to the target ``last`` (its motion mode, X Y Z, rotary axes, feed),
    or None where it has no complete position."""
    if np.isnan(last.position[0]).any() or (last.ccomp is not None and last.ccomp[0]):
        return None  # no position, or one under G41/G42: the offset path does not restart at a cut
    words = ["G0" if last.kind[0] == Kind.RAPID else "G1"]
    words += [f"{axis}{plain_number(v)}" for axis, v in zip("XYZ", last.position[0])]
    words += [f"{axis}{plain_number(v)}" for axis, v in zip("ABC", last.ext[0, :3]) if not np.isnan(v)]
    words += [f"{axis}{plain_number(v)}" for axis, v in zip("IJK", last.values[0, 3:6]) if not np.isnan(v)]  # G43.5 tool axis
    if not np.isnan(last.speed[0]):
        words.append(f"F{plain_number(last.speed[0])}")
    return " ".join(words)


def body_shape(raw: bytes) -> re.Pattern | None:
    """The body as it reads on line shapes, where every G of ``raw`` is a G0 / G1 word; else None."""
    return _SHAPE_BODY if _only_g0_g1(raw) else None


def _only_g0_g1(raw: bytes) -> bool:
    """Whether every G or g of ``raw`` starts a G0 / G1 word (``_G01``), vectorised over the G's."""
    a = np.frombuffer(raw + b"   ", dtype=np.uint8)
    at = np.flatnonzero((a[:-3] | 32) == ord("g"))
    if not len(at):
        return True
    n1, n2, n3 = a[at + 1], a[at + 2], a[at + 3]
    ends = lambda c: ~(((c >= 48) & (c <= 57)) | (c == 46))  # noqa: E731  (no digit or '.' follows)
    zero_one = lambda c: (c == 48) | (c == 49)  # noqa: E731
    return bool(np.all((zero_one(n1) & ends(n2)) | ((n1 == 48) & zero_one(n2) & ends(n3))))


RULES = StreamRules(move=MOVE, body=BODY, restate=restate, body_shape=body_shape)
