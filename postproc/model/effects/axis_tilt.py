"""Tilt between parallel joint axes (Hayati's beta): what the DH table cannot describe.

Denavit-Hartenberg describes the relation of two consecutive joint axes by their common
normal. When the nominal axes are parallel (twist alpha_i = 0: joints 2, 3 and 4 of a
UR arm, joints 2 and 3 of most six-axis industrial robots) a small tilt of axis i+1 out
of the plane of the two axes moves the common normal arbitrarily far, so the small DH
errors (dtheta, dd, da, dalpha) cannot represent it: the identification Jacobian has no
column for it. Hayati and Mirmirani add a rotation beta_i about the y axis of frame i
for exactly these pairs,

    T_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i) Rot_x(alpha_i) Rot_y(beta_i)

(S. Hayati and M. Mirmirani, "Improving the absolute positioning accuracy of robot
manipulators", Journal of Robotic Systems 2(4), 397-413, 1985; the same parameter is
the "modified DH" of robot-calibration texts, e.g. Mooring, Roth & Driels, Fundamentals
of Manipulator Calibration, Wiley 1991, sec. 3.4). To first order a tilt beta_i about
y_i at the origin o_i moves the measured point p by beta_i (y_i x (p - o_i)); the model
evaluates it on the nominal chain (a product of two small errors is left out), as the
identification Jacobian of the DH errors does.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import joint_frames

from .base import Context, Effect, EffectSpecError, Param

_PARALLEL_DEG = 1.0  # nominal twist below which two consecutive axes count as parallel


def parallel_pairs(robot) -> list[int]:
    """DH frames i (1-based, 1..5) whose twist alpha_i makes axis i+1 parallel to axis i."""
    alpha = np.asarray(robot.alpha_deg, dtype=float)
    return [i + 1 for i in range(5) if abs(np.sin(np.deg2rad(alpha[i]))) < np.sin(np.deg2rad(_PARALLEL_DEG))]


class AxisTilt(Effect):
    name = "axis_tilt"
    kind = "cartesian"
    summary = "two joint axes that should be parallel are tilted against each other (Hayati's beta, outside the DH table)"
    finding = "residuals follow the wrist's reach across the arm plane: parallel joint axes are tilted against each other"
    identifiability = (
        "One tilt per pair of nominally parallel consecutive axes (UR: joints 2-3 and 3-4). The part of a tilt "
        "that moves the point by a constant offset along the parallel axes is the DH offsets' (dd) and is absorbed "
        "there; what identifies beta is the point's reach along the link beyond the tilted axis, which changes with "
        "the following joints (the wrist). A robot without parallel axes has no such parameter."
    )

    def __init__(self, frames: tuple[int, ...] | None = None):
        self.frames = None if frames is None else tuple(int(f) for f in frames)

    def options(self) -> dict:
        return {} if self.frames is None else {"frames": list(self.frames)}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "AxisTilt":
        unknown = set(opts) - {"frames"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: frames)")
        if "frames" not in opts:
            return cls()
        try:
            frames = tuple(int(f) for f in opts["frames"].split(",") if f.strip())
        except ValueError:
            raise EffectSpecError(f"{cls.name}: frames must be DH frame numbers 1..5, got '{opts['frames']}'") from None
        if not frames or any(f < 1 or f > 5 for f in frames):
            raise EffectSpecError(f"{cls.name}: frames must be DH frame numbers 1..5, got '{opts['frames']}'")
        return cls(frames)

    def _frames(self, robot) -> list[int]:
        return list(self.frames) if self.frames is not None else parallel_pairs(robot)

    def params(self, robot) -> list[Param]:
        # Machined parallel bores hold about 0.01-0.05 deg; bounds far beyond any assembled arm.
        return [Param(f"{self.name}.beta{i}", "deg", 0.01, 0.02, lower=-2.0, upper=2.0) for i in self._frames(robot)]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        rots, origins = joint_frames(robot, ctx.q_deg)
        tool = np.zeros(3) if ctx.tool_mm is None else np.asarray(ctx.tool_mm, dtype=float)
        point = origins[:, 6] + rots[:, 6] @ tool  # (N, 3) mm, nominal chain
        frames = self._frames(robot)
        basis = np.zeros((len(point), 3, len(frames)))
        for k, i in enumerate(frames):
            basis[:, :, k] = np.cross(rots[:, i, :, 1], point - origins[:, i]) * np.deg2rad(1.0)  # mm per degree
        return basis

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        return magnitude * param.typical * rng.standard_normal()
