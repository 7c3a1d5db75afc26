"""URScript poses: ``p[x, y, z, rx, ry, rz]`` in metres and a rotation vector in radians
(URScript manual, "Data types: pose"), and the pose functions postproc evaluates when
their arguments are constants (``pose_trans``, ``pose_add``). Vectorised over rows."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ...frames import make_transform, matrix_to_quat_wxyz

M_TO_MM = 1000.0
RAD_TO_DEG = 180.0 / np.pi
TURNS = np.array([-2, -1, 0, 1, 2])  # spellings of one rotation tried when writing near old numbers


def rotvec_to_matrix(rotvec: np.ndarray) -> np.ndarray:
    """(N, 3) rotation vectors (radians) -> (N, 3, 3)."""
    return Rotation.from_rotvec(np.asarray(rotvec, dtype=float).reshape(-1, 3)).as_matrix()


def rotvec_to_quat(rotvec: np.ndarray) -> np.ndarray:
    """(N, 3) rotation vectors (radians) -> (N, 4) quaternions w, x, y, z."""
    xyzw = Rotation.from_rotvec(np.asarray(rotvec, dtype=float).reshape(-1, 3)).as_quat()
    return xyzw[:, [3, 0, 1, 2]]


def matrix_to_rotvec(rot: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
    """(N, 3, 3) -> (N, 3) rotation vectors, each the spelling (angle + whole turns about the
    same axis) nearest ``near`` (N, 3) where it is given (not NaN): a controller reads every
    spelling as the same rotation (rotation vectors, URScript manual "pose"), and the one
    nearest the program's own numbers keeps a compensated number a small change."""
    rot = np.asarray(rot, dtype=float).reshape(-1, 3, 3)
    plain = Rotation.from_matrix(rot).as_rotvec()
    if near is None:
        return plain
    near = np.asarray(near, dtype=float).reshape(-1, 3)
    angle = np.linalg.norm(plain, axis=1, keepdims=True)
    # The axis of a (near) zero rotation is free: take the old numbers' axis.
    near_norm = np.linalg.norm(np.nan_to_num(near), axis=1, keepdims=True)
    axis = np.where(angle > 1e-12, plain / np.where(angle > 1e-12, angle, 1.0), np.nan_to_num(near) / np.where(near_norm > 0, near_norm, 1.0))
    candidates = axis[:, None, :] * (angle[:, None, :] + 2.0 * np.pi * TURNS[None, :, None])  # (N, K, 3)
    distance = np.linalg.norm(candidates - np.nan_to_num(near)[:, None, :], axis=2)
    best = candidates[np.arange(len(rot)), np.argmin(distance, axis=1)]
    return np.where(np.isnan(near).any(axis=1, keepdims=True), plain, best)


def pose_to_transform(pose: np.ndarray) -> np.ndarray:
    """(N, 6) URScript poses (m, rad) -> (N, 4, 4) transforms in millimetres."""
    pose = np.asarray(pose, dtype=float).reshape(-1, 6)
    return make_transform(rotvec_to_matrix(pose[:, 3:]), pose[:, :3] * M_TO_MM)


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


def transform_quat(transform: np.ndarray) -> np.ndarray:
    """(N, 4, 4) -> (N, 4) the rotations as quaternions w, x, y, z."""
    return matrix_to_quat_wxyz(np.asarray(transform)[:, :3, :3])
