"""Yaskawa's form (figure, "type") of a robot posture, as ``///RCONF`` writes it, and the
IK solution a form selects.

``///RCONF l,m,n,o,p,q,...`` (DX100 "Interface with an easy offline teaching system",
4.1 job data format, RCONF; the types are described in the NX100 / DX100 operator's
manual, "Manipulator Types", 3.9):
- l: 0 flip, 1 no flip. It is the R axis's position: flip where -90 < R <= 90 (or
  270 < R <= 360, -360 < R <= -270), no flip where 90 < R <= 270 (or -270 < R <= -90);
- m: 0 upper arm, 1 lower arm: the type the L and U axes make (elbow up or down), here
  which side of the line from the L axis to the wrist centre (B axis) the U axis is on, in
  the arm's own sense;
- n: 0 front, 1 rear: the wrist centre in front of or behind the S axis;
- o, p, q: 0 where the R, T, S axis angle is below 180 deg, 1 where it is 180 or more, in
  magnitude (which turn of a joint whose range exceeds a turn: with the flip bit, R in
  -90..90 against 270..360).
The IR keeps them as conf = [l, m, n, o + 2 p + 4 q].
"""


from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin

TURN_JOINTS = (3, 5, 0)  # R, T, S: bits 0, 1, 2 of the last conf column


def form_of_joints(robot, q_deg: np.ndarray) -> np.ndarray:
    """(N, 4) [flip, arm, side, turns] of joint vectors (N, 6) in degrees."""
    q = np.asarray(q_deg, dtype=float).reshape(-1, 6)
    opw = robot.opw
    phi = kin.opw_angles(robot, q)
    forward, up = kin.wrist_centre_in_arm_plane(robot, phi)
    # Elbow (U axis) in the arm plane, relative to the L axis at (a1, 0).
    elbow_f, elbow_u = opw.c2 * np.sin(phi[:, 1]), opw.c2 * np.cos(phi[:, 1])
    side_of_line = (forward - opw.a1) * elbow_u - up * elbow_f  # > 0: U left of L -> wrist
    r = q[:, 3]
    no_flip = np.mod(r + 90.0, 360.0) > 180.0  # R in (90, 270] + k 360: the "B position" of the manual's figure
    no_flip |= np.mod(r + 90.0, 360.0) == 0.0  # R = -90 (+ k 360) is no flip too
    flip = no_flip.astype(float)  # 0 flip, 1 no flip
    arm = (side_of_line <= 0).astype(float)
    side = (forward < 0).astype(float)
    turns = sum((np.abs(q[:, j]) >= 180.0) * (1 << k) for k, j in enumerate(TURN_JOINTS))
    return np.column_stack([flip, arm, side, turns.astype(float)])


def _turned(robot, q: np.ndarray, joint: int, want: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """q (M,) of one joint moved by whole turns to the side of 180 deg ``want`` (M,) asks
    for, inside the limits; and (M,) True where exactly one such value exists."""
    lo, hi = robot.lower_deg[joint], robot.upper_deg[joint]
    options = q[:, None] + np.array([-360.0, 0.0, 360.0])[None, :]
    fits = (options >= lo) & (options <= hi) & ((np.abs(options) >= 180.0) == want[:, None])
    unique = fits.sum(axis=1) == 1
    return np.where(unique, options[np.arange(len(q)), np.argmax(fits, axis=1)], np.nan), unique


def select_by_form(robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joints (N, 6) and branch (N,) of the IK solution (``solutions`` (N, 8, 6)) with the
    form ``conf`` (N, 4); NaN and -1 where none has it or the turn is not determined."""
    sols = np.asarray(solutions, dtype=float)
    n = sols.shape[0]
    best, branch = np.full((n, 6), np.nan), np.full(n, -1)
    want_turns = conf[:, 3].astype(int)
    for b in range(sols.shape[1]):
        open_rows = np.nonzero(branch < 0)[0]
        if not len(open_rows):
            break
        cand = sols[open_rows, b].copy()
        ok = ~np.isnan(cand).any(axis=1)
        for k, joint in enumerate(TURN_JOINTS):
            cand[:, joint], unique = _turned(robot, np.nan_to_num(cand[:, joint]), joint, (want_turns[open_rows] >> k) & 1 == 1)
            ok &= unique
        ok &= kin.within_limits(robot, np.nan_to_num(cand))
        form = form_of_joints(robot, np.nan_to_num(cand))
        ok &= (form[:, :3] == conf[open_rows, :3]).all(axis=1)
        best[open_rows[ok]] = cand[ok]
        branch[open_rows[ok]] = b
    return best, branch
