"""The posture a controller takes at each target: IK branch and joint values, in program order.

A Cartesian target has up to eight joint solutions; which one the robot takes is the
controller's rule, not ours. The rules, as the controllers' manuals state them:

- A joint target (ABB ``MoveAbsJ``, KUKA ``PTP`` to an ``AXIS``/``E6AXIS``) sets the posture
  exactly: its joint values.
- A Cartesian target whose configuration data apply selects that branch: KUKA ``PTP`` with
  ``S`` (Status) and ``T`` (Turn) (KUKA System Software 8.x operating and programming
  manual, "Status and Turn": S and T are evaluated for PTP motions only); ABB ``MoveJ``, and
  ``MoveL``/``MoveC`` while ``ConfL\\On`` (the default) (RAPID reference, "confdata",
  "ConfL", "ConfJ").
- Every other Cartesian target keeps the branch the robot is in and takes the joints nearest
  to the previous ones: KUKA ``LIN``/``CIRC``/``SLIN``/``SCIRC`` ignore S and T; ABB under
  ``ConfL\\Off``/``ConfJ\\Off``; G-code driven robots have no configuration data at all.

The dialect tells which targets carry applicable configuration data and selects their
branch (``anchor_q``/``anchor_branch``); this module carries the posture along the path,
vectorised: every target takes the branch of the last target that set one, and its joints
are unwrapped from that target's joints so that no joint jumps by a turn.

Before the first target that sets a posture the start posture is the robot's (unknown to a
post-processor): ``start_q`` (``--start-joints``) gives it; without it the posture nearest to
all-zero joints is assumed and named in a note, never silently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kinematics as kin
from . import ur_kinematics

MAX_STEP_DEG = 30.0  # a joint moving more than this between consecutive targets is a flip, not a path


@dataclass(frozen=True)
class Postures:
    q: np.ndarray  # (N, 6) degrees, NaN where the carried branch has no solution
    branch: np.ndarray  # (N,) IK branch index 0..7, -1 where none
    ok: np.ndarray  # (N,) False: no solution on the branch, outside the limits, or a flip
    set_by: np.ndarray  # (N,) index of the target whose posture this one carries, -1 for the start posture
    notes: tuple[str, ...] = ()


def branch_of(robot, q_deg: np.ndarray) -> np.ndarray:
    """The IK branch index (0..7) of joint vectors q (N, 6): the solution of IK(FK(q)) equal to q."""
    q = np.atleast_2d(np.asarray(q_deg, dtype=float))
    _, idx = kin.select_nearest(robot, kin.ik(robot, kin.fk(robot, q)), q)
    return idx


class Solutions:
    """The IK of N flange poses, computed only as far as the posture rules read it: all eight
    branches of the few targets that need them (configuration data, the start posture), one
    branch of every other (``kin.ik_branch``, bit for bit the same numbers at an eighth of the
    work: a long program's targets all carry a branch). ``rows``: the targets that have a
    pose (Cartesian ones, in program order among N); the others have no solution (NaN)."""

    def __init__(self, robot, flange: np.ndarray, rows: np.ndarray, n: int):
        self.robot, self.flange, self.n = robot, flange, n
        self._at = np.full(n, -1)
        self._at[rows] = np.arange(len(rows))

    def __len__(self) -> int:
        return self.n

    def all(self, idx: np.ndarray) -> np.ndarray:
        """(len(idx), 8, 6) every branch of the targets idx."""
        out = np.full((len(idx), 8, 6), np.nan)
        at = self._at[idx]
        has = at >= 0
        if has.any():
            out[has] = kin.ik(self.robot, self.flange[at[has]])
        return out

    def on(self, idx: np.ndarray, branch: np.ndarray) -> np.ndarray:
        """(len(idx), 6) the solution of target idx[k] on branch[k]."""
        out = np.full((len(idx), 6), np.nan)
        at = self._at[idx]
        has = at >= 0
        if has.any():
            out[has] = kin.ik_branch(self.robot, self.flange[at[has]], branch[has])
        return out


class _Computed:
    """``Solutions`` of an IK already computed (N, 8, 6)."""

    def __init__(self, solutions: np.ndarray):
        self.sols = np.asarray(solutions, dtype=float)

    def __len__(self) -> int:
        return self.sols.shape[0]

    def all(self, idx: np.ndarray) -> np.ndarray:
        return self.sols[idx]

    def on(self, idx: np.ndarray, branch: np.ndarray) -> np.ndarray:
        return self.sols[idx, branch]


def carry(robot, solutions, anchor: np.ndarray, anchor_q: np.ndarray, start_q=None, lines=None) -> Postures:
    """Postures along a path of N targets (program order).

    solutions: ``Solutions``, or the IK (N, 8, 6) of every target's flange pose (NaN rows for
    joint targets are fine); anchor (N,) bool: the target sets the posture (a joint target,
    or configuration data that apply); anchor_q (N, 6): its joints where anchor is True
    (NaN: the data match no solution).
    """
    sols = solutions if hasattr(solutions, "on") else _Computed(solutions)
    n = len(sols)
    valid_anchor = anchor & ~np.isnan(anchor_q).any(axis=1)
    start, notes = _start_posture(robot, sols, valid_anchor, start_q, lines)
    # Row 0 is the robot's start posture, an anchor like any other; rows 1..N the targets.
    is_anchor = np.concatenate([[True], valid_anchor])
    anchor_rows = np.vstack([start[None], np.where(valid_anchor[:, None], anchor_q, np.nan)])
    last = np.maximum.accumulate(np.where(is_anchor, np.arange(n + 1), 0))
    anchor_branch = np.full(n + 1, -1)
    finite_anchor = is_anchor & ~np.isnan(anchor_rows).any(axis=1)
    if finite_anchor.any():
        anchor_branch[finite_anchor] = branch_of(robot, anchor_rows[finite_anchor])
    carried = anchor_branch[last][1:]
    raw = np.full((n, 6), np.nan)
    has = (carried >= 0) & ~valid_anchor
    raw[has] = sols.on(np.nonzero(has)[0], carried[has])
    raw[valid_anchor] = anchor_q[valid_anchor]
    q, jump = _unwrap_from_anchors(np.vstack([start[None], raw]), is_anchor, last)
    q, jump = q[1:], jump[1:]
    finite = ~np.isnan(q).any(axis=1)
    ok = finite & kin.within_limits(robot, np.nan_to_num(q)) & ~jump
    set_by = last[1:] - 1  # -1: the start posture
    return Postures(q=q, branch=np.where(finite, carried, -1), ok=ok, set_by=set_by, notes=tuple(notes))


def _start_posture(robot, sols, valid_anchor, start_q, lines):
    """Joints the robot starts in, for the targets before the first one that sets a posture.
    Without ``start_q`` that is assumed (the solution of the first target nearest all-zero
    joints) and said in a note."""
    if start_q is not None:
        return np.asarray(start_q, dtype=float), []
    unset = ~np.maximum.accumulate(valid_anchor)
    if not unset.any():
        return np.full(6, np.nan), []
    zero = np.clip(np.zeros(6), robot.lower_deg, robot.upper_deg)
    q0, idx = kin.select_nearest(robot, _first_solved(sols, np.nonzero(unset)[0]), zero)
    where = ""
    if lines is not None:
        sel = np.asarray(lines)[unset]
        where = f" (lines {int(sel.min())}-{int(sel.max())})"
    note = (f"the program sets no posture before its first joint target or configuration data{where}: the posture nearest to "
            "all-zero joints is assumed there (give --start-joints to state the robot's real start posture)")
    return (q0[0] if idx[0] >= 0 else np.full(6, np.nan)), [note]


def _first_solved(sols, candidates: np.ndarray, block: int = 64) -> np.ndarray:
    """The solutions (1, 8, 6) of the first of ``candidates`` with any IK solution (of the
    first candidate if none has); the IK is computed a block of targets at a time."""
    for s in range(0, len(candidates), block):
        some = sols.all(candidates[s : s + block])
        solved = np.nonzero(~np.isnan(some).all(axis=(1, 2)))[0]
        if len(solved):
            return some[solved[:1]]
    return sols.all(candidates[:1])


def _unwrap_from_anchors(raw, anchors, last):
    """Joints along the path unwrapped from each segment's anchor: q[i] = q[anchor] + the
    wrapped steps since it, so no joint jumps by a turn. Also flags steps above MAX_STEP_DEG
    (into a non-anchor target: a joint target may be anywhere, the controller moves there)."""
    n = len(raw)
    finite = ~np.isnan(raw).any(axis=1)
    carry_idx = np.maximum.accumulate(np.where(finite, np.arange(n), 0))
    filled = np.nan_to_num(raw[carry_idx])
    steps = np.zeros_like(filled)
    steps[1:] = (np.diff(filled, axis=0) + 180.0) % 360.0 - 180.0
    cum = np.cumsum(steps, axis=0)
    q = raw[last] + (cum - cum[last])
    q[anchors] = raw[anchors]
    q[~finite] = np.nan
    jump = np.zeros(n, dtype=bool)
    jump[1:] = np.abs(steps[1:]).max(axis=1) > MAX_STEP_DEG
    jump &= ~anchors
    return q, jump


SINGULAR_DEG = 2.0  # within this many degrees of a wrist or elbow singularity
SHOULDER_MM = 20.0  # wrist centre closer than this to axis 1


def near_singular(robot, q_deg: np.ndarray) -> np.ndarray:
    """True where joints q (N, 6) are within SINGULAR_DEG of the wrist or elbow singularity,
    or the wrist centre within SHOULDER_MM of axis 1 (the shoulder singularity)."""
    return near_singular_margins(*singularity_margins(robot, q_deg))


def near_singular_margins(wrist, elbow, shoulder) -> np.ndarray:
    """``near_singular`` of the margins ``singularity_margins`` gave (False where they are NaN)."""
    return (wrist < SINGULAR_DEG) | (elbow < SINGULAR_DEG) | (shoulder < SHOULDER_MM)


SCREEN_MARGIN_DEG = 10.0  # both ends this far from the wrist and elbow singularities ...
SCREEN_MARGIN_MM = 200.0  # ... and the shoulder one ...
SCREEN_STEP_DEG = 5.0  # ... and no joint moving more than this: the segment needs no sampling


def clearly_regular(robot, q_start: np.ndarray, q_end: np.ndarray, margins_start=None, margins_end=None) -> np.ndarray:
    """(M,) True for straight segments that cannot come near a singularity: both ends
    SCREEN_MARGIN_DEG / _MM away from every singularity and no joint moving more than
    SCREEN_STEP_DEG between them. Along such a short move the joints stay within a few
    tenths of a degree of their straight interpolation, far from the 2 deg zone, so
    sampling it would find nothing (a long program's many small steps skip the IK).
    ``margins_start`` / ``margins_end``: their ``singularity_margins`` where the caller has them."""
    steps = np.abs((q_end - q_start + 180.0) % 360.0 - 180.0).max(axis=1)
    margins = [singularity_margins(robot, q) if given is None else given for q, given in ((q_start, margins_start), (q_end, margins_end))]
    far = np.all([(w >= SCREEN_MARGIN_DEG) & (e >= SCREEN_MARGIN_DEG) & (s >= SCREEN_MARGIN_MM) for w, e, s in margins], axis=0)
    return far & (steps <= SCREEN_STEP_DEG)


def singularity_margins(robot, q_deg: np.ndarray):
    """Distances (deg, deg, mm) of joints q (..., 6) from the wrist (axis 5 straight), elbow
    (arm stretched) and shoulder (wrist centre on axis 1) singularities of an OPW arm (of a UR arm: ``ur_kinematics.singularity_margins``)."""
    if robot.opw is None and ur_kinematics.is_ur_geometry(robot):
        return ur_kinematics.singularity_margins(robot, q_deg)
    p = robot.opw
    phi = np.deg2rad(p.signs * q_deg - p.offsets_deg)
    wrist = np.degrees(np.arcsin(np.minimum(np.abs(np.sin(phi[..., 4])), 1.0)))
    elbow = np.degrees(np.arcsin(np.minimum(np.abs(np.sin(phi[..., 2] + np.arctan2(p.a2, p.c3))), 1.0)))
    radial, _ = kin.wrist_centre_in_arm_plane(robot, phi)
    return wrist, elbow, np.abs(radial)


def interpolate_poses(start: np.ndarray, end: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """Poses along straight segments (M, 4, 4) -> (M, K, 4, 4): position linear, orientation
    by the shortest rotation (slerp), as controllers interpolate LIN / MoveL."""
    # Deferred: scipy.spatial is slow to import and the command line imports posture at start-up.
    from scipy.spatial.transform import Rotation

    m, k = len(start), len(fractions)
    rel = Rotation.from_matrix(np.einsum("nji,njk->nik", start[:, :3, :3], end[:, :3, :3])).as_rotvec()
    turn = Rotation.from_rotvec((rel[:, None, :] * fractions[None, :, None]).reshape(-1, 3)).as_matrix().reshape(m, k, 3, 3)
    out = np.zeros((m, k, 4, 4))
    out[..., :3, :3] = np.einsum("nij,nkjl->nkil", start[:, :3, :3], turn)
    out[..., :3, 3] = start[:, None, :3, 3] + fractions[None, :, None] * (end[:, None, :3, 3] - start[:, None, :3, 3])
    out[..., 3, 3] = 1.0
    return out


def check_linear_segments(robot, start_flange, end_flange, branch, q_start, samples: int = 16) -> np.ndarray:
    """Why each straight segment (flange poses start -> end, M of them) cannot be driven on
    its branch by the nominal controller: 0 fine, 1 leaves reach or the limits, 2 passes
    near a singularity, 3 flips (a joint jumps > MAX_STEP_DEG between samples).

    q_start (M, 6): the joints at each segment's start; branch (M,): the branch carried."""
    fractions = np.linspace(0.0, 1.0, samples + 2)[1:]
    poses = interpolate_poses(np.asarray(start_flange), np.asarray(end_flange), fractions)
    m = len(poses)
    sols = kin.ik(robot, poses.reshape(-1, 4, 4)).reshape(m, len(fractions), 8, 6)
    q = sols[np.arange(m)[:, None], np.arange(len(fractions))[None, :], np.maximum(branch, 0)[:, None]]
    path = np.concatenate([np.asarray(q_start, dtype=float)[:, None, :], q], axis=1)
    steps = (np.diff(path, axis=1) + 180.0) % 360.0 - 180.0
    unwrapped = path[:, :1] + np.concatenate([np.zeros((m, 1, 6)), np.cumsum(steps, axis=1)], axis=1)
    missing = np.isnan(q).any(axis=(1, 2)) | (branch < 0)
    flat = np.nan_to_num(unwrapped[:, 1:].reshape(-1, 6))
    outside = ~kin.within_limits(robot, flat).reshape(m, -1).all(axis=1)
    singular = near_singular(robot, flat).reshape(m, -1).any(axis=1)
    flip = np.nan_to_num(np.abs(steps)).max(axis=(1, 2)) > MAX_STEP_DEG
    reason = np.zeros(m, dtype=int)
    reason[flip] = 3
    reason[singular] = 2
    reason[missing | outside] = 1
    return reason
