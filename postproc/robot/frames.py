"""Orientation conversions between rotation matrices and the controllers' notations.

All functions are vectorised over a leading axis: rotations are (N, 3, 3) and
angles are in degrees, as in files and the public API (conventions.md).
"""

from __future__ import annotations

import numpy as np


def rot_x(angle_rad: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle_rad: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(angle_rad: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    o, z = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def quat_wxyz_to_matrix(quat: np.ndarray) -> np.ndarray:
    """ABB RAPID quaternion [q1, q2, q3, q4] = [w, x, y, z] -> (N, 3, 3); normalised first."""
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def matrix_to_quat_wxyz(rot: np.ndarray) -> np.ndarray:
    """(N, 3, 3) -> unit quaternions [w, x, y, z] with w >= 0 (Shepperd's method, stable everywhere)."""
    r = np.asarray(rot, dtype=float)
    shape = r.shape[:-2]
    r = r.reshape(-1, 3, 3)
    m00, m11, m22 = r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]
    trace = m00 + m11 + m22
    # Of the four candidate (unnormalised) quaternions, each rotation takes the one with the
    # largest pivot, which avoids dividing by a small number; only that one is computed.
    pivot = np.argmax(np.stack([trace, m00, m11, m22], -1), axis=-1)
    q = np.empty((len(r), 4))
    for p in range(4):
        at = np.nonzero(pivot == p)[0]
        if not len(at):
            continue
        s, t = r[at], trace[at]
        a00, a11, a22 = s[:, 0, 0], s[:, 1, 1], s[:, 2, 2]
        q[at] = np.stack(_SHEPPERD[p](s, t, a00, a11, a22), -1)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q).reshape(shape + (4,))


_SHEPPERD = (  # the candidate of each pivot (trace, m00, m11, m22), from the rotations s with trace t
    lambda s, t, a00, a11, a22: (1 + t, s[:, 2, 1] - s[:, 1, 2], s[:, 0, 2] - s[:, 2, 0], s[:, 1, 0] - s[:, 0, 1]),
    lambda s, t, a00, a11, a22: (s[:, 2, 1] - s[:, 1, 2], 1 + a00 - a11 - a22, s[:, 0, 1] + s[:, 1, 0], s[:, 0, 2] + s[:, 2, 0]),
    lambda s, t, a00, a11, a22: (s[:, 0, 2] - s[:, 2, 0], s[:, 0, 1] + s[:, 1, 0], 1 - a00 + a11 - a22, s[:, 1, 2] + s[:, 2, 1]),
    lambda s, t, a00, a11, a22: (s[:, 1, 0] - s[:, 0, 1], s[:, 0, 2] + s[:, 2, 0], s[:, 1, 2] + s[:, 2, 1], 1 - a00 - a11 + a22),
)


def quat_xyzw_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Quaternion in ROS / scipy order [x, y, z, w] -> (N, 3, 3)."""
    q = np.asarray(quat, dtype=float)
    return quat_wxyz_to_matrix(np.concatenate([q[..., 3:], q[..., :3]], axis=-1))


def abc_to_matrix(abc_deg: np.ndarray) -> np.ndarray:
    """KUKA A, B, C in degrees -> R = Rz(A) Ry(B) Rx(C)."""
    abc = np.deg2rad(np.asarray(abc_deg, dtype=float))
    return rot_z(abc[..., 0]) @ rot_y(abc[..., 1]) @ rot_x(abc[..., 2])


def abc_to_quat_wxyz(abc_deg: np.ndarray) -> np.ndarray:
    """KUKA A, B, C in degrees -> unit quaternions [w, x, y, z] (w >= 0) of Rz(A) Ry(B) Rx(C),
    from the half angles directly (no matrices: programs have a million of them)."""
    half = np.deg2rad(np.asarray(abc_deg, dtype=float)) / 2
    ca, cb, cc = np.cos(half[..., 0]), np.cos(half[..., 1]), np.cos(half[..., 2])
    sa, sb, sc = np.sin(half[..., 0]), np.sin(half[..., 1]), np.sin(half[..., 2])
    q = np.stack([ca * cb * cc + sa * sb * sc, ca * cb * sc - sa * sb * cc, ca * sb * cc + sa * cb * sc, sa * cb * cc - ca * sb * sc], -1)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0, -q, q)


def matrix_to_abc(rot: np.ndarray) -> np.ndarray:
    """(N, 3, 3) -> KUKA A, B, C in degrees, B in [-90, 90]; at B = ±90 C is set to 0."""
    r = np.asarray(rot, dtype=float)
    b = np.arctan2(-r[..., 2, 0], np.hypot(r[..., 0, 0], r[..., 1, 0]))
    gimbal = np.hypot(r[..., 0, 0], r[..., 1, 0]) < 1e-12
    a = np.where(gimbal, np.arctan2(-r[..., 0, 1], r[..., 1, 1]), np.arctan2(r[..., 1, 0], r[..., 0, 0]))
    c = np.where(gimbal, 0.0, np.arctan2(r[..., 2, 1], r[..., 2, 2]))
    return np.rad2deg(np.stack([a, b, c], -1))


def xyz_euler_to_matrix(angles_deg: np.ndarray) -> np.ndarray:
    """Fixed-axis XYZ Euler angles (roll about x, then pitch about y, then yaw about z), degrees."""
    ang = np.deg2rad(np.asarray(angles_deg, dtype=float))
    return rot_z(ang[..., 2]) @ rot_y(ang[..., 1]) @ rot_x(ang[..., 0])


def make_transform(rot: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """Stack (N, 3, 3) rotations and (N, 3) positions into (N, 4, 4) homogeneous transforms."""
    rot = np.asarray(rot, dtype=float)
    pos = np.asarray(pos, dtype=float)
    out = np.zeros(rot.shape[:-2] + (4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = pos
    out[..., 3, 3] = 1.0
    return out


def invert_transform(t: np.ndarray) -> np.ndarray:
    """Inverse of rigid transforms (N, 4, 4) without a general matrix inverse."""
    rot = np.swapaxes(t[..., :3, :3], -1, -2)
    return make_transform(rot, -np.einsum("...ij,...j->...i", rot, t[..., :3, 3]))


def wrap_deg(angle: np.ndarray) -> np.ndarray:
    """Wrap angles to [-180, 180)."""
    return (np.asarray(angle) + 180.0) % 360.0 - 180.0


def axis_to_quat_wxyz(axis: np.ndarray) -> np.ndarray:
    """Tool axis vectors (N, 3) -> orientations (N, 4) whose z axis is the tool axis.

    The rotation about the axis is not given by a vector: x is taken as the base x axis
    projected onto the plane normal to the tool axis (base y where x is parallel to it).
    """
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    ref = np.where(np.abs(z[..., :1]) > 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    x = ref - np.sum(ref * z, axis=-1, keepdims=True) * z
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return matrix_to_quat_wxyz(np.stack([x, y, z], axis=-1))


def rotvec_to_matrix(rotvec_deg: np.ndarray) -> np.ndarray:
    """Rotation vector (degrees) -> matrix (Rodrigues)."""
    r = np.deg2rad(np.asarray(rotvec_deg, dtype=float))
    angle = np.linalg.norm(r)
    if angle < 1e-15:
        return np.eye(3)
    k = r / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def kabsch(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid (R, t) minimising |R source + t - target|^2 over (N, 3) point sets (no scaling)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    cov = (target - mu_t).T @ (source - mu_s)
    u, _, vt = np.linalg.svd(cov)
    d = np.sign(np.linalg.det(u @ vt))
    rot = u @ np.diag([1.0, 1.0, d]) @ vt
    return rot, mu_t - rot @ mu_s
