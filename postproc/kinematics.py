"""Vectorised kinematics: forward kinematics, geometric Jacobian, analytic OPW inverse kinematics.

Every function takes arrays over poses (leading axis N) and has no per-pose Python loop.
Joint values are in degrees at the API (conventions.md); radians only inside the kernels.
The kernels work on a struct of arrays (rotation columns and positions as (3, C) blocks)
over chunks of C poses, which keeps the working set in cache; chunks run on a thread
pool because NumPy releases the GIL inside its ufunc loops.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .errors import KinematicsError
from .robots import RobotModel

CHUNK = 16384
_PARALLEL_MIN = 4 * CHUNK
# |sin(theta5)| below this is treated as the wrist singularity: theta4 and theta6 are then
# only defined through their sum (or difference), and theta4 is set to 0.
WRIST_SINGULAR_EPS = 1e-12
# Triangle inequalities violated by less than this (relative) are rounding at the reach
# boundary, not unreachable poses.
_ACOS_SLACK = 1e-10


def _as_joints(q_deg) -> np.ndarray:
    q = np.asarray(q_deg, dtype=float)
    if q.ndim == 1 and q.shape[0] == 6:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != 6:
        raise KinematicsError(f"joint values must have shape (N, 6), got {q.shape}")
    return q


def _as_poses(t) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.shape == (4, 4):
        t = t[None]
    if t.ndim != 3 or t.shape[1:] != (4, 4):
        raise KinematicsError(f"poses must have shape (N, 4, 4), got {t.shape}")
    return t


def _tool_transform(tool) -> np.ndarray | None:
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


def _run_chunked(n: int, work) -> None:
    """Call work(start, stop) over chunks, on threads when the batch is large."""
    bounds = [(s, min(s + CHUNK, n)) for s in range(0, n, CHUNK)]
    workers = min(os.cpu_count() or 1, len(bounds))
    if n < _PARALLEL_MIN or workers < 2:
        for s, e in bounds:
            work(s, e)
        return
    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(pool.map(lambda b: work(*b), bounds))


def _dh_thetas(robot: RobotModel, q_deg: np.ndarray) -> np.ndarray:
    """(C, 6) controller degrees -> (6, C) DH angles in radians."""
    return np.deg2rad(q_deg * robot.joint_sign + robot.theta0_deg).T.copy()


def _chain(theta: np.ndarray, d, a, alpha, keep_frames: bool):
    """Propagate the DH chain over a chunk.

    theta (6, C) radians; d, a (mm) and alpha (radians) are (6,) constants or (6, C) per
    pose. Returns the flange rotation columns (3 arrays (3, C)) and position (3, C); with
    keep_frames also the list of (columns, origin) of frames 0..6.
    """
    c = theta.shape[1]
    col0 = np.zeros((3, c))
    col1 = np.zeros((3, c))
    col2 = np.zeros((3, c))
    col0[0] = col1[1] = col2[2] = 1.0
    pos = np.zeros((3, c))
    frames = [((col0, col1, col2), pos)] if keep_frames else None
    for i in range(6):
        ct, st = np.cos(theta[i]), np.sin(theta[i])
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        # T_i = T_{i-1} Rz(theta) Tz(d) Tx(a) Rx(alpha), column by column.
        new0 = col0 * ct + col1 * st
        rot1 = col1 * ct - col0 * st
        new1 = rot1 * ca + col2 * sa
        new2 = col2 * ca - rot1 * sa
        pos = pos + d[i] * col2 + a[i] * new0
        col0, col1, col2 = new0, new1, new2
        if keep_frames:
            frames.append(((col0, col1, col2), pos))
    return (col0, col1, col2), pos, frames


def _dh_columns(values, n: int, name: str) -> np.ndarray:
    """A DH column as (6,) constants or (6, N) per pose, from (6,) or (N, 6) input."""
    arr = np.asarray(values, dtype=float)
    if arr.shape == (6,):
        return arr
    if arr.shape == (n, 6):
        return arr.T
    raise KinematicsError(f"DH '{name}' must have shape (6,) or (N, 6) with N = {n}, got {arr.shape}")


def _slice(col: np.ndarray, s: int, e: int) -> np.ndarray:
    return col if col.ndim == 1 else col[:, s:e]


def forward_dh(theta_deg, d_mm, a_mm, alpha_deg, tool=None) -> np.ndarray:
    """Poses (N, 4, 4) of a standard-DH chain whose parameters may vary per pose.

    theta_deg (N, 6) are the DH angles (joint value times sign plus offset, plus any
    error); d, a, alpha are (6,) or (N, 6). Used where the geometry differs from the
    robot file's: identified errors, thermal growth.
    """
    theta = np.deg2rad(_as_joints(theta_deg)).T.copy()
    n = theta.shape[1]
    d = _dh_columns(d_mm, n, "d")
    a = _dh_columns(a_mm, n, "a")
    alpha = np.deg2rad(_dh_columns(alpha_deg, n, "alpha"))
    out = np.zeros((n, 4, 4))
    out[:, 3, 3] = 1.0

    def work(s, e):
        cols, pos, _ = _chain(theta[:, s:e], _slice(d, s, e), _slice(a, s, e), _slice(alpha, s, e), keep_frames=False)
        for j in range(3):
            out[s:e, :3, j] = cols[j].T
        out[s:e, :3, 3] = pos.T

    _run_chunked(n, work)
    tool_t = _tool_transform(tool)
    return out if tool_t is None else out @ tool_t


def frames_dh(theta_deg, d_mm, a_mm, alpha_deg) -> tuple[np.ndarray, np.ndarray]:
    """All frames 0..6 of a per-pose DH chain: rotations (N, 7, 3, 3), origins (N, 7, 3)."""
    theta = np.deg2rad(_as_joints(theta_deg)).T.copy()
    n = theta.shape[1]
    d = _dh_columns(d_mm, n, "d")
    a = _dh_columns(a_mm, n, "a")
    alpha = np.deg2rad(_dh_columns(alpha_deg, n, "alpha"))
    rots = np.zeros((n, 7, 3, 3))
    origins = np.zeros((n, 7, 3))

    def work(s, e):
        _, _, frames = _chain(theta[:, s:e], _slice(d, s, e), _slice(a, s, e), _slice(alpha, s, e), keep_frames=True)
        for k, (cols, pos) in enumerate(frames):
            for j in range(3):
                rots[s:e, k, :, j] = cols[j].T
            origins[s:e, k] = pos.T

    _run_chunked(n, work)
    return rots, origins


def dh_angles(robot: RobotModel, q_deg) -> np.ndarray:
    """DH angles theta (N, 6) in degrees of controller joint values."""
    return _as_joints(q_deg) * robot.joint_sign + robot.theta0_deg


def fk(robot: RobotModel, q_deg, tool=None) -> np.ndarray:
    """Flange (or TCP, with ``tool``) poses base_T_flange (N, 4, 4), mm, for joints q (N, 6) in degrees."""
    return forward_dh(dh_angles(robot, q_deg), robot.d_mm, robot.a_mm, robot.alpha_deg, tool=tool)


def joint_frames(robot: RobotModel, q_deg) -> tuple[np.ndarray, np.ndarray]:
    """All DH frames 0..6: rotations (N, 7, 3, 3) and origins (N, 7, 3), mm. Frame 0 is the base."""
    return frames_dh(dh_angles(robot, q_deg), robot.d_mm, robot.a_mm, robot.alpha_deg)


def jacobian(robot: RobotModel, q_deg, tool=None) -> np.ndarray:
    """Geometric Jacobian (N, 6, 6) of the flange (or TCP) in the base frame.

    Rows 0-2: linear velocity (mm/rad), rows 3-5: angular velocity (rad/rad), per unit of
    the controller's joint value in radians (the joint sign is included).
    """
    q = _as_joints(q_deg)
    n = q.shape[0]
    out = np.zeros((n, 6, 6))
    tool_t = _tool_transform(tool)
    alpha = np.deg2rad(robot.alpha_deg)

    def work(s, e):
        _, pos, frames = _chain(_dh_thetas(robot, q[s:e]), robot.d_mm, robot.a_mm, alpha, keep_frames=True)
        end = pos
        if tool_t is not None:
            cols = frames[-1][0]
            end = pos + cols[0] * tool_t[0, 3] + cols[1] * tool_t[1, 3] + cols[2] * tool_t[2, 3]
        for i in range(6):
            (_, _, z), origin = frames[i]
            r = end - origin
            sign = robot.joint_sign[i]
            lin = np.stack(
                [z[1] * r[2] - z[2] * r[1], z[2] * r[0] - z[0] * r[2], z[0] * r[1] - z[1] * r[0]]
            )
            out[s:e, :3, i] = (sign * lin).T
            out[s:e, 3:, i] = (sign * z).T

    _run_chunked(n, work)
    return out


# ----------------------------------------------------------------------------- OPW


def _require_opw(robot: RobotModel):
    if robot.opw is None:
        raise KinematicsError(
            f"robot '{robot.name}' has no [opw] section: analytic IK needs an ortho-parallel arm with a spherical wrist"
        )
    return robot.opw


def opw_forward(robot: RobotModel, q_deg) -> np.ndarray:
    """Forward kinematics from the OPW parameters (used to check a robot file's two descriptions agree)."""
    p = _require_opw(robot)
    q = _as_joints(q_deg)
    phi = np.deg2rad(p.signs * q - p.offsets_deg)
    q1, q2, q3, q4, q5, q6 = phi.T
    cx1, cz1 = wrist_centre_in_arm_plane(robot, phi)
    centre = np.stack([cx1 * np.cos(q1) - p.b * np.sin(q1), cx1 * np.sin(q1) + p.b * np.cos(q1), cz1 + p.c1], -1)
    from .frames import make_transform, rot_y, rot_z

    rot = rot_z(q1) @ rot_y(q2 + q3) @ rot_z(q4) @ rot_y(q5) @ rot_z(q6)
    return make_transform(rot, centre + p.c4 * rot[:, :, 2])


def _triangle_angle(opposite: np.ndarray, side_b, side_c) -> np.ndarray:
    """Angle (radians) opposite one side of a triangle, from its three side lengths.

    Kahan's formula ("Miscalculating area and angles of a needle-like triangle"): accurate
    to a few ulps even for nearly degenerate triangles, where the law of cosines with acos
    loses half the digits (an arm near full stretch). NaN where no triangle exists.
    """
    a, b, c = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (opposite, side_b, side_c)))
    big, small = np.maximum(b, c), np.minimum(b, c)
    # mu = a - (big - small) or small - (big - a), whichever Kahan's ordering asks for.
    mu = np.where(small >= a, a - (big - small), small - (big - a))
    scale = big + small + a
    slack = _ACOS_SLACK * scale
    mu = np.where((mu < 0) & (mu > -slack), 0.0, mu)
    num = ((big - small) + a) * mu
    den = (big + (small + a)) * ((big - a) + small)
    den = np.where((den < 0) & (den > -slack * scale), 0.0, den)
    with np.errstate(divide="ignore", invalid="ignore"):
        angle = 2.0 * np.arctan(np.sqrt(num / den))
    # den == 0 with num > 0: the angle is pi (a equals the sum of the other sides).
    angle = np.where((den == 0) & (num >= 0), np.pi, angle)
    return np.where((mu < 0) | (den < 0) | (num < 0), np.nan, angle)


def _ik_chunk(p, rot: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """OPW inverse kinematics over a chunk: rot (C, 3, 3), pos (C, 3) -> OPW angles (C, 8, 6) radians."""
    c = pos - p.c4 * rot[:, :, 2]
    cx, cy, cz = c[:, 0], c[:, 1], c[:, 2]
    with np.errstate(invalid="ignore"):
        nx1 = np.sqrt(cx * cx + cy * cy - p.b * p.b) - p.a1
    dz = cz - p.c1
    # Distances from joint 2 to the wrist centre, arm in front (s1) or reaching over the back (s2).
    s1 = np.hypot(nx1, dz)
    s2 = np.hypot(nx1 + 2 * p.a1, dz)
    k = math.hypot(p.a2, p.c3)
    base_angle = np.arctan2(cy, cx)
    shoulder = np.arctan2(p.b, nx1 + p.a1)
    t1_front = base_angle - shoulder
    t1_back = base_angle + shoulder - np.pi
    # Shoulder angle between lower arm and the line to the wrist centre; elbow angle.
    shoulder_a = _triangle_angle(k, s1, p.c2)
    shoulder_b = _triangle_angle(k, s2, p.c2)
    elbow_a = np.pi - _triangle_angle(s1, p.c2, k)
    elbow_b = np.pi - _triangle_angle(s2, p.c2, k)
    lean_a = np.arctan2(nx1, dz)
    lean_b = np.arctan2(nx1 + 2 * p.a1, dz)
    psi3 = math.atan2(p.a2, p.c3)
    arm = [
        (t1_front, -shoulder_a + lean_a, elbow_a - psi3),
        (t1_front, shoulder_a + lean_a, -elbow_a - psi3),
        (t1_back, -shoulder_b - lean_b, elbow_b - psi3),
        (t1_back, shoulder_b - lean_b, -elbow_b - psi3),
    ]
    n = pos.shape[0]
    out = np.empty((n, 8, 6))
    for j, (t1, t2, t3) in enumerate(arm):
        s1_, c1_ = np.sin(t1)[:, None], np.cos(t1)[:, None]
        s23, c23 = np.sin(t2 + t3)[:, None], np.cos(t2 + t3)[:, None]
        # Wrist rotation R_ce = (Rz(t1) Ry(t2 + t3))^T R, decomposed as Rz(t4) Ry(t5) Rz(t6).
        rx0 = c1_ * rot[:, 0, :] + s1_ * rot[:, 1, :]  # row 0 of Rz(t1)^T R
        ry = -s1_ * rot[:, 0, :] + c1_ * rot[:, 1, :]  # row 1
        rz = rot[:, 2, :]
        w0 = c23 * rx0 - s23 * rz  # rows of R_ce
        w1 = ry
        w2 = s23 * rx0 + c23 * rz
        sin5 = np.hypot(w0[:, 2], w1[:, 2])
        t5 = np.arctan2(sin5, w2[:, 2])
        # At the wrist singularity only t4 + t6 (or t6 - t4) is defined: t4 = 0 there.
        t4 = np.where(sin5 < WRIST_SINGULAR_EPS, 0.0, np.arctan2(w1[:, 2], w0[:, 2]))
        # t6 from the rotation left after t4 and t5, so that it absorbs any error of t4
        # (large near the singularity) and the composed rotation stays exact.
        c4, s4, c5, s5 = np.cos(t4), np.sin(t4), np.cos(t5), np.sin(t5)
        m00 = c5 * (c4 * w0[:, 0] + s4 * w1[:, 0]) - s5 * w2[:, 0]
        m10 = -s4 * w0[:, 0] + c4 * w1[:, 0]
        t6 = np.arctan2(m10, m00)
        out[:, j] = np.stack([t1, t2, t3, t4, t5, t6], -1)
        out[:, j + 4] = np.stack([t1, t2, t3, t4 + np.pi, -t5, t6 - np.pi], -1)
    return out


def ik(robot: RobotModel, poses) -> np.ndarray:
    """All analytic inverse solutions (N, 8, 6), controller degrees in [-180, 180].

    ``poses`` are flange poses base_T_flange (N, 4, 4) in mm. A branch with no solution
    (target out of reach for that arm configuration) is a row of NaN. Branch order:
    0-3 the four arm configurations (shoulder front/back x elbow), 4-7 the same with the
    wrist flipped.
    """
    p = _require_opw(robot)
    t = _as_poses(poses)
    n = t.shape[0]
    out = np.empty((n, 8, 6))

    def work(s, e):
        phi = _ik_chunk(p, t[s:e, :3, :3], t[s:e, :3, 3])
        q = p.signs * (np.rad2deg(phi) + p.offsets_deg)
        q = (q + 180.0) % 360.0 - 180.0
        # A branch is unreachable as a whole: never return half a solution.
        q[np.isnan(q).any(axis=-1)] = np.nan
        out[s:e] = q

    _run_chunked(n, work)
    return out


# ---------------------------------------------------------------- branch selection


def within_limits(robot: RobotModel, q_deg, tol_deg: float = 1e-9) -> np.ndarray:
    """(..., 6) -> bool (...): inside every joint limit and every coupling limit; NaN rows are False."""
    q = np.asarray(q_deg, dtype=float)
    ok = np.all((q >= robot.lower_deg - tol_deg) & (q <= robot.upper_deg + tol_deg), axis=-1)
    for coupling in robot.couplings:
        value = q @ coupling.coeffs
        ok &= (value >= coupling.lower - tol_deg) & (value <= coupling.upper + tol_deg)
    return ok & ~np.isnan(q).any(axis=-1)


def _shift_turns_towards(robot: RobotModel, q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Add whole turns to each joint of q to come nearest to ref while staying inside the joint range.

    Only joints whose range spans more than a turn can take another value: the others are
    returned as they are (IK gives [-180, 180], their only representation in range)."""
    wide = (robot.upper_deg - robot.lower_deg) > 360.0 - 1e-9
    if not wide.any():
        return q.copy()
    shifted = q.copy()
    shifted[..., wide] = _shift_wide(robot, q[..., wide], np.broadcast_to(ref, q.shape)[..., wide], wide)
    return shifted


def _shift_wide(robot: RobotModel, q: np.ndarray, ref: np.ndarray, wide: np.ndarray) -> np.ndarray:
    lower, upper = robot.lower_deg[wide], robot.upper_deg[wide]
    shifted = ref + (q - ref + 180.0) % 360.0 - 180.0
    # If the nearest equivalent is outside the limits, try one turn either way.
    for delta in (360.0, -360.0):
        alt = shifted + delta
        bad = (shifted < lower) | (shifted > upper)
        good_alt = (alt >= lower) & (alt <= upper)
        shifted = np.where(bad & good_alt, alt, shifted)
    return shifted


def select_branch(robot: RobotModel, solutions, branch, q_ref) -> tuple[np.ndarray, np.ndarray]:
    """The solution on a given branch per pose (turns unwrapped towards q_ref); where that
    branch is unreachable or outside the limits, the nearest valid one (then the branch differs)."""
    sols = np.asarray(solutions, dtype=float)
    n = sols.shape[0]
    branch = np.asarray(branch)
    q = sols[np.arange(n), np.maximum(branch, 0)]
    q = _shift_turns_towards(robot, q, np.asarray(q_ref, dtype=float))
    ok = (branch >= 0) & within_limits(robot, q)
    out_branch = np.where(ok, branch, -1)
    if not ok.all():
        bad = np.nonzero(~ok)[0]
        q_alt, b_alt = select_nearest(robot, sols[bad], np.asarray(q_ref, dtype=float)[bad] if np.ndim(q_ref) == 2 else q_ref)
        q[bad], out_branch[bad] = q_alt, b_alt
    return q, out_branch


def select_nearest(robot: RobotModel, solutions, q_ref) -> tuple[np.ndarray, np.ndarray]:
    """Pick, per pose, the solution inside the limits nearest to a reference joint vector.

    solutions (N, 8, 6) from ``ik``; q_ref (N, 6) or (6,) degrees (e.g. the previous
    point's joints, or the uncompensated command's). Whole turns are added to joints
    whose range exceeds +-180 so that the result is the equivalent nearest to q_ref.
    Returns (q (N, 6) with NaN rows where no branch is valid, branch index (N,) or -1).
    """
    sols = np.asarray(solutions, dtype=float)
    ref = np.broadcast_to(np.asarray(q_ref, dtype=float), (sols.shape[0], 6))
    cand = _shift_turns_towards(robot, sols, ref[:, None, :])
    valid = within_limits(robot, cand)
    dist = np.where(valid, np.abs(cand - ref[:, None, :]).sum(-1), np.inf)
    idx = np.argmin(dist, axis=1)
    chosen = np.take_along_axis(cand, idx[:, None, None], axis=1)[:, 0]
    none = ~valid.any(axis=1)
    chosen[none] = np.nan
    idx = np.where(none, -1, idx)
    return chosen, idx


def select_path(robot: RobotModel, solutions, q_start, max_step_deg: float = 30.0):
    """Continuous joint path through consecutive poses, starting nearest to q_start.

    The branch of the first pose is kept along the path (a branch only changes at a
    singularity) and joints are unwrapped so consecutive values never jump by a turn.
    Returns (q (N, 6), branch index (N,), ok (N,) bool): ok is False where the branch has
    no solution, leaves the limits, or a joint jumps more than max_step_deg.
    """
    sols = np.asarray(solutions, dtype=float)
    first, idx0 = select_nearest(robot, sols[:1], q_start)
    if idx0[0] < 0:
        n = sols.shape[0]
        return np.full((n, 6), np.nan), np.full(n, -1), np.zeros(n, dtype=bool)
    path = sols[:, idx0[0]].copy()
    path[0] = first[0]
    finite = ~np.isnan(path).any(axis=1)
    filled = path.copy()
    if not finite.all():
        # Unwrap across gaps by carrying the last finite value forward.
        last = np.maximum.accumulate(np.where(finite, np.arange(len(path)), 0))
        filled = path[last]
    steps = (np.diff(filled, axis=0) + 180.0) % 360.0 - 180.0
    unwrapped = np.concatenate([filled[:1], filled[:1] + np.cumsum(steps, axis=0)])
    unwrapped[~finite] = np.nan
    jump = np.zeros(len(path), dtype=bool)
    jump[1:] = np.abs(steps).max(axis=1) > max_step_deg
    ok = finite & within_limits(robot, unwrapped) & ~jump
    return unwrapped, np.full(len(path), idx0[0]), ok


def _opw_angles(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    p = _require_opw(robot)
    if np.isnan(q).any():
        raise KinematicsError("joint values contain NaN: no configuration data for an unreachable pose")
    return np.deg2rad(p.signs * q - p.offsets_deg)


def wrist_centre_in_arm_plane(robot: RobotModel, phi: np.ndarray):
    """Wrist centre in the plane of the arm, from OPW angles phi (radians): (forward of
    axis 1, height above joint 2), mm."""
    p = robot.opw
    psi3 = math.atan2(p.a2, p.c3)
    k = math.hypot(p.a2, p.c3)
    t2, t3 = phi[..., 1], phi[..., 2]
    forward = p.c2 * np.sin(t2) + k * np.sin(t2 + t3 + psi3) + p.a1
    up = p.c2 * np.cos(t2) + k * np.cos(t2 + t3 + psi3)
    return forward, up


def abb_confdata(robot: RobotModel, q_deg) -> np.ndarray:
    """ABB confdata [cf1, cf4, cf6, cfx] (N, 4) of joint vectors (N, 6) in degrees.

    cf1, cf4, cf6: quadrant number floor(q / 90). cfx (serial robots): 4 x (wrist centre
    behind axis 1) + 2 x (wrist centre behind the lower arm) + (axis 5 negative).
    """
    q = _as_joints(q_deg)
    phi = _opw_angles(robot, q)
    forward, up = wrist_centre_in_arm_plane(robot, phi)
    # Component of (wrist centre - joint 2) normal to the lower arm, pointing forward.
    normal = (forward - robot.opw.a1) * np.cos(phi[:, 1]) - up * np.sin(phi[:, 1])
    cfx = 4 * (forward < 0) + 2 * (normal < 0) + (q[:, 4] < 0)
    quadrants = np.floor(q[:, [0, 3, 5]] / 90.0)
    return np.column_stack([quadrants, cfx]).astype(int)


def kuka_status_turn(robot: RobotModel, q_deg) -> tuple[np.ndarray, np.ndarray]:
    """KUKA Status and Turn bits (N,) of joint vectors (N, 6) in degrees.

    Status bit 0: wrist centre behind axis 1 (overhead area); bit 1: A3 at or beyond the
    angle where the arm is stretched; bit 2: A5 in (-180, 0] or beyond 180 (wrist
    flipped). Turn bit j-1: Aj < 0.
    """
    q = _as_joints(q_deg)
    p = _require_opw(robot)
    phi = _opw_angles(robot, q)
    forward, _ = wrist_centre_in_arm_plane(robot, phi)
    stretched = p.signs[2] * (np.rad2deg(-math.atan2(p.a2, p.c3)) + p.offsets_deg[2])
    a5 = q[:, 4]
    bit2 = ~(((a5 >= 0) & (a5 < 180)) | ((a5 >= -360) & (a5 < -180)))
    # "A3 >= stretched angle", measured the short way round: A3 ranges can exceed 180 degrees.
    elbow = (q[:, 2] - stretched + 180.0) % 360.0 - 180.0 >= 0
    status = (forward < 0).astype(int) + 2 * elbow + 4 * bit2
    turn = ((q < 0) * (1 << np.arange(6))).sum(axis=1)
    return status, turn


def _select_matching(robot: RobotModel, solutions, matches) -> tuple[np.ndarray, np.ndarray]:
    sols = np.asarray(solutions, dtype=float)
    n = sols.shape[0]
    best = np.full((n, 6), np.nan)
    idx = np.full(n, -1)
    for b in range(sols.shape[1]):
        for cand in _turn_variants(robot, sols[:, b]):
            usable = within_limits(robot, cand)  # False on unreachable (NaN) rows
            ok = np.isnan(best[:, 0]) & usable & matches(np.where(usable[:, None], cand, 0.0))
            best[ok] = cand[ok]
            idx[ok] = b
    return best, idx


def _turn_variants(robot: RobotModel, q: np.ndarray):
    """q and the equivalents one or two turns away on each joint whose range allows it."""
    yield q
    wide = np.nonzero(robot.upper_deg - robot.lower_deg > 360.0)[0]
    for joint in wide:
        for turns in (1, -1, 2, -2):
            alt = q.copy()
            alt[:, joint] += 360.0 * turns
            yield alt
    if len(wide) >= 2:
        for t_a in (1, -1):
            for t_b in (1, -1):
                alt = q.copy()
                alt[:, wide[0]] += 360.0 * t_a
                alt[:, wide[1]] += 360.0 * t_b
                yield alt


def select_by_abb_conf(robot: RobotModel, solutions, confdata) -> tuple[np.ndarray, np.ndarray]:
    """Pick the solution whose ABB confdata [cf1, cf4, cf6, cfx] equals the given (N, 4) or (4,)."""
    want = np.broadcast_to(np.asarray(confdata, dtype=int), (np.asarray(solutions).shape[0], 4))
    return _select_matching(robot, solutions, lambda q: np.all(abb_confdata(robot, q) == want, axis=1))


def select_by_kuka_status(robot: RobotModel, solutions, status, turn) -> tuple[np.ndarray, np.ndarray]:
    """Pick the solution whose KUKA Status and Turn equal the given values ((N,) or scalars)."""
    n = np.asarray(solutions).shape[0]
    want_s = np.broadcast_to(np.asarray(status, dtype=int), (n,))
    want_t = np.broadcast_to(np.asarray(turn, dtype=int), (n,))

    def matches(q):
        s, t = kuka_status_turn(robot, q)
        return (s == want_s) & (t == want_t)

    return _select_matching(robot, solutions, matches)


# ------------------------------------------------------------------------ gravity

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s^2, base frame (conventions.md)


def gravity_torque(robot: RobotModel, q_deg, payload_kg: float = 0.0, payload_com_mm=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Torque gravity exerts on each joint (N, 6), N*m, in the sense of the controller's q_i.

    tau_i = sum_{l >= i} z_{i-1} . ((c_l - o_{i-1}) x m_l g)  (conventions.md), with an
    optional payload: a point mass at ``payload_com_mm`` in the flange frame. A joint of
    stiffness k_i deflects by tau_i / k_i in the direction gravity pushes it.
    """
    rots, origins = joint_frames(robot, q_deg)
    masses = np.asarray(robot.mass_kg, dtype=float)
    com_local = np.asarray(robot.com_mm, dtype=float)
    # Centres of mass in the base frame, metres: c_l = o_l + R_l com_l.
    com = (origins[:, 1:] + np.einsum("nlij,lj->nli", rots[:, 1:], com_local)) / 1000.0
    if payload_kg:
        pay = (origins[:, 6] + rots[:, 6] @ np.asarray(payload_com_mm, dtype=float)) / 1000.0
        com = np.concatenate([com, pay[:, None]], axis=1)
        masses = np.append(masses, payload_kg)
        owner = np.array([0, 1, 2, 3, 4, 5, 5])
    else:
        owner = np.arange(6)
    forces = masses[:, None] * GRAVITY  # (L, 3)
    moments = np.cross(com, forces)  # (N, L, 3) about the base origin
    # Suffix sums over the links beyond joint i: sum_l (c_l x F_l) and sum_l F_l.
    torque = np.zeros((com.shape[0], 6))
    for i in range(6):
        beyond = owner >= i
        moment_sum = moments[:, beyond].sum(axis=1)
        force_sum = forces[beyond].sum(axis=0)
        origin = origins[:, i] / 1000.0
        axis = rots[:, i, :, 2]
        about_joint = moment_sum - np.cross(origin, force_sum)
        torque[:, i] = np.einsum("nj,nj->n", axis, about_joint)
    return torque * robot.joint_sign
