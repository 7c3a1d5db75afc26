"""The rotary solution of a tilted working plane (PLANE, Cycle 19), as the TNC chooses it, and
the targets under it placed on a machine.

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
- MOVE / MOVE DIST / TURN: plane_motion. STAY (and Cycle 19) leaves the rotary axes to the
  program's own blocks, often from Q120-Q122 where the TNC stores its solution: plane_stay.
- PLANE AXIAL and Cycle 19 as axis angles (machine file [heidenhain] cycle19_angles; default
  "spatial", as PLANE SPATIAL): the angles are the rotary positions, the plane is the one they
  tilt to (plane_motion.axis_plane).
  Left flagged with the reason: head-table machines (the master axis is the machine
  builder's), a tilt on a datum shift, angles from Q parameters the text does not give.
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
from .plane_forms import spatial
from .plane_motion import axis_plane, tip_after_move, tip_after_turn
from .plane_stay import place_stay

_TILT = re.compile(r"\+PLANE [A-Z0-9]+@line(\d+)$")
MODES = {"MOVE": 1, "TURN": 2, "STAY": 3}
FORMS = {"AXIAL": 1, "CYCL19": 2}  # planes given by angles whose meaning the machine decides; 0: the rest


def plane_extras(planes: dict, positioning_rows: set, frame_names: tuple, frame: np.ndarray) -> dict:
    """Per target: the line of the PLANE / Cycle 19 in force (0: none), its SEQ, its positioning
    mode (MODES; +10 where MOVE turns about a point a DIST off the tool tip), that DIST (mm), its
    form (FORMS), its A B C (AXIAL, Cycle 19; NaN otherwise), True on the PLANE block's own
    positioning move."""
    n = len(frame)
    line_of_frame = np.array([int(m.group(1)) if (m := _TILT.search(name)) else 0 for name in frame_names], np.int64)
    line = line_of_frame[frame] if n else np.zeros(0, np.int64)
    seq, mode, form = (np.zeros(n, np.int8) for _ in range(3))
    dist = np.zeros(n)
    axes = np.full((n, 3), np.nan)
    for at, (sign, how, distance, name, angles) in planes.items():
        rows = line == at
        seq[rows] = sign
        mode[rows] = MODES[how] + (10 if distance else 0)
        dist[rows] = distance
        form[rows] = FORMS.get(name, 0)
        axes[rows] = angles
    moving = np.zeros(n, bool)
    moving[[r for r in positioning_rows if r < n]] = True
    return {"heidenhain.plane_line": line, "heidenhain.plane_seq": seq, "heidenhain.plane_mode": mode, "heidenhain.plane_dist": dist,
            "heidenhain.plane_form": form, "heidenhain.plane_axes": axes, "heidenhain.plane_move": moving}


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


def master_first(machine) -> list[int]:
    """Indices of machine.rotary with the master axis first: "the 1st rotary axis from the tool,
    or the last rotary axis from the table" (TNC 640 manual, SEQ): the table axis nearest the
    bed (rotary[0]) of a table-table machine, the head axis nearest the tool (rotary[1]) of a
    head-head one: on both the axis that tilts the tool axis."""
    return [0, 1] if machine.kind == "table-table" else [1, 0]


def solution(machine, axis: np.ndarray, seq: int, start: np.ndarray, where: str) -> np.ndarray:
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


def place_tilted(tp: Toolpath, machine) -> Toolpath:
    """``tp`` with the targets of each tilted plane on ``machine`` placed: positions in the
    untilted workpiece frame, the rotary axes at the TNC's solution (MOVE / TURN) or at the
    program's own positions (STAY, Cycle 19), resolved where nothing else leaves them open.
    What the rules above leave open stays flagged with a note."""
    line = tp.extras.get("heidenhain.plane_line")
    if line is None or not (line > 0).any():
        return tp
    out = {"position": tp.position.copy(), "ext": tp.ext.copy(), "resolved": tp.resolved.copy(), "frame": tp.frame.copy()}
    notes = list(tp.notes)
    for at in np.unique(line[line > 0]).tolist():
        rows = np.nonzero(line == at)[0]
        try:
            note = _place_plane(tp, machine, rows, out)
        except _Open as why:
            note = f"line {at}: tilted working plane: {why}; its targets stay flagged"
        else:
            notes = [n for n in notes if not n.startswith((f"line {at}: tilted working plane: positions", f"line {at}: PLANE ... "))]
        notes.append(note)
    return replace(tp, notes=tuple(notes), **out)


class _Open(Exception):
    """Why a plane's targets are not placed (the reason goes into a note)."""


def _place_plane(tp: Toolpath, machine, rows: np.ndarray, out: dict) -> str:
    """Place one plane's targets into ``out``; the note that says how, or _Open."""
    why = _left_open(tp, machine, rows, out["ext"])
    if why:
        raise _Open(why)
    first, at = int(rows[0]), int(tp.extras["heidenhain.plane_line"][rows[0]])
    cols = ["ABC".index(k) for k in machine.rotary_names]
    start = out["ext"][first - 1, cols] if first > 0 else np.full(2, np.nan)
    seq, mode = int(tp.extras["heidenhain.plane_seq"][first]), int(tp.extras["heidenhain.plane_mode"][first])
    tilt, given = _rotation(tp, machine, first, start)
    where = f"{tp.sources[0].path}:{at}"
    if given is not None:
        angles, how = given, "the plane's axis angles"
    elif seq or not np.isnan(start).any():
        axis = tp.frames[0][:3, :3] @ tilt[:, 2]  # the tilted tool axis, workpiece frame of the machine
        angles = solution(machine, axis, seq, start, where)
        how = f"SEQ{'+' if seq > 0 else '-' if seq < 0 else ' not given: the shorter way'}"
    elif mode == MODES["STAY"]:
        angles, how = None, ""
    else:
        raise _Open("without SEQ the TNC takes the shorter way from where the rotary axes are, which the text does not give before this block")
    aside = tp.extras["heidenhain.resolved_but_plane"]
    in_plane = np.einsum("ij,nj->ni", tilt, tp.position[rows])  # about the preset (no datum shift: _left_open)
    if mode == MODES["STAY"]:
        return place_stay(tp, machine, rows, tilt, in_plane, angles, out, where)
    moved = tp.extras["heidenhain.plane_move"][rows]
    out["position"][rows[~moved]] = in_plane[~moved]
    for r in rows[moved]:
        out["position"][r] = _positioned_tip(tp, machine, r, out["position"][r - 1], start, angles)
    out["frame"][rows] = 0
    out["ext"][np.ix_(rows, cols)] = angles
    out["resolved"][rows] = aside[rows] & ~np.isnan(out["position"][rows]).any(axis=1)
    names = machine.rotary_names
    return f"line {at}: tilted working plane on {machine.name}: the TNC's rotary solution {names[0]}{angles[0]:+.4f} {names[1]}{angles[1]:+.4f} ({how})"


def _rotation(tp: Toolpath, machine, first: int, start: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(R, axis angles or None): the plane's rotation in the preset frame, and the rotary
    positions (machine.rotary order) where the plane states them (AXIAL, Cycle 19 axis angles)."""
    form = int(tp.extras["heidenhain.plane_form"][first])
    if form == 0:
        return (np.linalg.inv(tp.frames[0]) @ tp.frames[tp.frame[first]])[:3, :3], None
    abc = tp.extras["heidenhain.plane_axes"][first]
    reading = machine.heidenhain.get("cycle19_angles", "spatial")
    if form == FORMS["CYCL19"] and reading == "spatial":
        return spatial(*np.nan_to_num(abc)), None  # an angle not given is 0 (TNC 640 manual, Cycle 19: "enter 0")
    cols = ["ABC".index(k) for k in machine.rotary_names]
    if (np.nan_to_num(abc[[i for i in range(3) if i not in cols]]) != 0.0).any():
        raise _Open(f"the axis angles turn an axis machine {machine.name} does not have")
    angles = np.where(np.isnan(abc[cols]), start, abc[cols])  # an axis not given stays where it is
    if np.isnan(angles).any():
        raise _Open("an axis angle is neither given nor where the axis is before this block")
    plane = axis_plane(machine, angles)
    preset = tp.frames[0][:3, :3]
    return preset.T @ plane, angles


def _positioned_tip(tp: Toolpath, machine, row: int, before: np.ndarray, start: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """The tip (preset frame) after the PLANE block's own positioning (plane_motion)."""
    mode = int(tp.extras["heidenhain.plane_mode"][row])
    if mode == MODES["MOVE"]:
        return before
    preset = tp.frames[0]
    tip = preset[:3, :3] @ before + preset[:3, 3]
    if mode == MODES["MOVE"] + 10:
        turned = tip_after_move(machine, tip, start, angles, float(tp.extras["heidenhain.plane_dist"][row]))
    else:
        turned = tip_after_turn(machine, tip, start, angles, float(tp.tools[tp.tool[row]][2, 3]))
    return preset[:3, :3].T @ (turned - preset[:3, 3])


def _left_open(tp: Toolpath, machine, rows: np.ndarray, ext: np.ndarray) -> str | None:
    """Why the TNC's positions under this plane are not determined here, or None (``ext``: the
    rotary positions as placed so far, an earlier plane's included)."""
    if machine.kind not in ("table-table", "head-head"):
        return f"machine {machine.name} is {machine.kind}: its master axis is the machine builder's (table-table and head-head machines are solved)"
    first = int(rows[0])
    mode = int(tp.extras["heidenhain.plane_mode"][first])
    before = ext[first - 1, ["ABC".index(k) for k in machine.rotary_names]] if first > 0 else np.full(2, np.nan)
    if mode not in (MODES["MOVE"], MODES["STAY"]) and np.isnan(before).any():
        return ("TURN moves the tool tip with the rotary axes from where they are" if mode == MODES["TURN"] else
                "MOVE DIST turns about a point on the tool axis where it is") + ", which the text does not give before this block"
    if machine.kind == "head-head" and mode != MODES["MOVE"] and tp.tool_known is not None and not tp.tool_known[tp.tool[first]]:
        return f"on head machine {machine.name} the tip swings by the tool length, which the program does not give (the tool table's)"
    if not re.fullmatch(r"PRESET\+PLANE [A-Z0-9]+@line\d+", tp.frame_names[tp.frame[first]]):
        return "the plane is tilted on a datum shift (Cycle 7), which is not placed here"
    form = int(tp.extras["heidenhain.plane_form"][first])
    if form == 0 and tp.frame_known is not None and not tp.frame_known[tp.frame[first]]:
        return "the plane's angles are not determined by the text (a Q parameter the text does not give)"
    if form and np.isnan(tp.extras["heidenhain.plane_axes"][first]).all():
        return "the plane's angles are not determined by the text"
    if tp.frame_known is not None and not tp.frame_known[0]:
        return "the workpiece preset is not given (--frame PRESET=...)"
    return None
