"""The standard-DH chain and the OPW angle mapping: the one copy of each, for every caller.

Numbers only (arrays and parameter records); no robot files, so ``robots`` (which checks a
file's OPW section against its DH table) and ``kinematics`` both import this module and
neither imports the other's users. The chain is one compiled kernel (``_dh_kernel``) over
chunks of poses on a thread pool: numba releases the GIL (``nogil``).
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

from postproc.errors import KinematicsError

from .frames import make_transform, rot_y, rot_z

CHUNK = 16384
_PARALLEL_MIN = 4 * CHUNK


def tool_transform(tool) -> np.ndarray | None:
    if tool is None:
        return None
    tool = np.asarray(tool, dtype=float)
    if tool.shape == (3,):
        out = np.eye(4)
        out[:3, 3] = tool
        return out
    if tool.shape == (4, 4):
        return tool
    raise KinematicsError(f"tool must be an offset (3,) in mm or a transform (4, 4), got shape {tool.shape}")


def as_joints(q_deg) -> np.ndarray:
    q = np.asarray(q_deg, dtype=float)
    if q.ndim == 1 and q.shape[0] == 6:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != 6:
        raise KinematicsError(f"joint values must have shape (N, 6), got {q.shape}")
    return q



def run_chunked(n: int, work) -> None:
    """Call work(start, stop) over chunks, on threads when the batch is large."""
    bounds = [(s, min(s + CHUNK, n)) for s in range(0, n, CHUNK)]
    workers = min(os.cpu_count() or 1, len(bounds))
    if n < _PARALLEL_MIN or workers < 2:
        for s, e in bounds:
            work(s, e)
        return
    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(pool.map(lambda b: work(*b), bounds))



@njit(cache=True, nogil=True)
def _dh_kernel(theta, d, a, alpha, rots, origins, flange):
    """The DH chain of _chain, compiled: per pose, frames 0..6 into rots (N, 7, 3, 3) and
    origins (N, 7, 3) when those have N rows, and the flange pose into flange (N, 4, 4)
    when it has. theta (N, 6) radians; d, a, alpha (M, 6) with M = 1 (constants) or N."""
    n = theta.shape[0]
    keep = rots.shape[0] == n
    want_flange = flange.shape[0] == n
    for p in range(n):
        gd = p if d.shape[0] > 1 else 0
        ga = p if a.shape[0] > 1 else 0
        gl = p if alpha.shape[0] > 1 else 0
        c00, c01, c02 = 1.0, 0.0, 0.0  # columns of the rotation: c0 = (c00, c01, c02), ...
        c10, c11, c12 = 0.0, 1.0, 0.0
        c20, c21, c22 = 0.0, 0.0, 1.0
        px, py, pz = 0.0, 0.0, 0.0
        if keep:
            for i in range(3):
                for j in range(3):
                    rots[p, 0, i, j] = 1.0 if i == j else 0.0
                origins[p, 0, i] = 0.0
        for i in range(6):
            ct, st = math.cos(theta[p, i]), math.sin(theta[p, i])
            ca, sa = math.cos(alpha[gl, i]), math.sin(alpha[gl, i])
            n0x, n0y, n0z = c00 * ct + c10 * st, c01 * ct + c11 * st, c02 * ct + c12 * st
            r1x, r1y, r1z = c10 * ct - c00 * st, c11 * ct - c01 * st, c12 * ct - c02 * st
            n1x, n1y, n1z = r1x * ca + c20 * sa, r1y * ca + c21 * sa, r1z * ca + c22 * sa
            n2x, n2y, n2z = c20 * ca - r1x * sa, c21 * ca - r1y * sa, c22 * ca - r1z * sa
            px += d[gd, i] * c20 + a[ga, i] * n0x
            py += d[gd, i] * c21 + a[ga, i] * n0y
            pz += d[gd, i] * c22 + a[ga, i] * n0z
            c00, c01, c02 = n0x, n0y, n0z
            c10, c11, c12 = n1x, n1y, n1z
            c20, c21, c22 = n2x, n2y, n2z
            if keep:
                f = i + 1
                rots[p, f, 0, 0], rots[p, f, 1, 0], rots[p, f, 2, 0] = c00, c01, c02
                rots[p, f, 0, 1], rots[p, f, 1, 1], rots[p, f, 2, 1] = c10, c11, c12
                rots[p, f, 0, 2], rots[p, f, 1, 2], rots[p, f, 2, 2] = c20, c21, c22
                origins[p, f, 0], origins[p, f, 1], origins[p, f, 2] = px, py, pz
        if want_flange:
            flange[p, 0, 0], flange[p, 1, 0], flange[p, 2, 0] = c00, c01, c02
            flange[p, 0, 1], flange[p, 1, 1], flange[p, 2, 1] = c10, c11, c12
            flange[p, 0, 2], flange[p, 1, 2], flange[p, 2, 2] = c20, c21, c22
            flange[p, 0, 3], flange[p, 1, 3], flange[p, 2, 3] = px, py, pz
            flange[p, 3, 0], flange[p, 3, 1], flange[p, 3, 2], flange[p, 3, 3] = 0.0, 0.0, 0.0, 1.0



def dh_rows(values, n: int, name: str) -> np.ndarray:
    """A DH column set as (1, 6) constants or (N, 6) per pose, C-contiguous, for _dh_kernel."""
    arr = np.asarray(values, dtype=float)
    if arr.shape == (6,):
        return arr.reshape(1, 6)
    if arr.shape == (n, 6):
        return np.ascontiguousarray(arr)
    raise KinematicsError(f"DH '{name}' must have shape (6,) or (N, 6) with N = {n}, got {arr.shape}")



def run_dh(theta_deg, d_mm, a_mm, alpha_deg, frames: bool):
    theta = np.ascontiguousarray(np.deg2rad(as_joints(theta_deg)))
    n = theta.shape[0]
    d, a = dh_rows(d_mm, n, "d"), dh_rows(a_mm, n, "a")
    alpha = np.deg2rad(dh_rows(alpha_deg, n, "alpha"))
    rots = np.empty((n if frames else 0, 7, 3, 3))
    origins = np.empty((n if frames else 0, 7, 3))
    flange = np.empty((0 if frames else n, 4, 4))

    def rows(col, s, e):
        return col[s:e] if len(col) > 1 else col

    def work(s, e):
        _dh_kernel(theta[s:e], rows(d, s, e), rows(a, s, e), rows(alpha, s, e), rots[s:e] if frames else rots, origins[s:e] if frames else origins, flange if frames else flange[s:e])

    run_chunked(n, work)
    return (rots, origins) if frames else flange



def forward_dh(theta_deg, d_mm, a_mm, alpha_deg, tool=None) -> np.ndarray:
    """Poses (N, 4, 4) of a standard-DH chain whose parameters may vary per pose.

    theta_deg (N, 6) are the DH angles (joint value times sign plus offset, plus any
    error); d, a, alpha are (6,) or (N, 6). Used where the geometry differs from the
    robot file's: identified errors, thermal growth.
    """
    out = run_dh(theta_deg, d_mm, a_mm, alpha_deg, frames=False)
    tool_t = tool_transform(tool)
    return out if tool_t is None else out @ tool_t



def frames_dh(theta_deg, d_mm, a_mm, alpha_deg) -> tuple[np.ndarray, np.ndarray]:
    """All frames 0..6 of a per-pose DH chain: rotations (N, 7, 3, 3), origins (N, 7, 3)."""
    return run_dh(theta_deg, d_mm, a_mm, alpha_deg, frames=True)


# ----------------------------------------------------------------------------- OPW


def opw_angles(opw, q_deg: np.ndarray) -> np.ndarray:
    """OPW joint angles phi = signs * q - offsets (N, 6), radians, of controller joint values in degrees."""
    return np.deg2rad(opw.signs * np.asarray(q_deg, dtype=float) - opw.offsets_deg)


def opw_wrist_centre(opw, phi: np.ndarray):
    """Wrist centre in the plane of the arm from OPW angles phi (radians): (forward of axis 1,
    height above joint 2), mm."""
    psi3 = math.atan2(opw.a2, opw.c3)
    k = math.hypot(opw.a2, opw.c3)
    t2, t3 = phi[..., 1], phi[..., 2]
    forward = opw.c2 * np.sin(t2) + k * np.sin(t2 + t3 + psi3) + opw.a1
    up = opw.c2 * np.cos(t2) + k * np.cos(t2 + t3 + psi3)
    return forward, up


def opw_forward(opw, q_deg) -> np.ndarray:
    """Flange poses (N, 4, 4) from the OPW parameters (Brandstötter et al. 2014)."""
    phi = opw_angles(opw, as_joints(q_deg))
    q1, q2, q3, q4, q5, q6 = phi.T
    cx1, cz1 = opw_wrist_centre(opw, phi)
    centre = np.stack([cx1 * np.cos(q1) - opw.b * np.sin(q1), cx1 * np.sin(q1) + opw.b * np.cos(q1), cz1 + opw.c1], -1)
    rot = rot_z(q1) @ rot_y(q2 + q3) @ rot_z(q4) @ rot_y(q5) @ rot_z(q6)
    return make_transform(rot, centre + opw.c4 * rot[:, :, 2])
