"""What a pose's history in the path is: the joints of the targets before it, in path order.

Some errors depend on how the arm got to a pose, not only on the pose: on the UR10's
Series A the first three poses measured after the probe moved to a new grid point miss by
0.27 / 0.17 / 0.12 mm on held-out poses of the hybrid model, the poses after them by
0.06 mm, and the same probe orientations measured later at a point miss by 0.03-0.05 mm
(docs/guide/validate.md, "The tail of random held-out poses"). A measurement set gives the
history by its row order (the order the poses were measured in), a program by the order of
its targets; a subset of a measurement set (a protocol's training or test poses) keeps the
history of its rows in the whole set, which is why it is taken before the split.
"""

from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin

#: how many targets back the history reaches
HISTORY_TARGETS = 3


def previous_targets(q_path_deg: np.ndarray, depth: int = HISTORY_TARGETS) -> np.ndarray:
    """(N, depth, 6): the joints of the 1st, 2nd, ... target before each row of the path
    (N, 6) in path order; before the first target, the first target itself (no move)."""
    q = np.asarray(q_path_deg, dtype=float)
    out = np.empty((len(q), depth, q.shape[1]))
    for back in range(1, depth + 1):
        index = np.maximum(np.arange(len(q)) - back, 0)
        out[:, back - 1] = q[index]
    return out


def path_travel_mm(robot, tool_mm, q_deg: np.ndarray, previous_q_deg: np.ndarray) -> np.ndarray:
    """(N, k): ``travel_mm`` of the poses at joints ``q_deg`` (N, 6)."""
    return travel_mm(robot, tool_mm, kin.fk(robot, np.asarray(q_deg, dtype=float), tool=np.asarray(tool_mm, dtype=float)), previous_q_deg)


def travel_mm(robot, tool_mm, poses: np.ndarray, previous_q_deg: np.ndarray) -> np.ndarray:
    """(N, k): nominal TCP distance (mm) of the move into each pose (``poses``, (N, 4, 4))
    and of the k - 1 moves before it (``previous_q_deg``, (N, k, 6), nearest target first)."""
    n, depth, _ = previous_q_deg.shape
    before = kin.fk(robot, previous_q_deg.reshape(-1, 6), tool=np.asarray(tool_mm, dtype=float))[:, :3, 3].reshape(n, depth, 3)
    chain = np.concatenate([poses[:, None, :3, 3], before], axis=1)  # this pose, then back along the path
    return np.linalg.norm(chain[:, :-1] - chain[:, 1:], axis=2)
