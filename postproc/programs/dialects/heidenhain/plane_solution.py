"""The rotary solution of a tilted working plane (PLANE SPATIAL), as the TNC chooses it.

TNC 640 User's Manual, "Tilting the working plane", PLANE function, "Selecting alternate
tilting possibilities: SEQ +/-": a tilted plane is reached by two rotary solutions.
- "SEQ+ positions the master axis so that it assumes a positive angle", SEQ- a negative one;
  the master axis is "the 1st rotary axis from the tool, or the last rotary axis from the
  table": on a table-table machine the table axis nearest the bed (machine.rotary[0]: A of
  xyzac-trt, B of xyzbc-trt). A solution outside the traverse range: "Angle not permitted".
- Without SEQ: "1. The TNC first checks whether both solution possibilities are within the
  traverse range of the rotary axes. 2. If they are, then the TNC selects the shortest
  possible solution. 3. If only one solution is within the traverse range, the TNC selects
  this solution. 4. If neither ... 'Angle not permitted'." Shortest is read here as the
  smaller sum of the two axes' travel from where they are before the PLANE block; a program
  whose rotary positions before it are not in the text leaves that choice open (flagged).
- MOVE turns the rotary axes about the tool tip (the tip stays where it is on the workpiece);
  TURN turns only the rotary axes (the tip moves with the table) and STAY leaves them for the
  program's own blocks (often from Q120-Q122, which the TNC computes): those stay flagged, as
  do MOVE with a DIST (a centre of rotation off the tip), head machines (whose master axis
  and solution rules are the machine builder's) and a tilt on a datum shift.
A rotary axis that turns without end (C) reaches the same plane at every 360 degrees; which
of them the TNC shows is a machine parameter (modulo display): the angle nearest to where the
axis is is taken, which places the geometry exactly (it does not change the path).
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from postproc.errors import InputError
from postproc.fivex.kinematics import rotary_solutions

from ...ir import Toolpath

_TILT = re.compile(r"\+PLANE SPATIAL@line(\d+)$")
MODES = {"MOVE": 1, "TURN": 2, "STAY": 3}


def plane_extras(planes: dict, positioning_rows: set, frame_names: tuple, frame: np.ndarray) -> dict:
    """Per target: the line of the PLANE SPATIAL in force (0: none), its SEQ, its positioning
    mode (MODES; +10 where MOVE turns about a point a DIST off the tool tip), True on the PLANE block's own positioning move."""
    n = len(frame)
    line_of_frame = np.array([int(m.group(1)) if (m := _TILT.search(name)) else 0 for name in frame_names], np.int64)
    line = line_of_frame[frame] if n else np.zeros(0, np.int64)
    seq = np.zeros(n, np.int8)
    mode = np.zeros(n, np.int8)
    for at, (sign, how, dist) in planes.items():
        rows = line == at
        seq[rows] = sign
        mode[rows] = MODES[how] + (10 if dist else 0)
    moving = np.zeros(n, bool)
    moving[[r for r in positioning_rows if r < n]] = True
    return {"heidenhain.plane_line": line, "heidenhain.plane_seq": seq, "heidenhain.plane_mode": mode, "heidenhain.plane_move": moving}


def choose(candidates: np.ndarray, limits: np.ndarray, seq: int, start: np.ndarray, where: str) -> np.ndarray:
    """The TNC's solution (2,) deg among ``candidates`` (2 solutions, 2 axes: master first)."""
    inside = np.all((candidates >= limits[:, 0] - 1e-9) & (candidates <= limits[:, 1] + 1e-9), axis=1) & ~np.isnan(candidates).any(axis=1)
    if seq:
        pick = [b for b in range(2) if np.sign(candidates[b, 0]) in (seq, 0) and inside[b]]
        if not pick:
            raise InputError(f"{where}: Angle not permitted: SEQ{'+' if seq > 0 else '-'} asks for the master axis "
                             f"{'positive' if seq > 0 else 'negative'}, and no such solution is within its traverse range (TNC 640 manual, PLANE: SEQ)")
        return candidates[pick[0]]
    if not inside.any():
        raise InputError(f"{where}: Angle not permitted: neither rotary solution of the tilted plane is within the traverse range (TNC 640 manual, PLANE: SEQ)")
    travel = np.abs(candidates - start).sum(axis=1)
    travel[~inside] = np.inf
    return candidates[int(np.argmin(travel))]


def nearest_turn(angle: np.ndarray, start: np.ndarray, periodic: np.ndarray) -> np.ndarray:
    """Each endless axis's angle moved by whole turns next to where it is (the same plane)."""
    return np.where(periodic, start + (angle - start + 180.0) % 360.0 - 180.0, angle)


def place_tilted(tp: Toolpath, machine) -> Toolpath:
    """``tp`` with the targets of PLANE SPATIAL ... MOVE / TURN on a table-table ``machine``
    placed: positions in the untilted workpiece frame, the rotary axes at the TNC's solution,
    resolved. What the rules above leave open stays flagged with a note."""
    line = tp.extras.get("heidenhain.plane_line")
    if line is None or not (line > 0).any():
        return tp
    notes = list(tp.notes)
    position, ext, resolved, frame = tp.position.copy(), tp.ext.copy(), tp.resolved.copy(), tp.frame.copy()
    names = machine.rotary_names
    cols = ["ABC".index(k) for k in names]
    periodic = np.array([ax.periodic for ax in machine.rotary])
    limits = np.array([ax.limits for ax in machine.rotary], float)
    for at in np.unique(line[line > 0]).tolist():
        rows = np.nonzero(line == at)[0]
        why = _left_open(tp, machine, rows)
        if why:
            notes.append(f"line {at}: tilted working plane: {why}; its targets stay flagged")
            continue
        first = int(rows[0])
        start = ext[first - 1, cols] if first > 0 else np.full(2, np.nan)
        seq = int(tp.extras["heidenhain.plane_seq"][first])
        if np.isnan(start).any() and not seq:
            notes.append(f"line {at}: tilted working plane without SEQ: the TNC takes the shorter way from where the rotary axes are, which the text "
                         "does not give before this block; its targets stay flagged")
            continue
        relative = np.linalg.inv(tp.frames[0]) @ tp.frames[tp.frame[first]]  # the tilt (about the preset)
        axis = tp.frames[0][:3, :3] @ relative[:3, 2]  # the tilted tool axis, workpiece frame of the machine
        cand, free = rotary_solutions(machine, axis[None, :])
        start0 = np.nan_to_num(start)
        cand = np.where(free[0], start0, cand[0])  # an axis free at the pole stays where it is
        cand = np.stack([nearest_turn(cand[b], start0, periodic) for b in range(2)])
        angles = choose(cand, limits, seq, start0, f"{tp.sources[0].path}:{at}")
        moved = tp.extras["heidenhain.plane_move"][rows]
        own = rows[~moved]
        position[own] = np.einsum("ij,nj->ni", relative[:3, :3], tp.position[own]) + relative[:3, 3]
        position[rows[moved]] = position[rows[moved] - 1]  # MOVE: the tip stays where it is on the workpiece
        frame[rows] = 0
        for j, c in enumerate(cols):
            ext[rows, c] = angles[j]
        resolved[rows] = ~np.isnan(position[rows]).any(axis=1)
        notes = [n for n in notes if not n.startswith((f"line {at}: tilted working plane: positions", f"line {at}: PLANE ... MOVE"))]  # now read
        notes.append(f"line {at}: tilted working plane on {machine.name}: the TNC's rotary solution {names[0]}{angles[0]:+.4f} "
                     f"{names[1]}{angles[1]:+.4f} (SEQ{'+' if seq > 0 else '-' if seq < 0 else ' not given: the shorter way'})")
    return replace(tp, position=position, ext=ext, resolved=resolved, frame=frame, notes=tuple(notes))


def _left_open(tp: Toolpath, machine, rows: np.ndarray) -> str | None:
    """Why the TNC's positions under this plane are not determined here, or None."""
    if machine.kind != "table-table":
        return f"machine {machine.name} is {machine.kind}: its master axis and solution are the machine builder's (only table-table machines are solved)"
    mode = int(tp.extras["heidenhain.plane_mode"][rows[0]])
    if mode != MODES["MOVE"]:
        return {MODES["TURN"]: "TURN turns only the rotary axes, the tool tip then moves with the table",
                MODES["STAY"]: "STAY leaves the rotary axes to the program's own blocks (Q120-Q122 are the TNC's)"}.get(
            mode, "MOVE with DIST turns about a point off the tool tip")
    if tp.frame_names[tp.frame[rows[0]]].split("+")[1:2] != [f"PLANE SPATIAL@line{int(tp.extras['heidenhain.plane_line'][rows[0]])}"]:
        return "the plane is tilted on a datum shift (Cycle 7), which is not placed here"
    if tp.frame_known is not None and not tp.frame_known[0]:
        return "the workpiece preset is not given (--frame PRESET=...)"
    return None


