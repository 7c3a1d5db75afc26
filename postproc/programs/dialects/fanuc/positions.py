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
# (A position never taught shows '********' for each number.)
_COMPONENT = re.compile(rf"\b([XYZWPR]|J\d|E\d)[ \t]*=[ \t]*({NUMBER}|\*+)[ \t]*(mm|deg)?", re.IGNORECASE)
_FIELD_OF = {"X": 0, "Y": 1, "Z": 2, "W": 3, "P": 4, "R": 5, **{f"J{i}": 6 + i for i in range(1, 7)}, **{f"E{i}": 12 + i for i in range(1, 7)}}

TAUGHT, UNTAUGHT, NO_GROUP_1 = 0, 1, 2  # Positions.state
# Position words postproc does not read, and why (listings saved with the pendant in another
# language write its words: German KONFIG; RX .. RR are components of another kind of position).
_NOT_ENGLISH = re.compile(r"\bKONFIG\b|\bR[XYZWPR][ \t]*=", re.IGNORECASE)
_NOT_ENGLISH_WHY = {"KONFIG": "German (a listing saved with the pendant in German): postproc reads the English TP words; save it in English",
                    **{f"R{c}": "not a component of a group 1 position as the manual lists it (X Y Z W P R or J1 .. J6): RX .. RR are not read" for c in "XYZWPR"}}
ARM_CODE_BITS = {"F": 4, "N": 0, "D": 2, "U": 0, "B": 1, "T": 0}  # conf[0] = 4 flip + 2 down + 1 back (0: 'N U T')


@dataclass(frozen=True)
class Positions:
    """Every P[n] of /POS, one row each: values (P, NF) NaN where absent, spans (P, NF, 2)
    offsets (-1 none), joint (P,) (joint representation, not Cartesian), uf / ut (P,) the
    position's user frame and tool numbers (-1: 'F', the one selected when it runs), conf
    (P, 4) arm code and turns of J4 J5 J6 (NaN: no CONFIG), groups: the other motion groups
    (GP2 ...) each position also moves; state (P,): TAUGHT, UNTAUGHT ('********': never
    taught, the controller has no value) or NO_GROUP_1 (it moves other groups only)."""

    row_of: dict[int, int]  # P number -> row
    values: np.ndarray
    spans: np.ndarray
    joint: np.ndarray
    uf: np.ndarray
    ut: np.ndarray
    conf: np.ndarray
    groups: tuple[tuple[int, ...], ...]
    state: np.ndarray

    @classmethod
    def empty(cls) -> "Positions":
        return _table([])


class PositionError(ValueError):
    """A position the section cannot hold as the controller reads it: (offset, why)."""

    def __init__(self, offset: int, why: str):
        super().__init__(why)
        self.offset = offset


def read_positions(text: str, start: int, end: int) -> Positions:
    """Every P[n] of text[start:end] (the /POS section); a malformed one or a number given
    twice is a PositionError at its place. Listings where every position has the controller's
    own Cartesian layout are read in one pass (``_canonical``), others block by block."""
    table = _canonical(text, start, end)
    return table if table is not None else read_blocks(text, start, end)


def read_blocks(text: str, start: int, end: int) -> Positions:
    """``read_positions`` block by block (any layout the section allows)."""
    rows: list[tuple] = []
    seen: dict[int, int] = {}
    pos = start
    for m in _BLOCK.finditer(text, start, end):
        gap = text[pos : m.start()].strip()
        if gap:
            raise PositionError(pos + text[pos : m.start()].index(gap[0]), "not a position: /POS holds P[n]{ ... }; entries only")
        pos = m.end()
        number = int(m.group(1))
        if number in seen:
            raise PositionError(m.start(), f"P[{number}] is given twice in /POS: the controller keeps one value per position")
        seen[number] = len(rows)
        rows.append(_position(text, m, number))
    rest = text[pos:end].strip()
    if rest:
        raise PositionError(pos + text[pos:end].index(rest[0]), "not a position: /POS holds P[n]{ ... }; entries only (an unclosed '{' or a missing ';'?)")
    return _table(rows)


def _table(rows: list[tuple]) -> Positions:
    """Positions from (number, values, spans, joint, uf, ut, conf, groups, state) rows."""
    n = len(rows)
    return Positions({r[0]: k for k, r in enumerate(rows)},
                     np.array([r[1] for r in rows]).reshape(n, NF), np.array([r[2] for r in rows], dtype=np.int64).reshape(n, NF, 2),
                     np.array([r[3] for r in rows], dtype=bool), np.array([r[4] for r in rows], dtype=np.int64), np.array([r[5] for r in rows], dtype=np.int64),
                     np.array([r[6] for r in rows]).reshape(n, 4), tuple(r[7] for r in rows), np.array([r[8] for r in rows], dtype=np.int8))


_SEP = r"[ \t]*,[ \t]*"
_CANONICAL = re.compile(
    # P[n(:label)]{ GP1: UF : u, UT : t, CONFIG : 'F U T, a, b, c', X = .. mm, .. R = .. deg };  as the controller lists it
    rf"[ \t]*P\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*\{{[ \t]*\r?\n[ \t]*GP1[ \t]*:[ \t]*\r?\n"
    rf"[ \t]*UF[ \t]*:[ \t]*(\d+){_SEP}UT[ \t]*:[ \t]*(\d+){_SEP}CONFIG[ \t]*:[ \t]*'[ \t]*([NF])[ \t]+([UD])[ \t]+([TB])"
    rf"{_SEP}(-?\d+){_SEP}(-?\d+){_SEP}(-?\d+)[ \t]*'[ \t]*,[ \t]*\r?\n"
    rf"[ \t]*X[ \t]*=[ \t]*({NUMBER})[ \t]*mm{_SEP}Y[ \t]*=[ \t]*({NUMBER})[ \t]*mm{_SEP}Z[ \t]*=[ \t]*({NUMBER})[ \t]*mm[ \t]*,[ \t]*\r?\n"
    rf"[ \t]*W[ \t]*=[ \t]*({NUMBER})[ \t]*deg{_SEP}P[ \t]*=[ \t]*({NUMBER})[ \t]*deg{_SEP}R[ \t]*=[ \t]*({NUMBER})[ \t]*deg[ \t]*\r?\n"
    r"[ \t]*\}[ \t]*;[ \t]*\r?(?:\n|$)")
_NUMBER_GROUPS = slice(10, 16)  # groups of X Y Z W P R in _CANONICAL


def _canonical(text: str, start: int, end: int) -> Positions | None:
    """The positions of a /POS section that is nothing but canonical Cartesian blocks (blank
    lines between), read with one regular expression; None where any text is not one."""
    matches = list(_CANONICAL.finditer(text, start, end))
    if not matches:
        return None
    regs = np.array([m.regs for m in matches], dtype=np.int64)  # (P, groups + 1, 2) spans of every group
    gaps_start = np.concatenate([[start], regs[:, 0, 1]])
    gaps_end = np.concatenate([regs[:, 0, 0], [end]])
    if any(text[a:b].strip() for a, b in zip(gaps_start.tolist(), gaps_end.tolist()) if b > a):
        return None  # something else between the blocks: read block by block (and name it)
    groups = [m.groups() for m in matches]
    numbers = np.array([g[0] for g in groups], dtype=np.int64)
    if len(np.unique(numbers)) < len(numbers):
        return None  # a number given twice: the block reader names it
    n = len(matches)
    values = np.full((n, NF), np.nan)
    values[:, 0:6] = np.array([g[9:15] for g in groups], dtype=float)
    spans = np.full((n, NF, 2), -1, dtype=np.int64)
    spans[:, 0:6] = regs[:, 10:16]
    code = np.array([[ARM_CODE_BITS[g[k].upper()] for k in (3, 4, 5)] for g in groups]).sum(axis=1)
    conf = np.column_stack([code, np.array([g[6:9] for g in groups], dtype=float)])
    uf = np.array([g[1] for g in groups], dtype=np.int64)
    ut = np.array([g[2] for g in groups], dtype=np.int64)
    return Positions(dict(zip(numbers.tolist(), range(n))), values, spans, np.zeros(n, bool), uf, ut, conf, ((),) * n, np.zeros(n, np.int8))


def _position(text: str, m: re.Match, number: int) -> tuple:
    """(number, values, spans, joint, uf, ut, conf, other groups, state) of one block."""
    body_start = m.start(2)
    body = m.group(2)
    groups = list(_GROUP.finditer(body))
    if not groups:
        raise PositionError(body_start, f"P[{number}] has no group (GP1: ...): the controller has no value for it")
    numbers = [int(g.group(1)) for g in groups]
    if 1 not in numbers:  # a servo gun's or a positioner's own position
        return number, np.full(NF, np.nan), np.full((NF, 2), -1, dtype=np.int64), False, -1, -1, np.full(4, np.nan), tuple(numbers), NO_GROUP_1
    k = numbers.index(1)
    gp1_end = groups[k + 1].start() if k + 1 < len(groups) else len(body)
    gp1 = body[groups[k].end() : gp1_end]
    base = body_start + groups[k].end()
    ft = _FRAME_TOOL.search(gp1)
    if ft is None:
        raise PositionError(base, f"P[{number}] GP1 has no 'UF : n, UT : n': its frame and tool are unknown")
    other = _NOT_ENGLISH.search(gp1)
    if other is not None:
        word = re.sub(r"[ \t]*=$", "", other.group(0)).upper()
        raise PositionError(base + other.start(), f"P[{number}]: '{word}' is {_NOT_ENGLISH_WHY[word]}")
    values = np.full(NF, np.nan)
    spans = np.full((NF, 2), -1, dtype=np.int64)
    stars = []
    for c in _COMPONENT.finditer(gp1, ft.end()):
        name = c.group(1).upper()
        field = _FIELD_OF.get(name)
        if field is None:
            raise PositionError(base + c.start(1), f"P[{number}]: {name} is not a component of a group 1 position")
        if not np.isnan(values[field]) or field in stars:
            raise PositionError(base + c.start(1), f"P[{number}]: {name} is given twice")
        if c.group(2).startswith("*"):
            stars.append(field)
            continue
        values[field] = float(c.group(2))
        spans[field] = (base + c.start(2), base + c.end(2))
    others = tuple(n for n in numbers if n != 1)
    uf, ut = (-1 if v.upper() == "F" else int(v) for v in ft.group(1, 2))
    if stars:
        if not np.isnan(values).all():
            raise PositionError(base, f"P[{number}] has some numbers and some '***': the controller keeps a position whole")
        return number, values, spans, False, uf, ut, np.full(4, np.nan), others, UNTAUGHT
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
    return number, values, spans, bool(joint.all()), uf, ut, conf, others, TAUGHT
