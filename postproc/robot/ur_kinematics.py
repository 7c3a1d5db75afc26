"""Analytic inverse kinematics of Universal Robots arms (UR3/5/10/16, CB3 and e-Series),
vectorised over poses.

A UR arm is not ortho-parallel with a spherical wrist (the OPW solver of
``postproc.robot.kinematics`` does not serve it): its shoulder, elbow and wrist-1 axes are
parallel, offset sideways by d4, and wrists 2 and 3 are offset by d5 and d6. Its standard DH
table has alpha (90, 0, 0, 90, -90, 0) deg, a (0, a2, a3, 0, 0, 0) and d (d1, 0, 0, d4, d5,
d6). The closed form (K. P. Hawkins, "Analytic Inverse Kinematics for the Universal Robots
UR-5/UR-10 Arms", Georgia Tech, 2013) gives up to eight solutions: shoulder (joint 1) two
ways, wrist (joint 5) up or down, elbow (joint 3) up or down. Branch order as
``kinematics.ik``: index = 4 * wrist + 2 * shoulder + elbow.

Only NumPy here (no robots import): the functions take a RobotModel-like object with
``alpha_deg``, ``a_mm``, ``d_mm``, ``theta0_deg``, ``joint_sign``.
"""

from __future__ import annotations

import numpy as np

UR_ALPHA_DEG = np.array([90.0, 0.0, 0.0, 90.0, -90.0, 0.0])
WRIST_SINGULAR_EPS = 1e-12  # |sin(theta5)| below this: theta6 is not defined (NaN), as kinematics' OPW solver
_ACOS_SLACK = 1e-10  # cosines beyond +-1 by less than this are rounding at the reach boundary


def is_ur_geometry(robot) -> bool:
    """True for a DH table of the UR shape (see the module's docstring)."""
    a, d = np.asarray(robot.a_mm, float), np.asarray(robot.d_mm, float)
    return bool(np.allclose(robot.alpha_deg, UR_ALPHA_DEG, atol=1e-9) and np.allclose(a[[0, 3, 4, 5]], 0.0, atol=1e-9)
            and np.allclose(d[[1, 2]], 0.0, atol=1e-9) and abs(a[1]) > 0 and abs(a[2]) > 0)


def _dh(theta, d, a, alpha_rad):
    """(..., 4, 4) standard DH transforms Rz(theta) Tz(d) Tx(a) Rx(alpha) for angles theta (...)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha_rad), np.sin(alpha_rad)
    out = np.zeros(np.shape(theta) + (4, 4))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2], out[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2], out[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    out[..., 2, 1], out[..., 2, 2], out[..., 2, 3] = sa, ca, d
    out[..., 3, 3] = 1.0
    return out


def _inverse(t):
    out = np.zeros_like(t)
    rt = np.swapaxes(t[..., :3, :3], -1, -2)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", rt, t[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def _acos(x):
    """arccos with rounding slack at +-1; NaN beyond it (no solution)."""
    x = np.where(np.abs(x) <= 1.0 + _ACOS_SLACK, np.clip(x, -1.0, 1.0), np.nan)
    return np.arccos(x)


def ik(robot, poses: np.ndarray) -> np.ndarray:
    """All solutions (N, 8, 6) in controller degrees within [-180, 180] of flange poses
    base_T_flange (N, 4, 4) in mm; a branch without a solution is a row of NaN."""
    t = np.asarray(poses, dtype=float).reshape(-1, 4, 4)
    n = len(t)
    d, a = np.asarray(robot.d_mm, float), np.asarray(robot.a_mm, float)
    alpha = np.deg2rad(np.asarray(robot.alpha_deg, float))
    theta = np.full((n, 2, 2, 2, 6), np.nan)  # shoulder, wrist, elbow

    # Joint 1: the wrist-2 origin p05 lies in the plane of the arm, d4 off the base axis.
    p05 = t[:, :3, 3] - d[5] * t[:, :3, 2]
    radius = np.hypot(p05[:, 0], p05[:, 1])
    psi = np.arctan2(p05[:, 1], p05[:, 0])
    phi = _acos(d[3] / np.where(radius > 0, radius, np.nan))
    q1 = np.stack([psi + phi, psi - phi], axis=1) + np.pi / 2  # (N, 2)
    s1, c1 = np.sin(q1), np.cos(q1)

    # Joint 5: the flange position along the arm plane's normal fixes cos(q5).
    px, py = t[:, None, 0, 3], t[:, None, 1, 3]
    q5_mag = _acos((px * s1 - py * c1 - d[3]) / d[5])  # (N, 2)
    q5 = np.stack([q5_mag, -q5_mag], axis=2)  # (N, 2 shoulder, 2 wrist)
    s5 = np.sin(q5)
    singular = np.abs(s5) < WRIST_SINGULAR_EPS

    # Joint 6 from the flange's x and y axes seen in the arm plane.
    xx, xy = t[:, None, None, 0, 0], t[:, None, None, 1, 0]
    yx, yy = t[:, None, None, 0, 1], t[:, None, None, 1, 1]
    s1w, c1w = s1[:, :, None], c1[:, :, None]
    safe_s5 = np.where(singular, 1.0, s5)
    q6 = np.arctan2((-yx * s1w + yy * c1w) / safe_s5, (xx * s1w - xy * c1w) / safe_s5)
    q6 = np.where(singular, np.nan, q6)

    # Joints 2, 3, 4: a planar three-link problem in frame 1.
    q1w = np.broadcast_to(q1[:, :, None], q5.shape)
    t16 = _inverse(_dh(q1w, d[0], a[0], alpha[0])) @ t[:, None, None]
    t14 = t16 @ _inverse(_dh(np.nan_to_num(q6), d[5], a[5], alpha[5])) @ _inverse(_dh(q5, d[4], a[4], alpha[4]))
    p13 = t14[..., :3, 3] - d[3] * t14[..., :3, 1]  # frame 4's origin is d4 along frame 3's z, which is frame 4's y (alpha4 = 90)
    x, y = p13[..., 0], p13[..., 1]
    q3_mag = _acos((x**2 + y**2 - a[1] ** 2 - a[2] ** 2) / (2.0 * a[1] * a[2]))
    q3 = np.stack([q3_mag, -q3_mag], axis=3)  # (N, 2, 2, 2 elbow)
    xe, ye = x[..., None], y[..., None]
    q2 = np.arctan2(ye, xe) - np.arctan2(a[2] * np.sin(q3), a[1] + a[2] * np.cos(q3))
    q234 = np.arctan2(t14[..., 1, 0], t14[..., 0, 0])[..., None]
    q4 = q234 - q2 - q3

    theta[..., 0] = q1[:, :, None, None]
    theta[..., 1], theta[..., 2], theta[..., 3] = q2, q3, q4
    theta[..., 4] = q5[..., None]
    theta[..., 5] = q6[..., None]
    q_deg = (np.degrees(theta) - np.asarray(robot.theta0_deg, float)) * np.asarray(robot.joint_sign, float)
    q_deg = (q_deg + 180.0) % 360.0 - 180.0
    bad = np.isnan(q_deg).any(axis=-1, keepdims=True)
    q_deg = np.where(bad, np.nan, q_deg)
    # (N, shoulder, wrist, elbow, 6) -> branch 4 * wrist + 2 * shoulder + elbow
    return q_deg.transpose(0, 2, 1, 3, 4).reshape(n, 8, 6)


def singularity_margins(robot, q_deg: np.ndarray):
    """Distances (deg, deg, mm) of joints q (..., 6) from the wrist (joint 5 at 0 or 180 deg:
    joints 4 and 6 aligned), elbow (joint 3 at 0: arm stretched) and shoulder (the wrist-2
    origin on the cylinder of radius d4 about joint 1, where the two joint-1 solutions meet)
    singularities of a UR arm."""
    q = np.asarray(q_deg, dtype=float)
    theta = np.deg2rad(q * np.asarray(robot.joint_sign, float) + np.asarray(robot.theta0_deg, float))
    wrist = np.degrees(np.arcsin(np.minimum(np.abs(np.sin(theta[..., 4])), 1.0)))
    elbow = np.degrees(np.arcsin(np.minimum(np.abs(np.sin(theta[..., 2])), 1.0)))
    d, a = np.asarray(robot.d_mm, float), np.asarray(robot.a_mm, float)
    # p05 in the base frame: the arm plane's in-plane distance from joint 1's axis.
    reach = a[1] * np.cos(theta[..., 1]) + a[2] * np.cos(theta[..., 1] + theta[..., 2]) + d[4] * np.sin(theta[..., 1] + theta[..., 2] + theta[..., 3])
    return wrist, elbow, np.abs(reach)
