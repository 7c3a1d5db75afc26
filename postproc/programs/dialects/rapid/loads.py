"""RAPID: the whole load a program states, carried into a converted program (``convert``).

RAPID reference manual, "tooldata": tload = [mass kg, cog [x,y,z] mm in the tool0 (wrist)
frame, aom [q1,q2,q3,q4] the axes of moment, ix, iy, iz kg m^2 about them]; "loaddata" is the
same six; "GripLoad": the payload held from that instruction on, on top of the tool's load
(``GripLoad load0`` drops it); a motion's ``\\TLoad`` is the whole load of that motion.
"""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import InputError

from ...emit.load_plan import LoadState, Statement, in_force, plan_from_index, with_grip
from ...emit.tool_load import NO_LOAD, ToolLoad
from ..base import NUMBER


def _place(tp, f: int, start: int) -> tuple[int, str]:
    text = tp.sources[f].text
    line = text.count("\n", 0, start) + 1
    return line, f"{tp.sources[f].path}:{line}:{start - (text.rfind(chr(10), 0, start) + 1) + 1}"


def _commented(text: str, start: int) -> bool:
    return "!" in text[text.rfind("\n", 0, start) + 1 : start]


def _declared(tp, kind: str, first: int) -> dict[str, tuple[ToolLoad, str]]:
    """NAME -> (load, file:line:column) of each ``kind`` declaration; its load from number ``first`` on."""
    out = {}
    for f, doc in enumerate(tp.sources):
        for m in re.finditer(rf"\b{kind}\s+(\w+)\s*:=\s*\[", doc.text, re.IGNORECASE):
            nums = [float(v) for v in re.findall(NUMBER, doc.text[m.end() : doc.text.find(";", m.end())])]
            stationary = kind == "tooldata" and not doc.text[m.end() :].lstrip().upper().startswith("TRUE")  # robhold FALSE: not on the flange
            if len(nums) >= first + 11 and not stationary and not _commented(doc.text, m.start()) and m.group(1).upper() not in out:
                v = nums[first : first + 11]
                out[m.group(1).upper()] = (ToolLoad(v[0], tuple(v[1:4]), tuple(v[8:11]), tuple(v[4:8])), _place(tp, f, m.start())[1])
    return out


def stated_loads(tp):
    """LoadPlan of the program: each target's tool tload (tool0: none) and the GripLoad in force."""
    tools = _declared(tp, "tooldata", 7)
    loads = _declared(tp, "loaddata", 0)
    grips = []
    for f, doc in enumerate(tp.sources):
        for m in re.finditer(r"\\TLoad\s*:=\s*(\w+)", doc.text, re.IGNORECASE):
            if not _commented(doc.text, m.start()):
                raise InputError(f"{_place(tp, f, m.start())[1]}: \\TLoad (the whole load of one motion) is not carried into a converted program; "
                                 "write it as a GripLoad before the motion")
        for m in re.finditer(r"\bGripLoad\s+(\w+)\s*;", doc.text, re.IGNORECASE):
            name = m.group(1).upper()
            if _commented(doc.text, m.start()):
                continue
            line, at = _place(tp, f, m.start())
            if name != "LOAD0" and name not in loads:
                raise InputError(f"{at}: GripLoad {m.group(1)}: no loaddata {m.group(1)} with its values in the program; it cannot be carried")
            grips.append(Statement(f, line, at, None if name == "LOAD0" else loads[name][0]))
    grip_at = in_force(tp, grips)  # (N,) the GripLoad in force, -1: none
    # one state per (tool, GripLoad) pair the targets use
    pairs, index = np.unique(np.stack([tp.tool.astype(int), grip_at]), axis=1, return_inverse=True)
    candidates = []
    for t, g in pairs.T.tolist():
        name = tp.tool_names[t].upper()
        state = LoadState(NO_LOAD) if name == "TOOL0" else (LoadState(tools[name][0], None, tools[name][1]) if name in tools else LoadState(None))
        candidates.append(with_grip(state, grips[g] if g >= 0 else None))
    return plan_from_index(candidates, index.ravel())
