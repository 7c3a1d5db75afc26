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

from ...errors import InputError
from ...fivex.kinematics import fk, rotary_solutions
from ...ir import Toolpath

_TILT = re.compile(r"\+PLANE [A-Z]+@line(\d+)$")
MODES = {"MOVE": 1, "TURN": 2, "STAY": 3}


def plane_extras(planes: dict, positioning_rows: set, frame_names: tuple, frame: np.ndarray) -> dict:
    """Per target: the line of the PLANE in force (0: none), its SEQ, its positioning mode
    (MODES; +10 where MOVE turns about a point a DIST off the tool tip), that DIST (mm), True
    on the PLANE block's own positioning move."""
    n = len(frame)
    line_of_frame = np.array([int(m.group(1)) if (m := _TILT.search(name)) else 0 for name in frame_names], np.int64)
    line = line_of_frame[frame] if n else np.zeros(0, np.int64)
    seq = np.zeros(n, np.int8)
    mode = np.zeros(n, np.int8)
    dist = np.zeros(n)
    for at, (sign, how, distance) in planes.items():
        rows = line == at
        seq[rows] = sign
        mode[rows] = MODES[how] + (10 if distance else 0)
        dist[rows] = distance
    moving = np.zeros(n, bool)
    moving[[r for r in positioning_rows if r < n]] = True
    return {"heidenhain.plane_line": line, "heidenhain.plane_seq": seq, "heidenhain.plane_mode": mode, "heidenhain.plane_dist": dist,
            "heidenhain.plane_move": moving}


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
    """``tp`` with the targets of a tilted plane (PLANE ... MOVE / TURN) on ``machine``
    placed: positions in the untilted workpiece frame, the rotary axes at the TNC's solution,
    resolved. What the rules above leave open stays flagged with a note."""
    line = tp.extras.get("heidenhain.plane_line")
    if line is None or not (line > 0).any():
        return tp
    notes = list(tp.notes)
    position, ext, resolved, frame = tp.position.copy(), tp.ext.copy(), tp.resolved.copy(), tp.frame.copy()
    cols = ["ABC".index(k) for k in machine.rotary_names]
    for at in np.unique(line[line > 0]).tolist():
        rows = np.nonzero(line == at)[0]
        why = _left_open(tp, machine, rows)
        first = int(rows[0])
        start = ext[first - 1, cols] if first > 0 else np.full(2, np.nan)
        seq = int(tp.extras["heidenhain.plane_seq"][first])
        if why is None and np.isnan(start).any() and not seq:
            why = "without SEQ the TNC takes the shorter way from where the rotary axes are, which the text does not give before this block"
        if why:
            notes.append(f"line {at}: tilted working plane: {why}; its targets stay flagged")
            continue
        relative = np.linalg.inv(tp.frames[0]) @ tp.frames[tp.frame[first]]  # the tilt (about the preset)
        angles = _solution(machine, tp.frames[0][:3, :3] @ relative[:3, 2], seq, start, f"{tp.sources[0].path}:{at}")
        moved = tp.extras["heidenhain.plane_move"][rows]
        own = rows[~moved]
        position[own] = np.einsum("ij,nj->ni", relative[:3, :3], tp.position[own]) + relative[:3, 3]
        for r in rows[moved]:
            position[r] = _positioned_tip(tp, machine, r, position[r - 1], start, angles)
        frame[rows] = 0
        ext[np.ix_(rows, cols)] = angles
        resolved[rows] = ~np.isnan(position[rows]).any(axis=1)
        notes = [n for n in notes if not n.startswith((f"line {at}: tilted working plane: positions", f"line {at}: PLANE ... MOVE", f"line {at}: PLANE ... TURN"))]
        notes.append(f"line {at}: tilted working plane on {machine.name}: the TNC's rotary solution {machine.rotary_names[0]}{angles[0]:+.4f} "
                     f"{machine.rotary_names[1]}{angles[1]:+.4f} (SEQ{'+' if seq > 0 else '-' if seq < 0 else ' not given: the shorter way'})")
    return replace(tp, position=position, ext=ext, resolved=resolved, frame=frame, notes=tuple(notes))


def master_first(machine) -> list[int]:
    """Indices of machine.rotary with the master axis first: "the 1st rotary axis from the tool,
    or the last rotary axis from the table" (TNC 640 manual, SEQ): the table axis nearest the
    bed (rotary[0]) of a table-table machine, the head axis nearest the tool (rotary[1]) of a
    head-head one: on both the axis that tilts the tool axis."""
    return [0, 1] if machine.kind == "table-table" else [1, 0]


def _solution(machine, axis: np.ndarray, seq: int, start: np.ndarray, where: str) -> np.ndarray:
    """The rotary positions (2,) deg, machine.rotary order, that the TNC takes for tool axis ``axis``."""
    order = master_first(machine)
    periodic = np.array([ax.periodic for ax in machine.rotary])
    limits = np.array([ax.limits for ax in machine.rotary], float)
    cand, free = rotary_solutions(machine, axis[None, :])
    start0 = np.nan_to_num(start)
    cand = np.where(free[0], start0, cand[0])  # an axis free at the pole stays where it is
    cand = np.stack([nearest_turn(cand[b], start0, periodic) for b in range(2)])
    picked = choose(cand[:, order], limits[order], seq, start0[order], where)
    return picked[np.argsort(order)]


def _positioned_tip(tp: Toolpath, machine, row: int, before: np.ndarray, start: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Where the tool tip is (preset frame) after the PLANE block's own positioning: MOVE turns
    about the tip (it stays); TURN turns only the rotary axes, the linear axes stay (TNC 640
    manual, "Automatic positioning: MOVE/TURN/STAY"), so the tip moves with the table or swings
    with the head: the machine's forward kinematics at the new angles from the same linear axes."""
    mode = int(tp.extras["heidenhain.plane_mode"][row])
    if mode == MODES["MOVE"]:
        return before
    preset = tp.frames[0]
    tip = preset[:3, :3] @ before + preset[:3, 3]
    length = float(tp.tools[tp.tool[row]][2, 3])
    if mode == MODES["MOVE"] + 10:  # the centre DIST along the tool axis stays on the workpiece
        dist = float(tp.extras["heidenhain.plane_dist"][row])
        axis_before = fk(machine, np.r_[tip, start][None, :], length)[1][0]
        axis_after = fk(machine, np.r_[tip, angles][None, :], length)[1][0]
        turned = tip + dist * (axis_before - axis_after)
    else:
        linear = _linear_axes(machine, tip, start, length)
        turned = fk(machine, np.r_[linear, angles][None, :], length)[0][0]
    return preset[:3, :3].T @ (turned - preset[:3, 3])


def _linear_axes(machine, tip: np.ndarray, angles: np.ndarray, length: float) -> np.ndarray:
    """The linear axis positions that put the tip at ``tip`` (workpiece) with the rotary axes at
    ``angles``: forward kinematics are affine in the linear axes, solved from four evaluations."""
    probe = np.zeros((4, 5))
    probe[1:, :3] = np.eye(3)
    probe[:, 3:] = angles
    out = fk(machine, probe, length)[0]
    return np.linalg.solve((out[1:] - out[0]).T, tip - out[0])


def _left_open(tp: Toolpath, machine, rows: np.ndarray) -> str | None:
    """Why the TNC's positions under this plane are not determined here, or None."""
    if machine.kind not in ("table-table", "head-head"):
        return f"machine {machine.name} is {machine.kind}: its master axis is the machine builder's (table-table and head-head machines are solved)"
    first = int(rows[0])
    mode = int(tp.extras["heidenhain.plane_mode"][first])
    if mode == MODES["STAY"]:
        return "STAY leaves the rotary axes to the program's own blocks (Q120-Q122 are the TNC's)"
    before = tp.ext[first - 1, ["ABC".index(k) for k in machine.rotary_names]] if first > 0 else np.full(2, np.nan)
    if mode != MODES["MOVE"] and np.isnan(before).any():
        return ("TURN moves the tool tip with the rotary axes from where they are" if mode == MODES["TURN"] else
                "MOVE DIST turns about a point on the tool axis where it is") + ", which the text does not give before this block"
    if mode != MODES["MOVE"] and machine.kind == "head-head" and tp.tool_known is not None and not tp.tool_known[tp.tool[first]]:
        return f"on head machine {machine.name} the tip swings by the tool length, which the program does not give (the tool table's)"
    if not re.fullmatch(r"PRESET\+PLANE [A-Z]+@line\d+", tp.frame_names[tp.frame[first]]):
        return "the plane is tilted on a datum shift (Cycle 7), which is not placed here"
    if tp.frame_known is not None and not tp.frame_known[tp.frame[first]]:
        return "the plane's angles are not determined by the text (a Q parameter the text does not give)"
    if tp.frame_known is not None and not tp.frame_known[0]:
        return "the workpiece preset is not given (--frame PRESET=...)"
    return None
