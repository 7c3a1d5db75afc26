"""RAPID: the configuration data of a copied robtarget (subdividing a segment)."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError

from ...ir import Kind
from ..base import NUMBER


def set_robtarget_conf(text: str, conf: np.ndarray) -> str:
    """``text`` holding one robtarget literal ``[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[extax]]``
    with its confdata (the third component) replaced by ``conf``."""
    start = text.find("[")
    depth, part, open_at = 0, 0, -1
    for i in range(start, len(text)):
        ch = text[i]
        if ch == "[":
            depth += 1
            if depth == 2 and part == 2:
                open_at = i
        elif ch == "]":
            depth -= 1
            if depth == 1 and part == 2 and open_at >= 0:
                new = "[" + ",".join(str(int(v)) for v in conf) + "]"
                return text[:open_at] + new + text[i + 1 :]
            if depth == 0:
                break
        elif ch == "," and depth == 1:
            part += 1
    raise EmitError(f"no confdata in the robtarget '{text.strip()[:80]}'")


def tool_masses(tp) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N') of every payload the program puts on the flange: the tload of
    each tooldata the Cartesian targets use (tooldata is [robhold, [[x,y,z],[q1..q4]], [mass,
    [cog], [aom], ix, iy, iz]]); each ``GripLoad NAME`` adds that loaddata's mass to the
    tool's; a motion's ``\\TLoad:=NAME`` is the whole load of that motion."""
    used = {tp.tool_names[t].upper() for t in np.unique(tp.tool[tp.kind != Kind.ABSJ])}
    tools = [(mass, where) for name, mass, where in _declared(tp, "tooldata", 7) if name in used]
    loads = {name: mass for name, mass, _ in _declared(tp, "loaddata", 0)}
    out = list(tools)
    for doc in tp.sources:
        for pattern, whole in ((r"\bGripLoad\s+(\w+)\s*;", False), (r"\\TLoad\s*:=\s*(\w+)", True)):
            for m in re.finditer(pattern, doc.text, re.IGNORECASE):
                name = m.group(1).upper()
                if name == "LOAD0" or name not in loads:
                    continue
                where = f"{doc.path}, line {doc.text.count(chr(10), 0, m.start()) + 1} ({m.group(0).strip().rstrip(';')})"
                carried = [0.0] if whole or not tools else [mass for mass, _ in tools]
                out += [(loads[name] + extra, where) for extra in carried]
    return out


def _declared(tp, kind: str, index: int) -> list[tuple[str, float, str]]:
    """(NAME, number ``index`` of the value, 'FILE, line N (kind name)') of each declaration
    of ``kind`` (tooldata, loaddata) in the program's files."""
    out = []
    for doc in tp.sources:
        for m in re.finditer(rf"\b{kind}\s+(\w+)\s*:=\s*\[", doc.text, re.IGNORECASE):
            end = doc.text.find(";", m.end())
            nums = re.findall(NUMBER, doc.text[m.end() : end])
            if len(nums) > index:
                where = f"{doc.path}, line {doc.text.count(chr(10), 0, m.start()) + 1} ({kind} {m.group(1)})"
                out.append((m.group(1).upper(), float(nums[index]), where))
    return out
