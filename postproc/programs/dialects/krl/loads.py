"""KRL: the payload a program states ($LOAD), for checking it against the model's."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import InputError
from postproc.robot.frames import abc_to_quat_wxyz

from ...emit.load_plan import LoadState, Statement, in_force, plan_from_index
from ...emit.tool_load import ToolLoad
from ..base import NUMBER

_LOAD_M = re.compile(rf"^[ \t]*\$LOAD\.M[ \t]*=[ \t]*({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_AGG = re.compile(rf"^[ \t]*\$LOAD[ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE | re.MULTILINE)
_LOAD_REF = re.compile(r"^[ \t]*\$LOAD[ \t]*=[ \t]*LOAD_DATA\[[ \t]*(\d+)[ \t]*\]", re.IGNORECASE | re.MULTILINE)
_BAS_TOOL = re.compile(r"^[ \t]*BAS[ \t]*\([ \t]*#TOOL[ \t]*,[ \t]*(\d+)", re.IGNORECASE | re.MULTILINE)
_LOAD_DATA = re.compile(rf"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{{[^}}]*?\bM[ \t]+({NUMBER})", re.IGNORECASE)


def load_masses(tp) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N') of every payload the program's files state."""
    table = {int(m.group(1)): float(m.group(2)) for doc in tp.sources for m in _LOAD_DATA.finditer(doc.text)}
    out = []
    for doc in tp.sources:
        if doc.role == "config":
            continue  # LOAD_DATA declarations: only those the program selects count

        def where(m):
            return f"{doc.path}, line {doc.text.count(chr(10), 0, m.start()) + 1}"

        for pattern in (_LOAD_M, _LOAD_AGG):
            out += [(float(m.group(1)), where(m)) for m in pattern.finditer(doc.text)]
        for pattern in (_LOAD_REF, _BAS_TOOL):
            out += [(table[int(m.group(1))], where(m) + f" (LOAD_DATA[{m.group(1)}])") for m in pattern.finditer(doc.text) if int(m.group(1)) in table]
    return out


# --- the whole load, carried into a converted program (convert) --------------------------
# KSS 8 system variables, "$LOAD": {M mass kg (-1: the default load of the machine data),
# CM frame of the centre of gravity relative to the flange {X, Y, Z mm, A, B, C deg: the
# principal axes of inertia}, J {X, Y, Z} moments of inertia about them, kg m^2}.
_STATEMENT = re.compile(r"^[ \t]*(?:\$LOAD[ \t]*=[ \t]*(\{|LOAD_DATA\[[ \t]*(\d+)[ \t]*\])|\$LOAD\.M[ \t]*=[ \t]*(" + NUMBER + r")"
                        r"|BAS[ \t]*\([ \t]*#TOOL[ \t]*,[ \t]*(\d+))", re.IGNORECASE | re.MULTILINE)
_DECLARED = re.compile(r"LOAD_DATA\[[ \t]*(\d+)[ \t]*\][ \t]*=[ \t]*\{", re.IGNORECASE)
NAN3 = (float("nan"),) * 3


def _aggregate(text: str, open_at: int) -> str:
    """The text of the {...} aggregate opening at ``open_at`` (nested braces included)."""
    depth = 0
    for i in range(open_at, len(text)):
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return text[open_at : i + 1]
    return text[open_at:]


def _load_of(agg: str):
    """ToolLoad of a $LOAD aggregate; a component it leaves out (or M -1) is NaN: the controller's."""

    def fields(name):
        m = re.search(rf"\b{name}[ \t]*\{{([^}}]*)\}}", agg, re.IGNORECASE)
        got = {} if m is None else {k.upper(): float(v) for k, v in re.findall(rf"\b([XYZABC])[ \t]+({NUMBER})", m.group(1), re.IGNORECASE)}
        return [got.get(k, float("nan")) for k in "XYZABC"]

    mass = re.search(rf"\bM[ \t]+({NUMBER})", agg, re.IGNORECASE)
    m = float(mass.group(1)) if mass else float("nan")
    cm, j = fields("CM"), fields("J")
    aom = tuple(abc_to_quat_wxyz(np.array(cm[3:]))) if np.isfinite(cm[3:]).all() else (float("nan"),) * 4
    return ToolLoad(m if m >= 0 else float("nan"), tuple(cm[:3]), tuple(j[:3]), tuple(float(v) for v in aom))


def stated_loads(tp):
    """LoadPlan of the program: the $LOAD in force at each target ($LOAD = {...}, $LOAD.M = m,
    $LOAD = LOAD_DATA[n] and BAS(#TOOL, n) with LOAD_DATA[n] declared, e.g. in $config.dat)."""
    table = {int(m.group(1)): _load_of(_aggregate(doc.text, m.end() - 1)) for doc in tp.sources for m in _DECLARED.finditer(doc.text)}
    statements = []
    for f, doc in enumerate(tp.sources):
        if doc.role == "config":
            continue
        for m in _STATEMENT.finditer(doc.text):
            start = m.start() + len(m.group(0)) - len(m.group(0).lstrip())
            line = doc.text.count("\n", 0, start) + 1
            at = f"{doc.path}:{line}:{start - (doc.text.rfind(chr(10), 0, start) + 1) + 1}"
            if m.group(1) == "{":
                load = _load_of(_aggregate(doc.text, m.end(1) - 1))
            elif m.group(3) is not None:
                load = ToolLoad(float(m.group(3)), NAN3, NAN3, (float("nan"),) * 4)
            else:
                n = int(m.group(2) or m.group(4))
                if n not in table:
                    if m.group(4):  # BAS(#TOOL, n) without LOAD_DATA[n] here: the controller's $config.dat, unknown here
                        statements.append(Statement(f, line, at, None))
                        continue
                    raise InputError(f"{at}: LOAD_DATA[{n}] is not in the program's files (give $config.dat with --data, or --tool-load)")
                load = table[n]
            statements.append(Statement(f, line, at, load))
    return plan_from_index([None if s.load is None else LoadState(s.load, None, s.at) for s in statements], in_force(tp, statements))
