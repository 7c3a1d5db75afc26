"""What a Fanuc R-30iB controller does with a TP program: which arm posture a target's
CONFIG selects, which motions follow it, where the path between targets is not the
straight line or circle the prediction assumes.

Configuration data of a Cartesian position, R-30iB Operator's Manual,
"Configuration" (position data): ``CONFIG : 'F|N U|D T|B, t4, t5, t6'``:
- F / N: the wrist flipped or not: here J5 > 0 is flipped (the home posture with the tool
  down, J5 = -90, is 'N');
- U / D: the elbow (J3's wrist centre) above or below the line from J2 to the wrist centre;
- T / B: the wrist centre in front of (toward) or behind the J1 axis;
- t4, t5, t6: the turn numbers of J4, J5, J6: turn t where the joint is in
  (-180 + 360 t, 180 + 360 t] degrees.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import opw_angles, within_limits, wrist_centre_in_arm_plane

from ...controller import Controller
from ...ir import Kind, Toolpath

TURN_JOINTS = (3, 4, 5)  # J4, J5, J6 (0-based)


def fanuc_config(robot, q_deg: np.ndarray) -> np.ndarray:
    """(N, 4) configuration of joints (N, 6) deg in the robot file's convention: arm code
    4 flip + 2 down + 1 back, and the turn numbers of J4, J5, J6."""
    q = np.asarray(q_deg, dtype=float).reshape(-1, 6)
    phi = opw_angles(robot, q)
    forward, up = wrist_centre_in_arm_plane(robot, phi)
    normal = (forward - robot.opw.a1) * np.cos(phi[:, 1]) - up * np.sin(phi[:, 1])
    back = forward < 0
    down = normal < 0  # the elbow below the J2 -> wrist centre line (ABB's cfx bit 1, the same geometry)
    flip = q[:, 4] > 0
    turns = np.ceil((q[:, list(TURN_JOINTS)] - 180.0) / 360.0)
    return np.column_stack([4 * flip + 2 * down + 1 * back, turns]).astype(float)


def config_text(conf: np.ndarray) -> str:
    """'N U T, 0, 0, 0' of one configuration row."""
    code = int(conf[0])
    arm = f"{'F' if code & 4 else 'N'} {'D' if code & 2 else 'U'} {'B' if code & 1 else 'T'}"
    return arm + "".join(f", {int(t)}" for t in conf[1:4])


class FanucController(Controller):
    name = "Fanuc R-30iB"
    maker = "Fanuc"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """A J motion to a Cartesian position takes the joint solution its CONFIG names (arm
        posture and turn numbers); L and C motions interpolate from the joints the robot is
        at and keep that posture (a taught CONFIG they cannot keep stops the robot with an
        alarm) (R-30iB Operator's Manual, "Configuration" and "Motion format")."""
        return (tp.kind == Kind.JOINT) & ~np.isnan(tp.conf).any(axis=1)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per target, the IK solution whose flip / up / front and J4 J5 J6 turn numbers are
        those of its CONFIG (R-30iB Operator's Manual, "Configuration"); NaN and -1 where none
        is, or the target has no CONFIG. Each wide joint is first turned to the turn asked for."""
        sols = np.asarray(solutions, dtype=float)
        n = sols.shape[0]
        best, idx = np.full((n, 6), np.nan), np.full(n, -1)
        conf = np.asarray(conf, dtype=float)
        has = ~np.isnan(conf).any(axis=1)
        for b in range(sols.shape[1]):
            open_rows = np.nonzero((idx < 0) & has)[0]
            if not len(open_rows):
                break
            cand = sols[open_rows, b].copy()
            for k, j in enumerate(TURN_JOINTS):
                wrapped = (cand[:, j] + 180.0) % 360.0 - 180.0  # in [-180, 180)
                wrapped = np.where(wrapped == -180.0, 180.0, wrapped)  # turn 0 is (-180, 180]
                cand[:, j] = wrapped + 360.0 * conf[open_rows, 1 + k]
            finite = ~np.isnan(cand).any(axis=1)
            usable = finite & within_limits(robot, np.where(finite[:, None], cand, 0.0))
            got = fanuc_config(robot, np.where(usable[:, None], cand, 0.0))
            ok = usable & np.all(got == conf[open_rows], axis=1)
            best[open_rows[ok]], idx[open_rows[ok]] = cand[ok], b
        return best, idx

    def payloads(self, tp: Toolpath) -> list[tuple[float, str]]:
        """PAYLOAD[n] selects a payload schedule set on the controller (R-30iB manual, "Payload
        setting"): the program states no mass."""
        return []

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """The first A (arc through consecutive points) or Wjnt motion (``extras["fanuc.off_line"]``,
        set by the parser): between its targets the controller leaves the straight line the
        prediction assumes (R-30iB manual, "Circular arc motion", "Wrist joint motion option")."""
        off_line = tp.extras.get("fanuc.off_line")
        if off_line is None or not off_line.any():
            return None
        row = int(np.argmax(off_line))
        return f"{tp.sources[int(tp.file[row])].path}:{tp.line[row]}: an A (arc) or Wjnt motion: the controller's path between these targets is not a straight line"


R30IB = FanucController()
