"""CYCLE800 (swivel plane): the frame the 840D sets from the cycle's parameters.

``CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR, _FR_I, _DMODE)``
(SINUMERIK 840D sl / 828D Programming Manual "Cycles" and Operating Manual, "Swivel plane
(CYCLE800)"; parameter screen: "X0 Y0 Z0 reference point for rotation", "X1 Y1 Z1 zero point
of the rotated surface"):
- ``_TC``: the swivel data record (the machine's kinematics); ``"0"`` deselects it and deletes
  the swivel frame;
- ``_ST`` units digit: 0 a new swivel plane (replaces the swivel frame), 1 additive (on it);
- ``_MODE`` bits 7-6: 00 axis by axis, 01 solid angle, 10 projection angle, 11 direct (rotary
  axis positions); axis by axis, bits 1-0 / 3-2 / 5-4 name the axes of the 1st / 2nd / 3rd
  rotation (01 X, 10 Y, 11 Z: 57 is X-Y-Z, 27 is Z-Y-X), turned by ``_A`` / ``_B`` / ``_C`` in
  that order, each about the axis the rotations before it left (as AROT in turn); solid angle:
  ``_A`` about Z, then ``_B`` about the turned Y;
- the frame: ``TRANS(_X0..) @ rotation @ TRANS(_X1..)``.
The swivel frame is a system frame below the programmable one (Fundamentals, "Frame chain":
$P_WPFRAME before $P_PFRAME): TRANS / ROT in the program do not delete it, and a point p is at
``settable @ swivel @ programmable @ p``.
The rotary positions the cycle turns to (``rotary_positions``) are the machine's: of the two
solutions for the swivelled tool axis, ``_DIR`` -1 takes the lower value of the direction
reference axis, +1 the higher, 0 does not turn; a solution outside the axis limits gives way to
the other (Operating Manual, "Swivel plane", "Direction (minus/plus)"). The reference axis is
set at commissioning; here it is the machine file's first rotary axis unless named.
Projection angles and direct mode (rotary positions, the machine's kinematics) are not
evaluated: the caller flags what follows, naming ``Unknown``'s reason.
"""

from __future__ import annotations

import re

import numpy as np

from postproc.fivex.kinematics import rotary_solutions
from postproc.fivex.machine import Machine
from postproc.robot.frames import rot_x, rot_y, rot_z

_ROT = {1: rot_x, 2: rot_y, 3: rot_z}
_CALL = re.compile(r"(?i)CYCLE800[ \t]*\((?P<args>[^)\n]*)\)")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_NAMES = ("_FR", "_TC", "_ST", "_MODE", "_X0", "_Y0", "_Z0", "_A", "_B", "_C", "_X1", "_Y1", "_Z1", "_DIR")


class Unknown(ValueError):
    """A CYCLE800 whose frame cannot be worked out from the program (the message says why)."""


def arguments(line: str) -> dict[str, object]:
    """The call's parameters by name: numbers, ``_TC`` as text; an omitted parameter is 0 (a
    PROC's value parameter not given is 0, Job Planning "Subprograms with parameter transfer").
    Raises Unknown for a parameter that is not a literal (an R parameter or expression)."""
    m = _CALL.search(line)
    if m is None:
        raise Unknown("CYCLE800 without its parameter list")
    values: dict[str, object] = {}
    for name, raw in zip(_NAMES, m.group("args").split(","), strict=False):
        raw = raw.strip()
        if name == "_TC":
            values[name] = raw.strip('"')
        elif not raw:
            values[name] = 0.0
        elif _NUMBER.fullmatch(raw):
            values[name] = float(raw)
        else:
            raise Unknown(f"CYCLE800 parameter {name}={raw} is not a number (not evaluated)")
    for name in _NAMES[len(values):]:
        values[name] = "" if name == "_TC" else 0.0
    return values


def moves_not_in_program(line: str) -> str | None:
    """What the call moves that the program does not say (a note), or None: the retraction
    (``_FR`` 1 Z, 2 Z X Y, 4 / 5 along the tool: to positions in the swivel data record) and
    the rotary axes' turn (``_DIR`` not 0)."""
    try:
        p = arguments(line)
    except Unknown:
        return None
    parts = [f"retracts (_FR={p['_FR']:g}, to the swivel data record's positions)"] if p["_FR"] else []
    if p["_DIR"] and str(p["_TC"]).strip() not in ("0", ""):
        parts.append(f"turns the rotary axes (_DIR={p['_DIR']:g})")
    return "CYCLE800 " + " and ".join(parts) + ": moves that are not targets" if parts else None


def rotation(mode: int, abc: np.ndarray) -> np.ndarray:
    """The swivel's rotation (3x3) for ``_MODE`` and the angles ``_A _B _C`` (degrees)."""
    kind = (mode >> 6) & 3
    a, b, c = np.radians(abc)
    if kind == 1:  # solid angle: _A about Z, then _B about the turned Y
        return rot_z(a) @ rot_y(b)
    if kind != 0:
        raise Unknown("CYCLE800 " + ("projection angles" if kind == 2 else "direct mode (rotary axis positions, the machine's kinematics)")
                      + " not evaluated")
    axes = [(mode >> shift) & 3 for shift in (0, 2, 4)]
    if 0 in axes or len(set(axes)) != 3:
        raise Unknown(f"CYCLE800 _MODE={mode}: bits 0-5 do not name an axis sequence")
    return _ROT[axes[0]](a) @ _ROT[axes[1]](b) @ _ROT[axes[2]](c)


def swivel_frame(previous: np.ndarray, line: str, to_mm: float) -> np.ndarray:
    """The swivel frame (4x4) after the CYCLE800 call in ``line``; ``previous``: the one in force."""
    p = arguments(line)
    if str(p["_TC"]).strip() in ("0", ""):
        return np.eye(4)  # swivel data record deselected: swivel frames deleted
    before, after = np.eye(4), np.eye(4)
    before[:3, 3] = np.array([p["_X0"], p["_Y0"], p["_Z0"]]) * to_mm
    after[:3, 3] = np.array([p["_X1"], p["_Y1"], p["_Z1"]]) * to_mm
    turn = np.eye(4)
    turn[:3, :3] = rotation(int(p["_MODE"]), np.array([p["_A"], p["_B"], p["_C"]]))
    additive = int(p["_ST"]) % 10 == 1
    if additive and np.isnan(previous).any():
        raise Unknown("additive CYCLE800 on a swivel frame that is not known")
    return (previous if additive else np.eye(4)) @ before @ turn @ after


def rotary_positions(machine: Machine, rotation_3x3: np.ndarray, direction: float, reference: int = 0) -> np.ndarray:
    """The rotary axes' positions (deg, in the machine file's order) that put the tool along the
    swivelled frame's Z (``rotation_3x3``, in the workpiece frame), chosen by ``_DIR``
    (``direction``: -1 lower, +1 higher value of rotary axis ``reference``). Raises Unknown for
    _DIR=0 (the cycle only computes the frame: the axes stay where they are, which the program
    does not say) and where neither solution is within the limits."""
    if direction == 0:
        raise Unknown("CYCLE800 _DIR=0 does not turn the rotary axes: their positions are where they were")
    tool_axis = np.asarray(rotation_3x3, float) @ machine.tool_axis
    both, _ = rotary_solutions(machine, tool_axis[None, :])
    both = both[0]  # (2 solutions, 2 axes)
    lo = np.array([ax.limits[0] for ax in machine.rotary])
    hi = np.array([ax.limits[1] for ax in machine.rotary])
    inside = np.all((both >= lo - 1e-9) & (both <= hi + 1e-9), axis=1) & ~np.isnan(both).any(axis=1)
    if not inside.any():
        raise Unknown(f"CYCLE800: no rotary solution of {machine.name} within its limits reaches tool axis {np.round(tool_axis, 6).tolist()}")
    order = np.argsort(both[:, reference])  # lower, higher value of the reference axis
    wanted = order[0] if direction < 0 else order[1]
    return both[wanted] if inside[wanted] else both[order[1] if wanted == order[0] else order[0]]
