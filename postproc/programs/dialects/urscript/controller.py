"""What a Universal Robots controller (CB3 / e-Series, PolyScope 3.x and 5.x) does with a
URScript program: which inverse-kinematics solution a pose target takes, and where blends
leave the programmed path. Each rule cites the URScript manual (Universal Robots, "The
URScript Programming Language", e-Series 5.x, module "motion")."""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import select_nearest

from ...controller import Controller
from ...ir import Toolpath


class UrController(Controller):
    maker = "Universal"  # as robot files' descriptions name the maker: their first word (program_check)
    name = "Universal Robots CB3 / e-Series controller"
    # A pose target takes the solution nearest the current joints: before the program's first
    # joint target those are the robot's at the start, which the program does not state.
    start_posture_assumed = False

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """(N,) True where the program itself picks the target's IK solution:
        ``movej(get_inverse_kin(x, qnear=q))`` takes the solution nearest q (manual,
        "get_inverse_kin": "qnear: list of joint positions (optional)... the solution closest
        to qnear"). Every other pose target (movel, movep, movec, movej to a pose) takes the
        solution nearest the current joints (manual, "movel": the target is converted with the
        inverse kinematics nearest the current joints; "get_inverse_kin": qnear defaults to
        the current joints): the robot keeps its posture (postproc.robot.posture carries it)."""
        return ~np.isnan(_qnear(tp)).any(axis=1)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray):
        """URScript has no configuration data: NaN and -1 (see ``branch_of_targets``)."""
        return super().branch_from_conf(robot, solutions, conf)

    def branch_of_targets(self, robot, solutions: np.ndarray, tp: Toolpath, rows: np.ndarray):
        """The solution nearest each target's qnear (manual, "get_inverse_kin")."""
        return select_nearest(robot, solutions, _qnear(tp)[rows])

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """``file:line: why`` of the first motion with a blend radius r > 0: the robot leaves the
        straight (or circular) path within r of the target, blending into the next motion
        (manual, "movel", "movep", "movec": parameter r, blend radius); None where every
        motion stops at its target. (movep also keeps the tool speed constant, on the same path.)"""
        blend = tp.extras.get("urscript.blend_m", tp.zone / 1000.0)
        blended = np.nan_to_num(blend, nan=1.0) > 0  # an r= the text does not fix may blend
        if not blended.any():
            return None
        i = int(np.nonzero(blended)[0][0])
        radius = "a blend radius the text does not fix" if np.isnan(blend[i]) else f"blend radius r={blend[i]:g} m"
        return (f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: {radius}: the robot leaves the programmed path near the target "
                "to blend into the next motion (URScript manual, 'movel', parameter r)")


def _qnear(tp: Toolpath) -> np.ndarray:
    """(N, 6) each target's get_inverse_kin qnear, degrees (NaN where none)."""
    return tp.extras.get("urscript.qnear_deg", np.full((len(tp), 6), np.nan))


UR_CONTROLLER = UrController()
