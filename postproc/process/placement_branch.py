"""The joints a controller takes at every target of every candidate placement, and why a
candidate is infeasible (vectorised over candidates x targets).

The posture rules are those of ``posture`` (a target whose configuration data apply sets the
branch; every other target keeps the branch of the last one that did, the first ones the
start posture nearest all-zero joints; joints move continuously, no jump by a turn), applied
to M candidate placements at once. Two readings of the configuration data:

- ``rederive`` (default): the program is posted again for the moved workpiece, as a CAM
  post would. The arm configuration the program states (ABB cfx, KUKA Status: shoulder,
  elbow, wrist) is kept; the turn data (ABB cf1/cf4/cf6 quadrants, KUKA Turn) are those of
  the joints the robot then takes, continuous from the first target. A moved workpiece
  turns axis 1 (and the wrist) by the move itself, so the quadrants written for the old
  place cannot hold at the new one.
- ``keep``: the program's configuration data, turn data included, exactly as written.

Each (candidate, target) gets a reason code, 0 when fine; a candidate's reason is the first
in ``REASONS`` order that any of its targets has.
"""

from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin
from postproc.robot.posture import MAX_STEP_DEG, singularity_margins

CONF_MODES = ("rederive", "keep")

OK, REACH, CONF = 0, 1, 2
LIMIT = 3  # 3..8: joint 1..6 outside its limits
COUPLING, WRIST, ELBOW, SHOULDER, FLIP = 9, 10, 11, 12, 13
REASONS = ("feasible", "out of reach", "configuration data", *(f"joint {j} limit" for j in range(1, 7)), "coupled-joint limit",
           "wrist singularity margin", "elbow singularity margin", "shoulder singularity margin", "joint flip between targets")


def arm_codes(language, robot, q: np.ndarray) -> np.ndarray:
    """The arm-configuration code (ABB cfx, KUKA Status) of joints q (N, 6) in ``language``'s
    notation (``arm_conf_column``, ``conf_of_joints``), -1 where q has NaN."""
    lang = language
    out = np.full(len(q), -1)
    finite = ~np.isnan(q).any(axis=1)
    if finite.any() and lang.arm_conf_column is not None:
        out[finite] = lang.conf_of_joints(robot, q[finite])[:, lang.arm_conf_column].astype(int)
    return out


def _anchor_branches(problem, sols: np.ndarray, anchors: np.ndarray):
    """Joints (M, A, 6) and branch (M, A) (-1: none) at the targets whose configuration data apply."""
    m, a = sols.shape[0], len(anchors)
    flat = sols[:, anchors].reshape(-1, 8, 6)
    if problem.conf_mode == "keep":
        want = np.tile(problem.conf[anchors], (m, 1))
        q, idx = problem.language.controller.branch_from_conf(problem.robot, flat, want)
        return q.reshape(m, a, 6), idx.reshape(m, a)
    # rederive: the first branch with the program's arm configuration (turns follow the path)
    codes = arm_codes(problem.language, problem.robot, flat.reshape(-1, 6)).reshape(-1, 8)
    wanted = np.tile(problem.arm[anchors], m)
    match = codes == wanted[:, None]
    idx = np.where(match.any(axis=1), np.argmax(match, axis=1), -1)
    q = np.take_along_axis(flat, np.maximum(idx, 0)[:, None, None], axis=1)[:, 0]
    q[idx < 0] = np.nan
    return q.reshape(m, a, 6), idx.reshape(m, a)


def _start_branch(robot, sols: np.ndarray):
    """The start posture (M, 6) and its branch (M,): the first target's solution nearest
    all-zero joints inside the limits; where none is inside, the nearest one outside (so that
    the reason names the joint that leaves its limits), -1 where the target is out of reach."""
    zero = np.clip(np.zeros(6), robot.lower_deg, robot.upper_deg)
    q, idx = kin.select_nearest(robot, sols[:, 0], zero)
    none = idx < 0
    if none.any():
        first = sols[none, 0]
        dist = np.where(np.isnan(first).any(axis=2), np.inf, np.abs(np.nan_to_num(first) - zero).sum(axis=2))
        nearest = np.argmin(dist, axis=1)
        reachable = np.isfinite(dist.min(axis=1))
        q[none] = np.where(reachable[:, None], first[np.arange(len(first)), nearest], np.nan)
        idx[none] = np.where(reachable, nearest, -1)
    return q, idx


def program_postures(problem, sols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joints (M, P, 6) on the program's configuration and the reason code (M, P) of each target.

    sols (M, P, 8, 6): the IK of every target's flange pose at every candidate."""
    m, p = sols.shape[:2]
    robot = problem.robot
    anchors = np.nonzero(problem.conf_applies)[0]
    is_anchor = np.zeros(p + 1, dtype=bool)  # row 0: the start posture, rows 1..P the targets
    is_anchor[0] = True
    is_anchor[anchors + 1] = True
    last = np.maximum.accumulate(np.where(is_anchor, np.arange(p + 1), 0))  # (P+1,) the row each carries
    branch_rows = np.full((m, p + 1), -1)
    raw = np.full((m, p + 1, 6), np.nan)
    raw[:, 0], branch_rows[:, 0] = _start_branch(robot, sols)
    if len(anchors):
        qa, ba = _anchor_branches(problem, sols, anchors)
        raw[:, anchors + 1], branch_rows[:, anchors + 1] = qa, ba
    carried = np.take_along_axis(branch_rows, np.broadcast_to(last, (m, p + 1)), axis=1)[:, 1:]  # (M, P)
    on_branch = np.take_along_axis(sols, np.maximum(carried, 0)[:, :, None, None], axis=2)[:, :, 0]
    on_branch[carried < 0] = np.nan
    targets = raw[:, 1:]
    fill = ~problem.conf_applies if problem.conf_mode == "keep" else np.ones(p, dtype=bool)
    targets[:, fill] = on_branch[:, fill]  # keep mode: an anchor's joints are turned as its data say
    first = np.zeros(p + 1, dtype=bool)
    first[:2] = True  # the start posture and the first target (its turns nearest all-zero joints)
    # keep: an anchor's turns are its data's; rederive: every turn follows the path from the first target
    resets = is_anchor | first if problem.conf_mode == "keep" else first
    q, jump = _unwrap(np.concatenate([raw[:, :1], targets], axis=1), resets, is_anchor | first)
    q, jump = q[:, 1:], jump[:, 1:]
    reason = _reasons(problem, sols, q, carried, jump)
    return q, reason


def _unwrap(raw: np.ndarray, resets: np.ndarray, may_jump: np.ndarray):
    """Joints (M, R, 6) unwrapped along the path from the last reset row (no step of a turn),
    and where a step into a row not in may_jump (a target that sets the posture moves there
    as a joint move) exceeds MAX_STEP_DEG (a flip)."""
    r = raw.shape[1]
    filled = np.nan_to_num(raw)
    steps = np.zeros_like(filled)
    steps[:, 1:] = (np.diff(filled, axis=1) + 180.0) % 360.0 - 180.0
    cum = np.cumsum(steps, axis=1)
    last = np.maximum.accumulate(np.where(resets, np.arange(r), 0))
    q = raw[:, last] + (cum - cum[:, last])
    q[:, resets] = raw[:, resets]
    q[np.isnan(raw).any(axis=2)] = np.nan
    jump = (np.abs(steps).max(axis=2) > MAX_STEP_DEG) & ~may_jump[None, :]
    return q, jump


def _reasons(problem, sols, q, carried, jump) -> np.ndarray:
    """Reason code (M, P) of each target: the first that applies in REASONS order."""
    robot = problem.robot
    m, p = q.shape[:2]
    reason = np.zeros((m, p), dtype=np.int8)
    flat = np.nan_to_num(q).reshape(-1, 6)
    wrist, elbow, shoulder = (v.reshape(m, p) for v in singularity_margins(robot, flat))
    checks = [jump, shoulder <= problem.shoulder_mm, elbow <= problem.singular_deg, wrist <= problem.singular_deg]
    codes = [FLIP, SHOULDER, ELBOW, WRIST]
    coupled = np.zeros((m, p), dtype=bool)
    for coupling in robot.couplings:
        value = flat @ coupling.coeffs
        coupled |= ((value < coupling.lower - 1e-9) | (value > coupling.upper + 1e-9)).reshape(m, p)
    checks.append(coupled)
    codes.append(COUPLING)
    for j in range(5, -1, -1):
        checks.append(((q[..., j] < robot.lower_deg[j] - 1e-9) | (q[..., j] > robot.upper_deg[j] + 1e-9)))
        codes.append(LIMIT + j)
    checks += [(carried < 0) | np.isnan(q).any(axis=2), np.isnan(sols).all(axis=(2, 3))]
    codes += [CONF, REACH]
    for check, code in zip(checks, codes):  # later (more basic) reasons overwrite earlier ones
        reason[check] = code
    return reason


def cell_reasons(point_reasons: np.ndarray) -> np.ndarray:
    """(M,) the reason of each candidate: its targets' smallest non-zero code, 0 when all are fine."""
    masked = np.where(point_reasons > 0, point_reasons, np.iinfo(np.int8).max)
    first = masked.min(axis=1)
    return np.where(first == np.iinfo(np.int8).max, 0, first).astype(np.int8)


def reason_counts(reasons: np.ndarray) -> dict[str, int]:
    """{reason name: number of candidates} of the infeasible ones, most frequent first."""
    codes, counts = np.unique(np.asarray(reasons).ravel(), return_counts=True)
    pairs = sorted(((REASONS[c], int(n)) for c, n in zip(codes, counts) if c != OK), key=lambda t: -t[1])
    return dict(pairs)
