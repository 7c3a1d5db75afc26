"""Batched rotation kernels: Rodrigues, rotation about a line, Paden-Kahan subproblems 1 and 2.

All functions take arrays over points (leading dimension N) and angles in radians.
"""

from __future__ import annotations

import numpy as np


def rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(N, 3, 3) right-handed rotation by ``angle`` (N,) rad about unit ``axis`` (3,) or (N, 3):
    R = cos I + sin [k]x + (1 - cos) k k^T (Rodrigues, no batched matrix product)."""
    angle = np.asarray(angle, dtype=float)
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    if np.ndim(axis) == 1:  # one axis for all: its matrices are constants
        k = np.asarray(axis, dtype=float)
        kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        kk = np.outer(k, k)
        return kk + c * (np.eye(3) - kk) + s * kx
    k = np.broadcast_to(np.asarray(axis, dtype=float), angle.shape + (3,))
    kx = np.zeros(angle.shape + (3, 3))
    kx[..., 0, 1], kx[..., 0, 2], kx[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    kx[..., 1, 0], kx[..., 2, 0], kx[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    return c * np.eye(3) + s * kx + (1.0 - c) * (k[..., :, None] * k[..., None, :])


def rotate_about_line(points: np.ndarray, rot: np.ndarray, through: np.ndarray) -> np.ndarray:
    """Points (N, 3) turned by ``rot`` (N, 3, 3) about a line through ``through`` (3,)."""
    return through + np.einsum("nij,nj->ni", rot, points - through)


def subproblem1(axis: np.ndarray, frm: np.ndarray, to: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angle (N,) rad turning ``frm`` onto ``to`` (N, 3) about unit ``axis`` (3,), and the
    length (N,) of ``frm``'s part perpendicular to the axis (0: any angle does, singular)."""
    axis = np.asarray(axis, dtype=float)
    fp = frm - (frm @ axis)[:, None] * axis
    tp = to - (to @ axis)[:, None] * axis
    angle = np.arctan2(np.cross(fp, tp) @ axis, np.einsum("ni,ni->n", fp, tp))
    return angle, np.linalg.norm(fp, axis=1)


def subproblem2(a: np.ndarray, b: np.ndarray, alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """The unit vectors x with x.a = alpha and x.b = beta: (N, 2, 3), NaN where none exists.

    a, b: unit, not parallel (3,); alpha, beta: (N,). Both solutions coincide on the
    boundary of the reachable set (rounding there is absorbed up to 1e-12)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    g = float(a @ b)
    c1 = (alpha - g * beta) / (1.0 - g * g)
    c2 = (beta - g * alpha) / (1.0 - g * g)
    n = np.cross(a, b)
    in_plane = c1 * c1 + c2 * c2 + 2.0 * c1 * c2 * g
    c3sq = (1.0 - in_plane) / float(n @ n)
    c3sq = np.where((c3sq < 0) & (c3sq > -1e-12), 0.0, c3sq)
    c3 = np.sqrt(np.where(c3sq >= 0, c3sq, np.nan))
    base = c1[:, None] * a + c2[:, None] * b
    return np.stack([base + c3[:, None] * n, base - c3[:, None] * n], axis=1)


def line_distance(p1: np.ndarray, d1: np.ndarray, p2: np.ndarray, d2: np.ndarray) -> tuple[float, float]:
    """Distance (mm) between two lines (point, unit direction) and the angle (rad) between them.

    For (nearly) parallel lines the distance is that of p1 from line 2."""
    cross = np.cross(d1, d2)
    angle = float(np.arctan2(np.linalg.norm(cross), abs(float(d1 @ d2))))
    if np.linalg.norm(cross) < 1e-12:
        diff = p1 - p2
        return float(np.linalg.norm(diff - (diff @ d2) * d2)), angle
    return float(abs((p1 - p2) @ cross) / np.linalg.norm(cross)), angle
