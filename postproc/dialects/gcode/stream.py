"""Chunked reading of long G-code programs (postproc.stream): which lines may be cut
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
BODY = re.compile(r"(?:(?:[ \t\d.+\-XYZABCFIJKMSTNxyzabcfijkmstn]+|[Gg]0?[01](?![\d.])|\([^()\n]*\)|;[^\n]*)*\r?\n)*")


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


RULES = StreamRules(move=MOVE, body=BODY, restate=restate)
