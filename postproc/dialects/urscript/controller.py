"""What a Universal Robots controller (CB3 / e-Series, PolyScope 3.x and 5.x) does with a
URScript program: which inverse-kinematics solution a pose target takes, and where blends
leave the programmed path. Each rule cites the URScript manual (Universal Robots, "The
URScript Programming Language", e-Series 5.x, section "Module motion")."""

from __future__ import annotations

import numpy as np

from ...ir import Kind, Toolpath


class UrController:
    maker = "Universal Robots"
    name = "Universal Robots CB3 / e-Series"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        """(N,) all False: a pose target (movel, movep, movec, movej to a pose) takes the
        inverse-kinematics solution nearest the current joints (manual, "movel"; "movej": a
        pose is converted with get_inverse_kin, whose qnear defaults to the current joints):
        the program gives no configuration data, the robot keeps the posture it is in
        (postproc.posture carries it from the last joint target)."""
        return np.zeros(len(tp), dtype=bool)

    def branch_from_conf(self, robot, solutions: np.ndarray, conf: np.ndarray):
        """No configuration data in URScript (see ``conf_applies``): NaN and -1."""
        return np.full((len(conf), 6), np.nan), np.full(len(conf), -1)

    def payloads(self, tp: Toolpath) -> list[tuple[float, str]]:
        return []

    def stated_loads(self, tp: Toolpath):
        return None

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """``file:line: why`` of the first motion with a blend radius r > 0: the robot leaves the
        straight (or circular) path within r of the target, blending into the next motion
        (manual, "movel": "r: blend radius"; "movep": "blend radius"); None where every motion
        stops at its target. movep also keeps the tool speed constant, but on the same path."""
        blend = _extra(tp, "urscript.blend_m")
        if blend is None:
            blend = tp.zone / 1000.0
        moving = np.nan_to_num(blend, nan=1.0) > 0  # an r= the text does not fix may be a blend
        if not moving.any():
            return None
        i = int(np.nonzero(moving)[0][0])
        radius = "a blend radius the text does not fix" if np.isnan(blend[i]) else f"blend radius r={blend[i]:g} m"
        return f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: {radius}: the robot leaves the programmed path near the target to blend into the next motion (URScript manual, 'movel', parameter r)"

    def arc_ends_at_target(self, tp: Toolpath) -> np.ndarray:
        """movec ends at pose_to (manual, "movec": mode 0 and 1 differ only in orientation)."""
        return np.ones(len(tp.kind), dtype=bool)


def _extra(tp: Toolpath, key: str):
    return tp.extras.get(key)


__all__ = ["UrController", "Kind"]
