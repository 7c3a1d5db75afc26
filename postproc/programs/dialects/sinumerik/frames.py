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
- SCALE / ASCALE X Y Z: factors per axis (an axis left out: 1), in the coordinate system in
  force; "if ATRANS is programmed with SCALE/ASCALE active, these offset values are also
  scaled" (the same composition);
- MIRROR / AMIRROR X0 Y0 Z0: each named axis mirrored (the value has no meaning); the 840D
  swaps G2/G3 (and G41/G42) under a mirror of one axis of the plane.
The programmable frame is kept as a rigid part and a diagonal (the axes' scale and mirror):
a point p is at ``rigid @ diag(axis_scale) @ p`` (``step``). A rotation added to a frame
that scales its axes by different amounts would shear it, which the 840D's frame (separate
translation, rotation, scale and mirror components) cannot hold: refused.
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


def step(frame: np.ndarray, axis_scale: np.ndarray, keyword: str, xyz: np.ndarray, rpl: float, plane: float,
         to_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The programmable frame after one frame instruction: its rigid part (4x4) and its axes'
    scale and mirror factors (3,), a point p at ``rigid @ diag(axis_scale) @ p``.

    ``xyz``: the block's X Y Z values (NaN where not programmed), ``rpl``: its RPL= angle (NaN
    where none), ``plane``: the active plane G code, ``to_mm``: 25.4 under G70/G700 (TRANS
    values are lengths in the program's unit), else 1."""
    given = ~np.isnan(xyz)
    if keyword in ABSOLUTE:
        frame, axis_scale = np.eye(4), np.ones(3)
    frame, axis_scale = frame.copy(), np.asarray(axis_scale, dtype=float).copy()
    if keyword in ("TRANS", "ATRANS"):
        # rigid @ D @ Trans(t) = rigid @ Trans(D t) @ D: an offset in scaled or mirrored axes is scaled too
        part = np.eye(4)
        part[:3, 3] = axis_scale * np.where(given, xyz, 0.0) * to_mm
        return frame @ part, axis_scale
    if keyword in ("ROT", "AROT"):
        return frame @ _rotation_part(keyword, xyz, rpl, plane, axis_scale), axis_scale
    if keyword in ("SCALE", "ASCALE"):
        factors = np.where(given, xyz, 1.0)
        if (factors == 0.0).any():
            raise FrameRefused(f"{keyword} with a factor 0 (every point of the axis on its origin) is not a coordinate system")
        return frame, axis_scale * factors
    return frame, np.where(given, -axis_scale, axis_scale)  # MIRROR, AMIRROR: the named axes turn round


def _rotation_part(keyword: str, xyz: np.ndarray, rpl: float, plane: float, axis_scale: np.ndarray) -> np.ndarray:
    """The rigid 4x4 that ROT / AROT adds: ``D @ R = (D R D^-1) @ D`` with D the axes' scale and
    mirror, a rotation where D scales all axes alike (a mirror turns its sense); else refused."""
    if not np.isnan(rpl):
        if (~np.isnan(xyz)).any():
            raise FrameRefused(f"{keyword} takes either X Y Z angles or RPL=, not both")
        angles = np.zeros(3)
        angles[PLANE_AXIS.get(plane, 2)] = rpl
    else:
        angles = xyz
    turned = (axis_scale[:, None] * rotation(angles)) / axis_scale[None, :]
    if not np.allclose(turned.T @ turned, np.eye(3), rtol=0.0, atol=1e-12):
        raise FrameRefused(f"{keyword} in a frame that scales its axes by different factors (SCALE / ASCALE): the turned "
                           "coordinate system would be sheared, which the 840D's frame does not hold; write ROT before SCALE")
    part = np.eye(4)
    part[:3, :3] = turned
    return part
