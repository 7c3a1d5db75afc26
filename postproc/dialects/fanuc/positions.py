"""The /POS section of a Fanuc TP program (.ls): every position P[n] with the numbers'
spans, its user frame and tool numbers and its CONFIG string.

R-30iB Operator's Manual, "Position data" (and the .ls listing the controller writes):

    P[1:"comment"]{
       GP1:
        UF : 1, UT : 2,     CONFIG : 'N U T, 0, 0, 0',
        X = 100.000 mm, Y = 0.000 mm, Z = 50.000 mm,
        W = 180.000 deg, P = 0.000 deg, R = 0.000 deg
    };

or joint values ``J1= 0.000 deg, ...`` in place of X .. R; extended axes ``E1= ...``
follow either. Only group 1 (the robot) is read; another group (a positioner, a rail) is
kept and named so that the targets using it are flagged.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ...ir import NF
from ..base import NUMBER

# One position: its number and the text between the braces.
_BLOCK = re.compile(r"^[ \t]*P\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*\{(.*?)\}[ \t]*;", re.MULTILINE | re.DOTALL)
# Group headers inside a position (GP1:, GP2:).
_GROUP = re.compile(r"GP(\d+)[ \t]*:")
_FRAME_TOOL = re.compile(r"UF[ \t]*:[ \t]*(\d+|F)[ \t]*,[ \t]*UT[ \t]*:[ \t]*(\d+|F)", re.IGNORECASE)
_CONFIG = re.compile(r"CONFIG[ \t]*:[ \t]*'[ \t]*([NF])[ \t]*([UD])?[ \t]*([TB])?[ \t]*((?:,[ \t]*-?\d+[ \t]*){0,3})'", re.IGNORECASE)
# A component: its name, its number, its unit (mm or deg).
_COMPONENT = re.compile(rf"\b([XYZWPR]|J\d|E\d)[ \t]*=[ \t]*({NUMBER})[ \t]*(mm|deg)?", re.IGNORECASE)
_FIELD_OF = {"X": 0, "Y": 1, "Z": 2, "W": 3, "P": 4, "R": 5, **{f"J{i}": 6 + i for i in range(1, 7)}, **{f"E{i}": 12 + i for i in range(1, 7)}}

ARM_CODE_BITS = {"F": 4, "N": 0, "D": 2, "U": 0, "B": 1, "T": 0}  # conf[0] = 4 flip + 2 down + 1 back (0: 'N U T')


@dataclass(frozen=True)
class Position:
    """One P[n] of /POS: values (NF,) NaN where absent, spans (NF, 2) offsets (-1 none)."""

    number: int
    start: int  # offset of 'P[' in the file
    values: np.ndarray
    spans: np.ndarray
    joint: bool  # joint representation (J1 ..), not Cartesian
    uf: int | None  # None: 'F' (the frame selected when it runs)
    ut: int | None
    conf: np.ndarray  # (4,) arm code, turns of J4 J5 J6; NaN where no CONFIG
    other_groups: tuple[int, ...]  # GP2 ... also moved by this position


class PositionError(ValueError):
    """A position the section cannot hold as the controller reads it: (offset, why)."""

    def __init__(self, offset: int, why: str):
        super().__init__(why)
        self.offset = offset


def read_positions(text: str, start: int, end: int) -> dict[int, Position]:
    """Every P[n] of text[start:end] (the /POS section) by number; a malformed one or a
    number given twice is a PositionError at its place."""
    out: dict[int, Position] = {}
    pos = start
    for m in _BLOCK.finditer(text, start, end):
        gap = text[pos : m.start()].strip()
        if gap:
            raise PositionError(pos + text[pos : m.start()].index(gap[0]), "not a position: /POS holds P[n]{ ... }; entries only")
        pos = m.end()
        number = int(m.group(1))
        if number in out:
            raise PositionError(m.start(), f"P[{number}] is given twice in /POS: the controller keeps one value per position")
        out[number] = _position(text, m, number)
    rest = text[pos:end].strip()
    if rest:
        raise PositionError(pos + text[pos:end].index(rest[0]), "not a position: /POS holds P[n]{ ... }; entries only (an unclosed '{' or a missing ';'?)")
    return out


def _position(text: str, m: re.Match, number: int) -> Position:
    body_start = m.start(2)
    body = m.group(2)
    groups = list(_GROUP.finditer(body))
    if not groups or groups[0].group(1) != "1":
        raise PositionError(body_start, f"P[{number}] has no GP1: group 1 (the robot) must come first")
    gp1_end = groups[1].start() if len(groups) > 1 else len(body)
    gp1 = body[groups[0].end() : gp1_end]
    base = body_start + groups[0].end()
    ft = _FRAME_TOOL.search(gp1)
    if ft is None:
        raise PositionError(base, f"P[{number}] GP1 has no 'UF : n, UT : n': its frame and tool are unknown")
    values = np.full(NF, np.nan)
    spans = np.full((NF, 2), -1, dtype=np.int64)
    for c in _COMPONENT.finditer(gp1, ft.end()):
        name = c.group(1).upper()
        field = _FIELD_OF.get(name)
        if field is None:
            raise PositionError(base + c.start(1), f"P[{number}]: {name} is not a component of a group 1 position")
        if not np.isnan(values[field]):
            raise PositionError(base + c.start(1), f"P[{number}]: {name} is given twice")
        values[field] = float(c.group(2))
        spans[field] = (base + c.start(2), base + c.end(2))
    cart, joint = ~np.isnan(values[0:6]), ~np.isnan(values[7:13])
    if not ((cart.all() and not joint.any()) or (joint.all() and not cart.any())):
        raise PositionError(base, f"P[{number}] is neither Cartesian (X Y Z W P R) nor joint (J1 .. J6) in full")
    conf = np.full(4, np.nan)
    c = _CONFIG.search(gp1)
    if c is not None:
        turns = [int(t) for t in re.findall(r"-?\d+", c.group(4))]
        turns += [0] * (3 - len(turns))  # CONFIG : 'N U T' alone: turn numbers 0
        conf[:] = [sum(ARM_CODE_BITS[(g or d).upper()] for g, d in zip(c.group(1, 2, 3), "NUT")), *turns]
    elif cart.all():
        raise PositionError(base, f"P[{number}] is Cartesian without CONFIG: the controller cannot tell which arm posture it is")
    uf, ut = (None if v.upper() == "F" else int(v) for v in ft.group(1, 2))
    return Position(number, m.start(), values, spans, bool(joint.all()), uf, ut, conf, tuple(int(g.group(1)) for g in groups[1:]))
