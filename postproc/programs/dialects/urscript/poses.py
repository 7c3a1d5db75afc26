"""URScript poses: ``p[x, y, z, rx, ry, rz]`` in metres and a rotation vector in radians
(URScript manual, "Data types: pose"), and the pose functions postproc evaluates when
their arguments are constants (``pose_trans``, ``pose_add``). Vectorised over rows."""

from __future__ import annotations

import numpy as np

from postproc.robot.frames import make_transform

from ...rotation_forms import form

M_TO_MM = 1000.0
RAD_TO_DEG = 180.0 / np.pi


ROTVEC = form("rotvec")  # the rotation vector's entry in the table of notations


def pose_to_transform(pose: np.ndarray) -> np.ndarray:
    """(N, 6) URScript poses (m, rad) -> (N, 4, 4) transforms in millimetres."""
    pose = np.asarray(pose, dtype=float).reshape(-1, 6)
    return make_transform(ROTVEC.to_matrix(pose[:, 3:]), pose[:, :3] * M_TO_MM)


def pose_trans(frame: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose_trans(p_from, p_from_to)`` = p_from . p_from_to, as 4x4 transforms in mm
    (URScript manual, "pose_trans": the second pose expressed in the first's frame)."""
    return frame @ pose


def pose_add_frame(constant: np.ndarray) -> np.ndarray | None:
    """The frame ``pose_add`` with the constant pose ``constant`` (4, 4) applies to its other
    pose, where it is one: the manual defines position p_1.P + p_2.P and rotation p_1.R . p_2.R
    (URScript manual, "pose_add"), a frame (a pure translation) on the other pose only when the
    constant's rotation is the identity. None where it is not."""
    if not np.allclose(constant[:3, :3], np.eye(3), atol=1e-15, rtol=0):
        return None
    return make_transform(np.eye(3)[None], constant[None, :3, 3])[0]
