"""The workpiece frame of a program: the one frame every Cartesian target is given in
(placement moves it; engagement reads the stock in it). IR only: no language, no robot."""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError

from .ir import Kind, Toolpath


def workpiece_frame_index(tp: Toolpath) -> tuple[int, np.ndarray]:
    """The one frame every Cartesian target uses, and the rows of those targets."""
    rows = np.nonzero(tp.kind != Kind.ABSJ)[0]
    if not len(rows):
        raise InputError(f"{tp.sources[0].path}: no Cartesian target to place")
    bad = rows[np.isnan(tp.position[rows]).any(axis=1) | np.isnan(tp.orientation[rows]).any(axis=1)]
    if len(bad):
        raise InputError(f"{tp.sources[0].path}, line {tp.line[bad[0]]}: target without a position or orientation in its frame")
    used = np.unique(tp.frame[rows])
    if len(used) != 1:
        names = ", ".join(tp.frame_names[i] for i in used)
        line = tp.line[rows][np.nonzero(tp.frame[rows] != tp.frame[rows[0]])[0][0]]
        raise InputError(f"{tp.sources[0].path}, line {line}: targets in several frames ({names}); placement moves one workpiece frame")
    unresolved = rows[~tp.resolved[rows]]
    if len(unresolved):
        raise InputError(f"{tp.sources[0].path}, line {tp.line[unresolved[0]]}: target or tool cannot be evaluated from the program")
    tools_unknown = tp.tool_known is not None and not tp.tool_known[tp.tool[rows]].all()
    if tools_unknown:
        i = rows[~tp.tool_known[tp.tool[rows]]][0]
        raise InputError(f"{tp.sources[0].path}, line {tp.line[i]}: tool '{tp.tool_names[tp.tool[i]]}' is not defined in the program")
    return int(used[0]), rows
