"""SINUMERIK programmable frames: how TRANS, ATRANS, ROT, AROT, RPL, SCALE, MIRROR compose.

SINUMERIK 840D sl "Fundamentals" programming manual (6FC5398-1BP40), "Coordinate
transformations (frames)":
- the programmable frame sits on the settable frame (G54..G57, G505..G599): a programmed
  point p is at ``settable @ programmable @ p``;
- TRANS, ROT, SCALE, MIRROR are *absolute*: each deletes the whole programmable frame
  (translation, rotation, scale, mirror) and sets its own part; without axes they only delete;
- ATRANS, AROT, ASCALE, AMIRROR are *additive*: they act in the coordinate system the frame
  already gives (``programmable @ new``);
- ROT / AROT X Y Z: rotations about X, Y, Z in the order Z, Y', X'' (roll-pitch-yaw, the
  default of machine data 10600 FRAME_ANGLE_INPUT_MODE = 1), so ``Rz(z) @ Ry(y) @ Rx(x)``;
- ROT / AROT RPL=: a rotation in the active plane: about Z under G17, Y under G18, X under G19.
SCALE / ASCALE / MIRROR / AMIRROR with axes (a scaled or mirrored part) are refused: a scaled
or mirrored frame changes arc directions and lengths in ways postproc does not model yet.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.frames import rot_x, rot_y, rot_z

ABSOLUTE = ("TRANS", "ROT", "SCALE", "MIRROR")
PLANE_AXIS = {17.0: 2, 18.0: 1, 19.0: 0}  # RPL rotates about Z (G17), Y (G18), X (G19)


class FrameRefused(ValueError):
    """A frame instruction the model cannot follow (its message says why)."""


def rotation(xyz_deg: np.ndarray) -> np.ndarray:
    """ROT X Y Z (degrees; NaN: not programmed, 0): Rz @ Ry @ Rx (RPY)."""
    x, y, z = np.radians(np.nan_to_num(xyz_deg))
    return rot_z(z) @ rot_y(y) @ rot_x(x)


def step(frame: np.ndarray, keyword: str, xyz: np.ndarray, rpl: float, plane: float, to_mm: float) -> np.ndarray:
    """The programmable frame (4x4) after one frame instruction.

    ``xyz``: the block's X Y Z values (NaN where not programmed), ``rpl``: its RPL= angle (NaN
    where none), ``plane``: the active plane G code, ``to_mm``: 25.4 under G70/G700 (TRANS
    values are lengths in the program's unit), else 1."""
    given = ~np.isnan(xyz)
    base = np.eye(4) if keyword in ABSOLUTE else frame.copy()
    part = np.eye(4)
    if keyword in ("TRANS", "ATRANS"):
        part[:3, 3] = np.where(given, xyz, 0.0) * to_mm
    elif keyword in ("ROT", "AROT"):
        if not np.isnan(rpl):
            if given.any():
                raise FrameRefused(f"{keyword} takes either X Y Z angles or RPL=, not both")
            angles = np.zeros(3)
            angles[PLANE_AXIS.get(plane, 2)] = rpl
            part[:3, :3] = rotation(angles)
        else:
            part[:3, :3] = rotation(xyz)
    elif given.any():  # SCALE, ASCALE, MIRROR, AMIRROR with axes
        raise FrameRefused(f"{keyword} with axes (a scaled or mirrored coordinate system) is not modelled; "
                           f"the program is refused rather than read without it")
    return base @ part
