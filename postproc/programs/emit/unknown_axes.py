"""Why a target's position is unknown when a new program is written, and how to give it.

A G-code block names only the axes it moves; the others keep the value they had. One the
program never set is where the machine happened to be when the program started (after a
G28 / G30 / G38.x: where the controller or the probe left it), which the text does not
say. ``convert`` refuses such a target; the message names the axes, why each is unknown
and what to write (before: "line 6: target position unknown in the input").
"""

from __future__ import annotations

import numpy as np

from postproc.errors import EmitError

from ..ir import Kind, Toolpath

AXES = "XYZ"


def refuse_unknown_positions(tp: Toolpath) -> None:
    """EmitError at the first Cartesian target whose position is unknown (file:line:1)."""
    bad = np.nonzero(np.isnan(tp.position).any(axis=1) & (tp.kind != Kind.ABSJ))[0]
    if len(bad):
        raise EmitError(explain(tp, int(bad[0])))


def explain(tp: Toolpath, row: int) -> str:
    """'FILE:LINE:1: target position unknown: Z ...; give ...' for target ``row``."""
    where = f"{tp.sources[int(tp.file[row])].path}:{int(tp.line[row])}:1"
    unknown = np.isnan(tp.position[row])
    seen = ~np.isnan(tp.position[:row])  # (row, 3): where each axis was known before
    reasons: dict[str, list[str]] = {}  # why -> the axes it holds for
    for axis in np.nonzero(unknown)[0].tolist():
        known_before = np.nonzero(seen[:, axis])[0]
        if tp.relative[row]:
            why = "an incremental (G91) move from a position the program never gave"
        elif not len(known_before):
            why = "never set since the program start (where the machine is when the program starts is not in the text)"
        else:
            why = (f"unknown since the block after line {int(tp.line[int(known_before[-1])])} (a G28/G30/G38.x, a G53 move, or a change of "
                   "work offset or tool length the program does not give: see the notes of `postproc inspect`)")
        reasons.setdefault(why, []).append(AXES[axis])
    axes = " ".join(AXES[a] for a in np.nonzero(unknown)[0].tolist())
    remedy = (f"give {axes} in this block, or in a G90 move before it (e.g. a safe G0 {axes.split()[0]}.. at the program start)"
              if not tp.relative[row] else "start with a G90 move to a known point before the G91 moves")
    said = "; ".join(f"{' '.join(names)}: {why}" for why, names in reasons.items())
    return f"{where}: target position unknown in the input: {said}; {remedy}"
