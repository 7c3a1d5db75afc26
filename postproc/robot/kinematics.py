"""Vectorised kinematics: forward kinematics, geometric Jacobian, analytic OPW inverse kinematics.

Every function takes arrays over poses (leading axis N) and has no per-pose Python loop.
Joint values are in degrees at the API (conventions.md); radians only inside the kernels.
The kernels work on a struct of arrays (rotation columns and positions as (3, C) blocks)
over chunks of C poses, which keeps the working set in cache; chunks run on a thread
pool because NumPy releases the GIL inside its ufunc loops.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from postproc.errors import KinematicsError

from . import ur_kinematics
from .dh import CHUNK, _dh_kernel, forward_dh, frames_dh  # noqa: F401  (re-exported: the DH chain lives in dh)
from .dh import as_joints as _as_joints
from .dh import dh_rows as _dh_rows
from .dh import opw_angles as _phi_of
from .dh import opw_forward as _opw_forward
from .dh import opw_wrist_centre as _wrist_centre
from .dh import run_chunked as _run_chunked
from .dh import tool_transform as _tool_transform
from .robots import RobotModel

# |sin(theta5)| below this is treated as the wrist singularity: theta4 and theta6 are then
# only defined through their sum (or difference), and theta4 is set to 0.
WRIST_SINGULAR_EPS = 1e-12
# Triangle inequalities violated by less than this (relative) are rounding at the reach
# boundary, not unreachable poses.
_ACOS_SLACK = 1e-10


def _as_poses(t) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.shape == (4, 4):
        t = t[None]
    if t.ndim != 3 or t.shape[1:] != (4, 4):
        raise KinematicsError(f"poses must have shape (N, 4, 4), got {t.shape}")
    return t


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
    the controller's joint value in radians (the joint sign is included). The frames come
    from the compiled DH chain, a chunk of poses at a time (bounded memory).
    """
    q = _as_joints(q_deg)
    n = q.shape[0]
    out = np.zeros((n, 6, 6))
    tool_t = _tool_transform(tool)
    offset = np.zeros(3) if tool_t is None else tool_t[:3, 3]
    for s in range(0, n, CHUNK):
        rots, origins = joint_frames(robot, q[s : s + CHUNK])
        end = origins[:, 6] + rots[:, 6] @ offset
        z = rots[:, :6, :, 2]  # joint axes z_0..z_5
        out[s : s + CHUNK, :3] = (np.cross(z, end[:, None] - origins[:, :6]) * robot.joint_sign[None, :, None]).transpose(0, 2, 1)
        out[s : s + CHUNK, 3:] = (z * robot.joint_sign[None, :, None]).transpose(0, 2, 1)
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
    return _opw_forward(_require_opw(robot), q_deg)


@njit(cache=True, inline="always")
def _triangle_angle(a, b, c, slack_factor):
    """Angle (radians) opposite side ``a`` of a triangle, from its three side lengths.

    Kahan's formula ("Miscalculating area and angles of a needle-like triangle"): accurate
    to a few ulps even for nearly degenerate triangles, where the law of cosines with acos
    loses half the digits (an arm near full stretch). NaN where no triangle exists; a
    rounding-sized negative (within slack_factor of the perimeter) counts as zero.
    """
    big, small = max(b, c), min(b, c)
    mu = a - (big - small) if small >= a else small - (big - a)
    scale = big + small + a
    slack = slack_factor * scale
    if mu < 0 and mu > -slack:
        mu = 0.0
    num = ((big - small) + a) * mu
    den = (big + (small + a)) * ((big - a) + small)
    if den < 0 and den > -slack * scale:
        den = 0.0
    if mu < 0 or den < 0 or num < 0:
        return np.nan
    if den == 0 and num >= 0:
        return np.pi
    return 2.0 * math.atan(np.sqrt(num / den))


@njit(cache=True, nogil=True)
def _ik_kernel(t, a1, a2, b, c1, c2, c3, c4, signs, offsets_deg, slack_factor, wrist_eps, only, out):
    """OPW inverse kinematics, compiled: flange poses t (N, 4, 4) -> out (N, 8, 6) controller degrees.
    With ``only`` (N,) branch indices (and out (N, 1, 6)) just that branch of each pose is
    computed, by the same arithmetic (``ik_branch``).

    Per pose: the wrist centre, the four arm configurations (shoulder front/back x elbow)
    from the triangle of joint 2, joint 3 and the wrist centre, then the wrist rotation
    R_ce = (Rz(t1) Ry(t2 + t3))^T R decomposed as Rz(t4) Ry(t5) Rz(t6), and its flip.
    At the wrist singularity only t4 + t6 is defined: t4 = 0 there, and t6 is taken from
    the rotation left after t4 and t5 so that the composed rotation stays exact."""
    k = math.hypot(a2, c3)
    psi3 = math.atan2(a2, c3)
    phi = np.empty(6)
    single = out.shape[1] == 1
    for p in range(t.shape[0]):
        want = only[p] if single else -1
        cx = t[p, 0, 3] - c4 * t[p, 0, 2]
        cy = t[p, 1, 3] - c4 * t[p, 1, 2]
        cz = t[p, 2, 3] - c4 * t[p, 2, 2]
        nx1 = np.sqrt(cx * cx + cy * cy - b * b) - a1
        dz = cz - c1
        s1 = math.hypot(nx1, dz)
        s2 = math.hypot(nx1 + 2 * a1, dz)
        base_angle = math.atan2(cy, cx)
        shoulder = math.atan2(b, nx1 + a1)
        t1_front = base_angle - shoulder
        t1_back = base_angle + shoulder - np.pi
        shoulder_a = _triangle_angle(k, s1, c2, slack_factor)
        shoulder_b = _triangle_angle(k, s2, c2, slack_factor)
        elbow_a = np.pi - _triangle_angle(s1, c2, k, slack_factor)
        elbow_b = np.pi - _triangle_angle(s2, c2, k, slack_factor)
        lean_a = math.atan2(nx1, dz)
        lean_b = math.atan2(nx1 + 2 * a1, dz)
        for j in range(4):
            if single and j != want % 4:
                continue
            if j == 0:
                t1, t2, t3 = t1_front, -shoulder_a + lean_a, elbow_a - psi3
            elif j == 1:
                t1, t2, t3 = t1_front, shoulder_a + lean_a, -elbow_a - psi3
            elif j == 2:
                t1, t2, t3 = t1_back, -shoulder_b - lean_b, elbow_b - psi3
            else:
                t1, t2, t3 = t1_back, shoulder_b - lean_b, -elbow_b - psi3
            s1_, c1_ = math.sin(t1), math.cos(t1)
            s23, c23 = math.sin(t2 + t3), math.cos(t2 + t3)
            # Rows of R_ce (the components the decomposition needs).
            rx00 = c1_ * t[p, 0, 0] + s1_ * t[p, 1, 0]
            rx02 = c1_ * t[p, 0, 2] + s1_ * t[p, 1, 2]
            w10 = -s1_ * t[p, 0, 0] + c1_ * t[p, 1, 0]
            w12 = -s1_ * t[p, 0, 2] + c1_ * t[p, 1, 2]
            w00 = c23 * rx00 - s23 * t[p, 2, 0]
            w02 = c23 * rx02 - s23 * t[p, 2, 2]
            w20 = s23 * rx00 + c23 * t[p, 2, 0]
            w22 = s23 * rx02 + c23 * t[p, 2, 2]
            sin5 = math.hypot(w02, w12)
            t5 = math.atan2(sin5, w22)
            t4 = 0.0 if sin5 < wrist_eps else math.atan2(w12, w02)
            c4_, s4_, c5, s5 = math.cos(t4), math.sin(t4), math.cos(t5), math.sin(t5)
            m00 = c5 * (c4_ * w00 + s4_ * w10) - s5 * w20
            m10 = -s4_ * w00 + c4_ * w10
            t6 = math.atan2(m10, m00)
            for flip in range(2):
                if single and flip != want // 4:
                    continue
                if flip == 0:
                    phi[0], phi[1], phi[2], phi[3], phi[4], phi[5] = t1, t2, t3, t4, t5, t6
                else:
                    phi[0], phi[1], phi[2], phi[3], phi[4], phi[5] = t1, t2, t3, t4 + np.pi, -t5, t6 - np.pi
                row = 0 if single else j + 4 * flip
                bad = False
                for i in range(6):
                    q = signs[i] * (phi[i] * (180.0 / np.pi) + offsets_deg[i])
                    q = (q + 180.0) % 360.0 - 180.0
                    if np.isnan(q):
                        bad = True
                    out[p, row, i] = q
                if bad:
                    for i in range(6):
                        out[p, row, i] = np.nan


def ik(robot: RobotModel, poses) -> np.ndarray:
    """All analytic inverse solutions (N, 8, 6), controller degrees in [-180, 180].

    ``poses`` are flange poses base_T_flange (N, 4, 4) in mm. A branch with no solution
    (target out of reach for that arm configuration) is a row of NaN. Branch order:
    0-3 the four arm configurations (shoulder front/back x elbow), 4-7 the same with the
    wrist flipped. A Universal Robots arm (no OPW parameters, UR geometry) is solved by
    ``ur_kinematics.ik`` in the same branch order.
    """
    if robot.opw is None and ur_kinematics.is_ur_geometry(robot):
        return ur_kinematics.ik(robot, _as_poses(poses))
    p = _require_opw(robot)
    t = np.ascontiguousarray(_as_poses(poses), dtype=float)
    n = t.shape[0]
    out = np.empty((n, 8, 6))
    signs = np.asarray(p.signs, dtype=float) * np.ones(6)
    offsets = np.asarray(p.offsets_deg, dtype=float) * np.ones(6)

    def work(s, e):
        _ik_kernel(t[s:e], p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4, signs, offsets, _ACOS_SLACK, WRIST_SINGULAR_EPS, _NO_BRANCH, out[s:e])

    _run_chunked(n, work)
    return out


_NO_BRANCH = np.zeros(0, dtype=np.int64)


def ik_branch(robot: RobotModel, poses, branch) -> np.ndarray:
    """The solution (N, 6) on one branch per pose (``branch`` (N,) in 0..7): bit for bit
    ``ik(robot, poses)[arange(N), branch]``, at about an eighth of its work."""
    if robot.opw is None and ur_kinematics.is_ur_geometry(robot):
        return ur_kinematics.ik(robot, _as_poses(poses))[np.arange(len(branch)), np.asarray(branch)]
    p = _require_opw(robot)
    t = np.ascontiguousarray(_as_poses(poses), dtype=float)
    want = np.ascontiguousarray(branch, dtype=np.int64)
    n = t.shape[0]
    out = np.empty((n, 1, 6))
    signs = np.asarray(p.signs, dtype=float) * np.ones(6)
    offsets = np.asarray(p.offsets_deg, dtype=float) * np.ones(6)

    def work(s, e):
        _ik_kernel(t[s:e], p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4, signs, offsets, _ACOS_SLACK, WRIST_SINGULAR_EPS, want[s:e], out[s:e])

    _run_chunked(n, work)
    return out[:, 0]


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


def branch_joints(robot: RobotModel, poses, branch, q_ref) -> tuple[np.ndarray, np.ndarray]:
    """``select_branch(robot, ik(robot, poses), branch, q_ref)``, with the full IK only for
    the poses whose branch has no valid solution (most poses need just their own branch)."""
    poses = _as_poses(poses)
    branch = np.asarray(branch)
    q_ref = np.asarray(q_ref, dtype=float)
    q = _shift_turns_towards(robot, ik_branch(robot, poses, np.maximum(branch, 0)), q_ref)
    ok = (branch >= 0) & within_limits(robot, q)
    out_branch = np.where(ok, branch, -1)
    if not ok.all():
        bad = np.nonzero(~ok)[0]
        q_alt, b_alt = select_nearest(robot, ik(robot, poses[bad]), q_ref[bad] if q_ref.ndim == 2 else q_ref)
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
    return _phi_of(p, q)


def opw_angles(robot: RobotModel, q_deg) -> np.ndarray:
    """OPW joint angles phi (N, 6) in radians of controller joint values (degrees)."""
    return _phi_of(_require_opw(robot), _as_joints(q_deg))


def wrist_centre_in_arm_plane(robot: RobotModel, phi: np.ndarray):
    """Wrist centre in the plane of the arm, from OPW angles phi (radians): (forward of
    axis 1, height above joint 2), mm."""
    return _wrist_centre(robot.opw, phi)


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


def _wide_joints(robot: RobotModel) -> np.ndarray:
    """Joints whose range spans more than a turn (the only ones whose turn the program picks)."""
    return np.nonzero(robot.upper_deg - robot.lower_deg > 360.0)[0]


def select_by_abb_conf(robot: RobotModel, solutions, confdata) -> tuple[np.ndarray, np.ndarray]:
    """Pick, per pose, the first branch whose solution has the given ABB confdata [cf1, cf4,
    cf6, cfx] ((N, 4) or (4,)). Each wide joint's turn (a range over a turn) is computed
    from the quadrant asked for rather than searched: 8 passes of ``abb_confdata``."""
    want = np.broadcast_to(np.asarray(confdata, dtype=int), (np.asarray(solutions).shape[0], 4))
    quadrant_col = {0: 0, 3: 1, 5: 2}
    return _first_matching(robot, solutions, lambda q, rows: np.all(abb_confdata(robot, q) == want[rows], axis=1),
                           lambda q, j, rows: _turn_to_quadrant(q, want[rows, quadrant_col[j]]) if j in quadrant_col else q)


def select_by_kuka_status(robot: RobotModel, solutions, status, turn) -> tuple[np.ndarray, np.ndarray]:
    """Pick, per pose, the first branch whose solution has the given KUKA Status and Turn
    ((N,) or scalars): each wide joint is turned to the sign its Turn bit asks for."""
    n = np.asarray(solutions).shape[0]
    want_s = np.broadcast_to(np.asarray(status, dtype=int), (n,))
    want_t = np.broadcast_to(np.asarray(turn, dtype=int), (n,))

    def matches(q, rows):
        st, tu = kuka_status_turn(robot, q)
        return (st == want_s[rows]) & (tu == want_t[rows])

    def turned(q, j, rows):
        negative = (want_t[rows] >> j) & 1 == 1
        return np.where(negative & (q >= 0), q - 360.0, np.where(~negative & (q < 0), q + 360.0, q))

    return _first_matching(robot, solutions, matches, turned)


def _turn_to_quadrant(q: np.ndarray, quadrant: np.ndarray) -> np.ndarray:
    """q plus the whole turns that put it in the wanted quadrant floor(q / 90), when some do."""
    turns = (quadrant - np.floor(q / 90.0)) / 4.0
    return np.where(turns == np.round(turns), q + 360.0 * turns, q)


def _first_matching(robot: RobotModel, solutions: np.ndarray, matches, turned):
    sols = np.asarray(solutions, dtype=float)
    n = sols.shape[0]
    best = np.full((n, 6), np.nan)
    idx = np.full(n, -1)
    wide = _wide_joints(robot)
    for b in range(sols.shape[1]):
        open_rows = np.nonzero(idx < 0)[0]
        if not len(open_rows):
            break
        cand = sols[open_rows, b].copy()
        for j in wide:
            cand[:, j] = turned(cand[:, j], j, open_rows)
        usable = within_limits(robot, cand)
        ok = usable & matches(np.where(usable[:, None], cand, 0.0), open_rows)
        best[open_rows[ok]] = cand[ok]
        idx[open_rows[ok]] = b
    return best, idx


# ------------------------------------------------------------------------ gravity

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s^2, base frame (conventions.md)


@njit(cache=True, nogil=True)
def _gravity_kernel(theta, d, a, alpha, masses, com_local, frame_of, owner, g, out):
    """tau_i = z_i . sum_{l loads i} (c_l - o_i) x m_l g per pose (positions in metres),
    with the DH frames of each pose computed on the spot (no (N, 7, 3, 3) arrays)."""
    rots = np.zeros((1, 7, 3, 3))
    origins = np.zeros((1, 7, 3))
    flange = np.zeros((0, 4, 4))
    c = np.empty(3)
    for p in range(theta.shape[0]):
        _dh_kernel(theta[p : p + 1], d, a, alpha, rots, origins, flange)
        for i in range(6):
            out[p, i] = 0.0
        for l in range(len(masses)):
            f = frame_of[l]
            for k in range(3):
                c[k] = (origins[0, f, k] + rots[0, f, k, 0] * com_local[l, 0] + rots[0, f, k, 1] * com_local[l, 1] + rots[0, f, k, 2] * com_local[l, 2]) / 1000.0
            fx, fy, fz = masses[l] * g[0], masses[l] * g[1], masses[l] * g[2]
            for i in range(owner[l] + 1):
                rx = c[0] - origins[0, i, 0] / 1000.0
                ry = c[1] - origins[0, i, 1] / 1000.0
                rz = c[2] - origins[0, i, 2] / 1000.0
                mx = ry * fz - rz * fy
                my = rz * fx - rx * fz
                mz = rx * fy - ry * fx
                out[p, i] += rots[0, i, 0, 2] * mx + rots[0, i, 1, 2] * my + rots[0, i, 2, 2] * mz


def gravity_torque(robot: RobotModel, q_deg, payload_kg: float = 0.0, payload_com_mm=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Torque gravity exerts on each joint (N, 6), N*m, in the sense of the controller's q_i.

    tau_i = sum_{l >= i} z_{i-1} . ((c_l - o_{i-1}) x m_l g)  (conventions.md), with an
    optional payload: a point mass at ``payload_com_mm`` in the flange frame. A joint of
    stiffness k_i deflects by tau_i / k_i in the direction gravity pushes it.
    """
    theta = np.ascontiguousarray(np.deg2rad(dh_angles(robot, q_deg)))
    masses = np.asarray(robot.mass_kg, dtype=float)
    com_local = np.asarray(robot.com_mm, dtype=float).reshape(6, 3)
    frame_of = np.arange(1, 7)  # link l's centre of mass is fixed in DH frame l + 1
    owner = np.arange(6)  # ... and it loads joints 0..l
    if payload_kg:
        masses = np.append(masses, payload_kg)
        com_local = np.vstack([com_local, np.asarray(payload_com_mm, dtype=float)])
        frame_of = np.append(frame_of, 6)
        owner = np.append(owner, 5)
    d, a = _dh_rows(robot.d_mm, 1, "d"), _dh_rows(robot.a_mm, 1, "a")
    alpha = np.deg2rad(_dh_rows(robot.alpha_deg, 1, "alpha"))
    torque = np.empty((theta.shape[0], 6))
    _run_chunked(theta.shape[0], lambda s, e: _gravity_kernel(theta[s:e], d, a, alpha, masses, com_local, frame_of, owner, GRAVITY, torque[s:e]))
    return torque * robot.joint_sign
