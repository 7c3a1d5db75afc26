"""A new URScript program from the writer events (see postproc.programs.emit.writer).

One ``def name():`` ... ``end`` (a .script file PolyScope and the controller's script port
run as a program); poses p[x, y, z, rx, ry, rz] in metres and a rotation vector in radians,
joint lists in radians, v= in m/s and r= in m (URScript manual, "movej", "movel", "movec").
A frame other than the base is a global pose and its targets ``pose_trans(frame, p[...])``.
"""

from __future__ import annotations

import numpy as np

from ...emit.writer import legal_name, short_number
from ...rotation_forms import form

ROTVEC = form("rotvec")
DECIMALS = 7  # metres and radians: 0.1 um, 0.1 urad (the IR's write tolerances are 0.5 um and 9 urad)


def pose_literal(t: np.ndarray) -> str:
    """``p[x, y, z, rx, ry, rz]`` of a transform (mm) in metres and a rotation vector."""
    rotvec = ROTVEC.numbers_from_matrix(t[None, :3, :3])[0]
    return "p[" + ", ".join(short_number(v, DECIMALS) for v in [*(t[:3, 3] / 1000.0), *rotvec]) + "]"


class UrWriter:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "prog")
        self.head: list[str] = []
        self.body: list[str] = []
        self.frame_var: str | None = None
        self.frames: dict[str, str] = {}
        self.v = ""
        self.r = ""

    def start(self, name: str) -> None:
        pass

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        if np.allclose(base_T_frame, np.eye(4), atol=1e-12, rtol=0):
            self.frame_var = None
            return
        literal = pose_literal(base_T_frame)
        if literal not in self.frames:
            self.frames[literal] = legal_name(f"frame_{len(self.frames) + 1}_{name}", "frame")
            self.head.append(f"  global {self.frames[literal]} = {literal}")
        self.frame_var = self.frames[literal]

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.body.append(f"  set_tcp({pose_literal(flange_T_tcp)})")

    def speed(self, mm_s: float) -> None:
        self.v = f", v={short_number(mm_s / 1000.0, 6)}" if np.isfinite(mm_s) and mm_s > 0 else ""

    def zone(self, mm: float) -> None:
        # r= blends within r of the target (URScript manual, "movel"); none where the source stops.
        self.r = f", r={short_number(mm / 1000.0, 6)}" if np.isfinite(mm) and mm > 0 else ""

    def _pose(self, pose: np.ndarray) -> str:
        literal = pose_literal(pose)
        return literal if self.frame_var is None else f"pose_trans({self.frame_var}, {literal})"

    def move_joint(self, pose, conf=None) -> None:
        # movej to a pose: the controller takes the IK solution nearest the current joints.
        self.body.append(f"  movej({self._pose(pose)}{self.r})")

    def move_linear(self, pose, conf=None) -> None:
        self.body.append(f"  movel({self._pose(pose)}{self.v}{self.r})")

    def move_circular(self, via, end, conf=None) -> None:
        self.body.append(f"  movec({self._pose(via)}, {self._pose(end)}{self.v}{self.r}, mode=0)")

    def move_joints(self, q) -> None:
        self.body.append("  movej([" + ", ".join(short_number(v, DECIMALS) for v in np.radians(q)) + f"]{self.r})")

    def raw(self, line: str) -> None:
        self.body.append(f"  # {line}")

    def end(self) -> list[str]:
        return ["\n".join([f"def {self.name}():", *self.head, *self.body, "end", ""])]
