"""RAPID: the configuration data of a copied robtarget (subdividing a segment)."""

from __future__ import annotations

import numpy as np

from postproc.errors import EmitError


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
