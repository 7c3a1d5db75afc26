"""RAPID: the loads a program puts on the flange, from the IR (``load_facts``: the parser's).

RAPID reference manual, "tooldata": tload = [mass kg, cog [x,y,z] mm in the tool0 (wrist)
frame, aom [q1,q2,q3,q4] the axes of moment, ix, iy, iz kg m^2 about them]; "loaddata" is the
same six; "GripLoad": the payload held from that instruction on, on top of the tool's load
(``GripLoad load0`` drops it); a motion's ``\\TLoad`` is the whole load of that motion.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError

from ...emit.load_plan import LoadState, Statement, plan_from_index, with_grip
from ...emit.tool_load import NO_LOAD, ToolLoad
from ...ir import Kind, Toolpath
from .load_facts import GRIP, LOADS, Declared, RapidLoads

TLOAD_FIRST = 7  # tooldata: robhold, tframe (3 + 4 numbers), then tload


def payloads(tp: Toolpath) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N (...)') of every payload the program puts on the flange: the tload
    of each tooldata the Cartesian targets use; each ``GripLoad NAME`` adds that loaddata's mass
    to the tool's; a motion's ``\\TLoad:=NAME`` is the whole load of that motion. Every
    statement as written counts, a commented one too: a mismatch is reported, never hidden."""
    facts: RapidLoads = tp.facts[LOADS]
    used = {tp.tool_names[t].upper() for t in np.unique(tp.tool[tp.kind != Kind.ABSJ])}
    tools = [(d.numbers[TLOAD_FIRST], f"{d.place.where} ({d.kind} {d.name})")
             for d in _of_kind(facts, "tooldata") if len(d.numbers) > TLOAD_FIRST and d.name.upper() in used]
    masses = {d.name.upper(): d.numbers[0] for d in _of_kind(facts, "loaddata") if d.numbers}  # the last declaration of a name
    out = list(tools)
    for f in sorted({u.place.file for u in facts.grips + facts.tloads}):
        for statements, whole in ((facts.grips, False), (facts.tloads, True)):
            for u in statements:
                name = u.name.upper()
                if u.place.file != f or name == "LOAD0" or name not in masses:
                    continue
                carried = [0.0] if whole or not tools else [mass for mass, _ in tools]
                out += [(masses[name] + extra, f"{u.place.where} ({u.written})") for extra in carried]
    return out


def stated_loads(tp: Toolpath):
    """LoadPlan of the program: each target's tool tload (tool0: none) and the GripLoad in force."""
    facts: RapidLoads = tp.facts[LOADS]
    tools = _loads(facts, "tooldata", TLOAD_FIRST)
    loads = _loads(facts, "loaddata", 0)
    grips: list[Statement | None] = [None] * len(facts.grips)
    for f in sorted({u.place.file for u in facts.grips + facts.tloads}):
        for u in facts.tloads:
            if u.place.file == f and not u.place.commented:
                raise InputError(f"{u.place.at}: \\TLoad (the whole load of one motion) is not carried into a converted program; "
                                 "write it as a GripLoad before the motion")
        for k, u in enumerate(facts.grips):
            name = u.name.upper()
            if u.place.file != f or u.place.commented:
                continue
            if name != "LOAD0" and name not in loads:
                raise InputError(f"{u.place.at}: GripLoad {u.name}: no loaddata {u.name} with its values in the program; it cannot be carried")
            grips[k] = Statement(u.place.file, u.place.line, u.place.at, None if name == "LOAD0" else loads[name][0])
    if facts.grip_refused:
        raise InputError(facts.grip_refused)
    grip_at = tp.extras[GRIP]  # (N,) the GripLoad in force, -1: none
    # one state per (tool, GripLoad) pair the targets use
    pairs, index = np.unique(np.stack([tp.tool.astype(int), grip_at]), axis=1, return_inverse=True)
    candidates = []
    for t, g in pairs.T.tolist():
        name = tp.tool_names[t].upper()
        state = LoadState(NO_LOAD) if name == "TOOL0" else (LoadState(tools[name][0], None, tools[name][1]) if name in tools else LoadState(None))
        candidates.append(with_grip(state, grips[g] if g >= 0 else None))
    return plan_from_index(candidates, index.ravel())


def _of_kind(facts: RapidLoads, kind: str) -> list[Declared]:
    return [d for d in facts.declared if d.kind == kind]


def _loads(facts: RapidLoads, kind: str, first: int) -> dict[str, tuple[ToolLoad, str]]:
    """NAME -> (load, file:line:column) of each ``kind`` declaration on the flange, its load from
    number ``first`` on (the first uncommented declaration of a name with all eleven numbers)."""
    out = {}
    for d in _of_kind(facts, kind):
        if len(d.numbers) >= first + 11 and d.on_flange and not d.place.commented and d.name.upper() not in out:
            v = d.numbers[first : first + 11]
            out[d.name.upper()] = (ToolLoad(v[0], tuple(v[1:4]), tuple(v[8:11]), tuple(v[4:8])), d.place.at)
    return out
