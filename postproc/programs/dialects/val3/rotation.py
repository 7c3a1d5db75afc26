"""Stäubli's Rx, Ry, Rz: successive rotations about x, then the new y', then the new z''.

VAL3 reference manual, "trsf" type: the orientation of a trsf is "Rx, Ry, Rz" in degrees,
rotations about the moving axes in the order x, y', z'', so R = Rx(rx) Ry(ry) Rz(rz).
Checked against a published converter: RoboDK's ``Pose_2_TxyzRxyz`` (used by its VAL3
post) reads ry = asin(R[0, 2]), rx = atan2(-R[1, 2], R[2, 2]), rz = atan2(-R[0, 1], R[0, 0]),
which is exactly this product (tests/test_val3.py checks both ways). The notation is the
"rxyz" entry of postproc.programs.rotation_forms; these are its conversions by name.
"""

from __future__ import annotations

import numpy as np

from ...rotation_forms import FORMS

RXYZ = FORMS["rxyz"]


def rxyz_to_matrix(rxyz_deg: np.ndarray) -> np.ndarray:
    """(N, 3) Rx, Ry, Rz in degrees -> (N, 3, 3) = Rx(rx) Ry(ry) Rz(rz)."""
    return RXYZ.to_matrix(np.asarray(rxyz_deg, dtype=float).reshape(-1, 3))


def rxyz_to_quat_wxyz(rxyz_deg: np.ndarray) -> np.ndarray:
    """(N, 3) Rx, Ry, Rz in degrees -> unit quaternions w, x, y, z."""
    return RXYZ.to_quat(np.asarray(rxyz_deg, dtype=float).reshape(-1, 3))


def matrix_to_rxyz(rot: np.ndarray) -> np.ndarray:
    """(N, 3, 3) -> Rx, Ry, Rz in degrees, Ry in [-90, 90] (at Ry = ±90, Rx is 0)."""
    rot = np.asarray(rot, dtype=float).reshape(-1, 3, 3)
    return RXYZ.numbers_from_matrix(rot)


def trsf_matrix(values: np.ndarray) -> np.ndarray:
    """(N, 6) x, y, z (mm), Rx, Ry, Rz (deg) -> (N, 4, 4)."""
    values = np.asarray(values, dtype=float).reshape(-1, 6)
    out = np.zeros((len(values), 4, 4))
    out[:, :3, :3] = rxyz_to_matrix(values[:, 3:6])
    out[:, :3, 3] = values[:, :3]
    out[:, 3, 3] = 1.0
    return out
