"""What a Stäubli controller (CS8 / CS9, VAL3) does with a program: the arm configuration
it takes for each motion, and where it leaves the exact path.

Configuration (VAL3 reference manual, "config" type, 6-axis arms, and "movej" / "movel" /
"movec"): a pointRx carries ``shoulder`` (righty / lefty / ssame / sfree), ``elbow``
(epositive / enegative / esame / efree) and ``wrist`` (wpositive / wnegative / wsame /
wfree). ``movej`` goes to the point in the configuration it names; ``movel`` and ``movec``
cannot change configuration along the way and keep the one the arm is in. ``same`` keeps
the current value and ``free`` lets the controller choose, so only a point naming all three
fixes the posture of a movej; elsewhere the robot keeps its posture (postproc.robot.posture).

The words are read from the joints as follows: elbow epositive where j3 >= 0, wrist
wpositive where j5 >= 0 (the manual: the sign of joint 3, of joint 5); shoulder righty where
the wrist centre is behind axis 1, lefty in front (the mapping RoboDK's Stäubli post
processor writes, ``"righty" if rear``: the manual's figure shows the arm seen from above).
"""

from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin

from ...controller import Controller
from ...ir import Kind, Toolpath


class Val3Controller(Controller):
    """The rules of a Stäubli CS8 / CS9 controller running VAL3."""

    maker = "Stäubli"
    name = "Stäubli CS9 (VAL3)"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """(N,) True for movej targets whose point names shoulder, elbow and wrist (VAL3
        reference manual, "movej": the destination's configuration is taken; "movel" /
        "movec": no configuration change is possible during the motion)."""
        definite = np.all(np.abs(np.nan_to_num(tp.conf[:, :3])) == 1.0, axis=1)
        return (tp.kind == Kind.JOINT) & definite

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joints and branch of the first IK solution inside the limits whose shoulder,
        elbow and wrist are the point's (VAL3 reference manual, "config"); NaN and -1
        where the point names none or no solution has it."""
        sols = np.asarray(solutions, dtype=float)
        n = len(conf)
        q, branch = np.full((n, 6), np.nan), np.full(n, -1)
        want = np.asarray(conf, dtype=float)[:, :3]
        definite = np.all(np.abs(np.nan_to_num(want)) == 1.0, axis=1)
        for b in range(sols.shape[1]):
            open_rows = np.nonzero(definite & (branch < 0))[0]
            if not len(open_rows):
                break
            cand = sols[open_rows, b]
            usable = ~np.isnan(cand).any(axis=1) & kin.within_limits(robot, np.nan_to_num(cand))
            words = config_of_joints(robot, np.where(usable[:, None], cand, 0.0))
            ok = usable & np.all(words == want[open_rows], axis=1)
            q[open_rows[ok]], branch[open_rows[ok]] = cand[ok], b
        return q, branch

    # payloads / stated_loads: the base class's none. A VAL3 tool carries no mass (VAL3
    # reference manual, "tool": a geometric transformation and an I/O link only).

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """``file:line: why`` of the first motion whose descriptor blends (blend joint or
        Cartesian, or a descriptor that does not say: VAL3 reference manual, "mdesc": with a
        blend the arm leaves the path ``leave`` mm before the point and rejoins it ``reach``
        mm after), else None."""
        blended = np.nonzero(~(tp.zone == 0.0))[0]
        if not len(blended):
            return None
        r = int(blended[0])
        how = "does not state its blend" if np.isnan(tp.zone[r]) else f"blends (leave {tp.zone[r]:g} mm)"
        return f"{tp.sources[int(tp.file[r])].path}:{int(tp.line[r])}: the motion descriptor {how}: the arm leaves the exact path near the point"


def config_of_joints(robot, q_deg: np.ndarray) -> np.ndarray:
    """(N, 3) shoulder, elbow, wrist codes (1: righty / epositive / wpositive, -1: lefty /
    enegative / wnegative) of joints (N, 6) in degrees (see the module's docstring)."""
    q = np.asarray(q_deg, dtype=float).reshape(-1, 6)
    forward, _ = kin.wrist_centre_in_arm_plane(robot, kin.opw_angles(robot, q))
    shoulder = np.where(forward < 0, 1.0, -1.0)
    elbow = np.where(q[:, 2] >= 0, 1.0, -1.0)
    wrist = np.where(q[:, 4] >= 0, 1.0, -1.0)
    return np.column_stack([shoulder, elbow, wrist])


CS9 = Val3Controller()
