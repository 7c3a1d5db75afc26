"""Brute-force reference for workpiece placement feasibility: one candidate at a time, one
target at a time, written straight from the controller's rules (no vectorisation, no shared
selection code with ``postproc.process.placement_branch``), to check the product against.

At each candidate, for each target in program order:
- the flange pose's eight IK solutions (none: out of reach);
- the branch: at a target whose configuration data apply, the first solution with the
  program's arm configuration (re-derive), or whose whole configuration data, turns
  included, equal the program's inside the limits (keep); elsewhere the branch the robot is
  in (before any such target: the first target's solution nearest all-zero joints inside
  the limits, or outside them where none is inside);
- joints unwrapped from the previous target's (no step of a turn), except the first target
  and, in keep mode, a target whose data set its turns; a step over 30 deg into a target
  that does not set the posture is a flip;
- joint limits, the coupled-joint limits, singularity margins.
The candidate's reason is the most basic one any target has (the product's order).
"""

from __future__ import annotations

import itertools

import numpy as np

from postproc.robot import kinematics as kin
from postproc.robot.posture import singularity_margins

REACH, CONF, LIMIT, COUPLING, WRIST, ELBOW, SHOULDER, FLIP = 1, 2, 3, 9, 10, 11, 12, 13


def _turned_variants(robot, q):
    """Every equivalent of q (whole turns on the joints whose range spans more than a turn)."""
    wide = [j for j in range(6) if robot.upper_deg[j] - robot.lower_deg[j] > 360.0]
    for turns in itertools.product((-1, 0, 1), repeat=len(wide)):
        v = q.copy()
        for j, t in zip(wide, turns):
            v[j] += 360.0 * t
        yield v


def _in_limits(robot, q):
    ok = all(robot.lower_deg[j] - 1e-9 <= q[j] <= robot.upper_deg[j] + 1e-9 for j in range(6))
    return ok and all(c.lower - 1e-9 <= float(q @ c.coeffs) <= c.upper + 1e-9 for c in robot.couplings)


def _keep_choice(problem, sols, p):
    lang = problem.language
    for b in range(8):
        if np.isnan(sols[b]).any():
            continue
        for v in _turned_variants(problem.robot, sols[b]):
            conf = lang.conf_of_joints(problem.robot, v[None])[0]
            want = problem.conf[p]
            if _in_limits(problem.robot, v) and all(np.isnan(w) or c == w for c, w in zip(conf, want)):
                return b, v
    return -1, None


def _rederive_choice(problem, sols, p):
    lang = problem.language
    for b in range(8):
        if not np.isnan(sols[b]).any() and lang.conf_of_joints(problem.robot, sols[b][None])[0][lang.arm_conf_column] == problem.arm[p]:
            return b, sols[b].copy()
    return -1, None


def _start(robot, sols):
    best, best_in = None, None
    for b in range(8):
        if np.isnan(sols[b]).any():
            continue
        d = float(np.abs(sols[b]).sum())
        if best is None or d < best[0]:
            best = (d, b)
        if _in_limits(robot, sols[b]) and (best_in is None or d < best_in[0]):
            best_in = (d, b)
    chosen = best_in or best
    return -1 if chosen is None else chosen[1]


def _point_reason(problem, q, jump):
    robot = problem.robot
    if q is None or np.isnan(q).any():
        return CONF
    for j in range(6):
        if not robot.lower_deg[j] - 1e-9 <= q[j] <= robot.upper_deg[j] + 1e-9:
            return LIMIT + j
    if any(not c.lower - 1e-9 <= float(q @ c.coeffs) <= c.upper + 1e-9 for c in robot.couplings):
        return COUPLING
    wrist, elbow, shoulder = (float(v[0]) for v in singularity_margins(robot, q[None]))
    if wrist <= problem.singular_deg:
        return WRIST
    if elbow <= problem.singular_deg:
        return ELBOW
    if shoulder <= problem.shoulder_mm:
        return SHOULDER
    return FLIP if jump else 0


def reference_cell(problem, frame):
    """(reason code, joints (P, 6)) of one candidate workpiece frame."""
    flange = frame[None] @ problem.local_tcp @ np.linalg.inv(problem.flange_T_tcp)
    all_sols = kin.ik(problem.robot, flange)
    reasons, joints = [], []
    branch, prev = _start(problem.robot, all_sols[0]), None
    for p, sols in enumerate(all_sols):
        if np.isnan(sols).all():
            reasons.append(REACH)
            joints.append(np.full(6, np.nan))
            continue
        anchor = bool(problem.conf_applies[p])
        turned = None
        if anchor:
            branch, turned = (_keep_choice if problem.conf_mode == "keep" else _rederive_choice)(problem, sols, p)
        q = None if branch < 0 else sols[branch].copy()
        jump = False
        if q is not None and not np.isnan(q).any():
            if turned is not None and problem.conf_mode == "keep":
                q = turned
            elif prev is not None and p > 0:
                step = (q - prev + 180.0) % 360.0 - 180.0
                q = prev + step
                jump = (not anchor) and np.abs(step).max() > 30.0
        reasons.append(_point_reason(problem, q, jump))
        joints.append(np.full(6, np.nan) if q is None else q)
        prev = None if q is None or np.isnan(q).any() else q
    bad = [r for r in reasons if r]
    return (min(bad) if bad else 0), np.array(joints)
