"""Predictor inputs from commanded joints, computed with the nominal kinematics.

- ``pose``: the nominal TCP pose (x, y, z mm; KUKA A, B, C deg) — seed 001's features;
- ``joints+disp``: the 6 joint angles and the TCP's displacement from a reference point
  (the first pose of the training set) — seed 000's features;
- ``position``: the nominal TCP position only — the spatial grid's;
- ``tcp+joints``: the nominal TCP position (mm) and the 6 joint angles (deg) — the arm's
  posture as well as where the probe is: Cartesian features cannot tell two postures that
  reach the same pose apart (another IK branch, another wrist angle), joint angles can;
- ``joints``: the 6 joint angles (deg) only;
- ``tcp+joints+travel``: ``tcp+joints`` and how far the TCP travelled (nominal, mm) in the
  move into the pose and in the two moves before it, as log(1 + mm): the pose's history in
  the path (postproc.model.path_history). On the UR10's Series A the first poses after a
  move to a new grid point miss by three to four times what the later poses at the point
  do; a learner that sees only the pose cannot tell them apart.

GP_KINDS are the kinds the ``gpr`` predictor may be given (``--gp-features``); its first
three features are what its local experts are split on (the TCP position, or for
``joints`` the first three joint angles).
"""

from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin
from postproc.robot.frames import matrix_to_abc

from ..path_history import travel_mm

KINDS = ("pose", "joints+disp", "position", "tcp+joints", "joints", "tcp+joints+travel")
GP_KINDS = ("pose", "tcp+joints", "joints", "tcp+joints+travel")
#: the kinds that read the targets before each pose (``previous_q_deg``)
HISTORY_KINDS = ("tcp+joints+travel",)


def features(robot, tool_mm, q_deg: np.ndarray, kind: str, reference: np.ndarray | None = None,
             previous_q_deg: np.ndarray | None = None) -> np.ndarray:
    """(N, F) inputs of the kind; ``previous_q_deg`` (N, k, 6): the joints of the targets
    before each pose in path order (postproc.model.path_history), for HISTORY_KINDS."""
    poses = kin.fk(robot, q_deg, tool=np.asarray(tool_mm, dtype=float))
    if kind == "position":
        return poses[:, :3, 3]
    if kind == "pose":
        return np.hstack([poses[:, :3, 3], matrix_to_abc(poses[:, :3, :3])])
    if kind == "tcp+joints":
        return np.hstack([poses[:, :3, 3], np.asarray(q_deg, dtype=float)])
    if kind == "tcp+joints+travel":
        if previous_q_deg is None:
            raise ValueError("the tcp+joints+travel features need the joints of the targets before each pose")
        return np.hstack([poses[:, :3, 3], np.asarray(q_deg, dtype=float), np.log1p(travel_mm(robot, tool_mm, poses, previous_q_deg))])
    if kind == "joints":
        return np.asarray(q_deg, dtype=float).copy()
    if kind == "joints+disp":
        ref = np.zeros(3) if reference is None else np.asarray(reference, dtype=float)
        return np.hstack([np.asarray(q_deg, dtype=float), poses[:, :3, 3] - ref])
    raise ValueError(f"unknown feature kind '{kind}' ({', '.join(KINDS)})")
