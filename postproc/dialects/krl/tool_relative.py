"""LIN_REL / PTP_REL ... #TOOL targets on write-back.

Their increments are in the tool frame at the previous target (KSS 8.3 'LIN_REL'); the
splice emitter writes increments per base axis, which would be wrong numbers for them. Until
the tool-frame increments are rewritten, a compensation that moves such a target (or the
target before it, which its increments start from) is refused with its place and the remedy.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import EmitError
from ...ir import Toolpath

_TOOL_WORD = re.compile(r"#TOOL\b", re.IGNORECASE)


def refuse_moved_tool_steps(original: Toolpath, modified: Toolpath) -> None:
    rows = np.nonzero(original.relative)[0]
    if not len(rows):
        return
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=1e-9, equal_nan=True).all(axis=1)
    for r in rows.tolist():
        if not (moved[r] or (r > 0 and moved[r - 1])):
            continue
        doc = original.sources[int(original.file[r])]
        line = doc.text.split("\n")[int(original.line[r]) - 1]
        code = line.split(";")[0]
        hit = _TOOL_WORD.search(code)
        if hit:
            raise EmitError(f"{doc.path}:{int(original.line[r])}:{hit.start() + 1}: a {code.split()[0].upper()} ... #TOOL step (increments in the tool "
                            "frame) cannot be written back compensated yet: write the motion as an absolute LIN / PTP, or as LIN_REL ... #BASE")
