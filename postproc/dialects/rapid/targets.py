"""RAPID: the configuration data of a copied robtarget (subdividing a segment)."""

from __future__ import annotations

import numpy as np

from ...errors import EmitError


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
    """(mass kg, 'FILE, line N') of the tload of each tooldata the Cartesian targets use:
    tooldata is [robhold, [[x,y,z],[q1..q4]], [mass, [cog], [aom], ix, iy, iz]]."""
    import re

    from ...ir import Kind
    from ..base import NUMBER

    used = {tp.tool_names[t].upper() for t in np.unique(tp.tool[tp.kind != Kind.ABSJ])}
    out = []
    for doc in tp.sources:
        for m in re.finditer(r"\btooldata\s+(\w+)\s*:=\s*\[", doc.text, re.IGNORECASE):
            if m.group(1).upper() not in used:
                continue
            end = doc.text.find(";", m.end())
            nums = re.findall(NUMBER, doc.text[m.end() : end])
            if len(nums) >= 8:
                out.append((float(nums[7]), f"{doc.path}, line {doc.text.count(chr(10), 0, m.start()) + 1} (tooldata {m.group(1)})"))
    return out
