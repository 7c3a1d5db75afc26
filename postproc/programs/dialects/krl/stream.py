"""Chunked reading of long KRL programs (postproc.jobs.stream): which lines may be cut between,
and the move that restates the position at a cut.

Body lines are moves to an inline Cartesian aggregate (``LIN {X 1, Y 2, ...} C_DIS``),
comments (not folds) and numeric assignments to motion system variables ($VEL, $ACC,
$APO, $ADVANCE, $OV_PRO). Anything else (a $BASE or $TOOL change, a named point, a joint
target, control structures) ends the part of the program that is cut into chunks.
"""

from __future__ import annotations

import re

import numpy as np

from ...ir import Kind, Toolpath
from ..base import StreamRules, plain_number

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_FIELD = rf"(?:[XYZABCST]|E[1-6])[ \t]+{_NUM}"
_AGG = rf"\{{[ \t]*{_FIELD}(?:[ \t]*,[ \t]*{_FIELD})*[ \t]*\}}"
_COMMENT = r"(?:;(?![ \t]*(?:FOLD|ENDFOLD)\b)[^\n]*)"
_MOVE = rf"[ \t]*(?:S?LIN|S?PTP)[ \t]*{_AGG}(?:[ \t]+C_(?:DIS|PTP|VEL|ORI))?[ \t]*{_COMMENT}?\r?"
MOVE = re.compile(rf"{_MOVE}$", re.IGNORECASE)
# The body is checked on every line of a long program: a looser shape than MOVE, without
# backtracking (the aggregate's inside is not re-read: the parser reads it, and the
# restated target is checked at every cut), about 2 us a line.
_BODY_MOVE = r"S?(?:LIN|PTP)[ \t]*\{[^}\n]*\}[ \t]*(?:C_(?:DIS|PTP|VEL|ORI)[ \t]*)?"
_SETTING = rf"\$(?:VEL|ACC|APO|ADVANCE|OV_PRO)(?:\.\w+)?[ \t]*=[ \t]*{_NUM}[ \t]*"
BODY = re.compile(rf"(?:[ \t]*(?:{_BODY_MOVE}|{_SETTING})?{_COMMENT}?\r?\n)*", re.IGNORECASE)


def restate(last: Toolpath, carried: np.ndarray) -> str | None:
    """A move of the same kind to the target ``last``: X Y Z, its A B C as carried, its external
    axes; None where a component is unknown."""
    abc = carried[3:6]
    if np.isnan(last.position[0]).any() or np.isnan(abc).any():
        return None
    keyword = "PTP" if last.kind[0] == Kind.JOINT else "LIN"
    fields = [f"{name} {plain_number(v)}" for name, v in zip(("X", "Y", "Z", "A", "B", "C"), (*last.position[0], *abc))]
    fields += [f"E{i + 1} {plain_number(v)}" for i, v in enumerate(last.ext[0]) if not np.isnan(v)]
    return f"{keyword} {{{', '.join(fields)}}}"


def body_shape(raw: bytes) -> re.Pattern:
    """BODY tells a body line by its shape (digits written 0): it reads digits only as ``\\d``."""
    return BODY


RULES = StreamRules(move=MOVE, body=BODY, restate=restate, tail="END\n", body_shape=body_shape)
