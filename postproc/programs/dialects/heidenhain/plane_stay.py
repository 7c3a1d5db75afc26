"""The targets of a tilted plane whose rotary axes the program positions itself: PLANE ... STAY
and Cycle 19 (TNC 640 User's Manual, "Automatic positioning: MOVE/TURN/STAY": "the TNC saves
the positioning values in Q120 (A), Q121 (B), Q122 (C)"; "Cycle 19 WORKING PLANE": the cycle
positions no axis, the next blocks do).

A target is placed where its rotary positions (the program's numbers, or Q120..Q122 as the
TNC's solution) turn the tool axis onto the tilted plane's: its X Y Z are then the tilted
plane's (rotated into the workpiece). A block that programs only rotary axes moves no linear
axis (without M128), so its tip moves with the table or swings with the head
(plane_motion.tip_after_turn). Targets before the axes reach the plane are flagged: the TNC
runs them in a tilted system the rotary axes do not stand in.
"""

from __future__ import annotations

import numpy as np

from ...ir import F_POS, Toolpath
from .plane_motion import tip_after_turn, tool_axes


def place_stay(tp: Toolpath, machine, rows: np.ndarray, tilt: np.ndarray, in_plane: np.ndarray, solution: np.ndarray | None,
               out: dict, where: str) -> str:
    """Place ``rows`` (one STAY plane / Cycle 19) into ``out``; the note that says how."""
    at = where.rsplit(":", 1)[1]
    cols = ["ABC".index(k) for k in machine.rotary_names]
    rot = out["ext"][np.ix_(rows, cols)]
    fill = tp.extras["heidenhain.plane_q"][np.ix_(rows, cols)] & np.isnan(rot)
    if fill.any():
        if solution is None:
            return (f"line {at}: tilted working plane: Q120..Q122 (the TNC's solution) position the rotary axes, and without SEQ the TNC "
                    "takes the shorter way from where they are, which the text does not give before the plane; its targets stay flagged")
        rot = np.where(fill, solution[None, :], rot)
    known = ~np.isnan(rot).any(axis=1)
    axis = tool_axes(machine, np.nan_to_num(rot))
    at_plane = known & (np.linalg.norm(axis - tp.frames[0][:3, :3] @ tilt[:, 2], axis=1) < 1e-6)
    position = in_plane.copy()
    rotary_only = np.isnan(tp.values[rows, F_POS]).all(axis=1)
    for i in np.nonzero(at_plane & rotary_only)[0]:
        position[i] = _turned(tp, machine, rows, i, rot, at_plane, out)
    placed = at_plane & ~np.isnan(position).any(axis=1)
    out["position"][rows[placed]] = position[placed]
    out["frame"][rows[placed]] = 0
    out["ext"][np.ix_(rows, cols)] = np.where(known[:, None], rot, out["ext"][np.ix_(rows, cols)])
    out["resolved"][rows] = tp.extras["heidenhain.resolved_but_plane"][rows] & placed
    names = machine.rotary_names
    note = f"line {at}: tilted working plane on {machine.name}: the program positions the rotary axes (STAY / Cycle 19)"
    if fill.any():
        note += f"; Q120..Q122 are the TNC's solution {names[0]}{solution[0]:+.4f} {names[1]}{solution[1]:+.4f}"
    if not placed.all():
        line = int(tp.line[rows[int(np.argmin(placed))]])
        note += (f"; from line {line} on, targets whose rotary axes do not stand in the tilted plane (or follow from such a target) "
                 "are flagged: the TNC runs them in a tilted system the axes do not give")
    return note


def _turned(tp: Toolpath, machine, rows: np.ndarray, i: int, rot: np.ndarray, at_plane: np.ndarray, out: dict) -> np.ndarray:
    """The tip after a rotary-only block ``rows[i]``: from the tip and angles before it, NaN where
    the tip before it is not known (a target that is not in the plane)."""
    cols = ["ABC".index(k) for k in machine.rotary_names]
    before_row = rows[i] - 1
    if before_row < 0 or (i > 0 and not at_plane[i - 1]):
        return np.full(3, np.nan)
    before_angles = rot[i - 1] if i > 0 else out["ext"][before_row, cols]
    preset = tp.frames[0]
    tip = preset[:3, :3] @ out["position"][before_row] + preset[:3, 3]
    turned = tip_after_turn(machine, tip, before_angles, rot[i], float(tp.tools[tp.tool[rows[i]]][2, 3]))
    return preset[:3, :3].T @ (turned - preset[:3, 3])
