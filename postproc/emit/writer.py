"""Writing a new robot program from a Toolpath (when the input was another language).

A narrow event protocol, as CAM post-processors use: start, frame, tool, speed, zone,
move_joint / move_linear / move_circular / move_joints, raw line, end. ``RapidWriter``
and ``KrlWriter`` implement it; ``write_program`` drives one over a Toolpath.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import EmitError
from ..frames import matrix_to_abc, matrix_to_quat_wxyz, quat_wxyz_to_matrix
from ..ir import Kind, Toolpath

# A tool pointing straight down (180 degrees about y): the orientation given to targets
# that come without one (3-axis G-code).
TOOL_DOWN = np.array([0.0, 0.0, 1.0, 0.0])


def _name(text: str, prefix: str) -> str:
    clean = re.sub(r"[^A-Za-z0-9_]", "_", text).strip("_") or prefix
    return clean if clean[0].isalpha() else f"{prefix}_{clean}"


def _n(v: float, decimals: int = 4) -> str:
    text = f"{v:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


class RapidWriter:
    def __init__(self, module: str = "Converted"):
        self.module = _name(module, "Module")
        self.decl: list[str] = []
        self.body: list[str] = []
        self.tool_name, self.wobj_name = "tool0", "wobj0"
        self.v, self.z = 100.0, 0.0
        self.proc = "main"

    def start(self, name: str) -> None:
        self.proc = _name(name, "main")

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.wobj_name = _name(name, "wobj")
        if self.wobj_name != "wobj0":
            q = matrix_to_quat_wxyz(base_T_frame[None, :3, :3])[0]
            t = base_T_frame[:3, 3]
            self.decl.append(f"  TASK PERS wobjdata {self.wobj_name} := [FALSE,TRUE,\"\",[[{','.join(_n(v) for v in t)}],[{','.join(_n(v, 7) for v in q)}]],[[0,0,0],[1,0,0,0]]];")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.tool_name = _name(name, "tool")
        if self.tool_name != "tool0":
            q = matrix_to_quat_wxyz(flange_T_tcp[None, :3, :3])[0]
            t = flange_T_tcp[:3, 3]
            self.decl.append(f"  PERS tooldata {self.tool_name} := [TRUE,[[{','.join(_n(v) for v in t)}],[{','.join(_n(v, 7) for v in q)}]],[1,[0,0,1],[1,0,0,0],0,0,0]];")

    def speed(self, mm_s: float) -> None:
        self.v = mm_s

    def zone(self, mm: float) -> None:
        self.z = mm

    def _args(self) -> str:
        speed = f"v1000\\V:={_n(self.v, 3)}" if np.isfinite(self.v) else "v100"
        zone = "fine" if not np.isfinite(self.z) or self.z <= 0 else f"z10\\Z:={_n(self.z, 3)}"
        wobj = "" if self.wobj_name == "wobj0" else f"\\WObj:={self.wobj_name}"
        return f"{speed}, {zone}, {self.tool_name}{wobj}"

    @staticmethod
    def _target(pose: np.ndarray, conf=None) -> str:
        q = matrix_to_quat_wxyz(pose[None, :3, :3])[0]
        c = [0, 0, 0, 0] if conf is None or np.isnan(conf).any() else [int(v) for v in conf]
        return f"[[{','.join(_n(v) for v in pose[:3, 3])}],[{','.join(_n(v, 7) for v in q)}],[{','.join(map(str, c))}],[9E9,9E9,9E9,9E9,9E9,9E9]]"

    def move_joint(self, pose, conf=None) -> None:
        self.body.append(f"    MoveJ {self._target(pose, conf)}, {self._args()};")

    def move_linear(self, pose, conf=None) -> None:
        self.body.append(f"    MoveL {self._target(pose, conf)}, {self._args()};")

    def move_circular(self, via, end, conf=None) -> None:
        self.body.append(f"    MoveC {self._target(via, conf)}, {self._target(end, conf)}, {self._args()};")

    def move_joints(self, q) -> None:
        self.body.append(f"    MoveAbsJ [[{','.join(_n(v) for v in q)}],[9E9,9E9,9E9,9E9,9E9,9E9]]\\NoEOffs, {self._args()};")

    def raw(self, line: str) -> None:
        self.body.append(f"    ! {line}")

    def end(self) -> list[str]:
        lines = [f"MODULE {self.module}", *dict.fromkeys(self.decl), f"  PROC {self.proc}()", *self.body, "  ENDPROC", "ENDMODULE", ""]
        return ["\n".join(lines)]


class KrlWriter:
    def __init__(self, name: str = "converted"):
        self.name = _name(name, "prog").lower()
        self.body: list[str] = []
        self.approx = False

    def start(self, name: str) -> None:
        pass

    @staticmethod
    def _frame(t: np.ndarray) -> str:
        abc = matrix_to_abc(t[None, :3, :3])[0]
        return "{" + ", ".join(f"{k} {_n(v)}" for k, v in zip("XYZABC", [*t[:3, 3], *abc])) + "}"

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.body.append(f"$BASE = {self._frame(base_T_frame)}")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.body.append(f"$TOOL = {self._frame(flange_T_tcp)}")

    def speed(self, mm_s: float) -> None:
        if np.isfinite(mm_s):
            self.body.append(f"$VEL.CP = {_n(mm_s / 1000.0, 6)}")

    def zone(self, mm: float) -> None:
        self.approx = np.isfinite(mm) and mm > 0
        if self.approx:
            self.body.append(f"$APO.CDIS = {_n(mm, 3)}")

    def _c(self) -> str:
        return " C_DIS" if self.approx else ""

    def move_joint(self, pose, conf=None) -> None:
        self.body.append(f"PTP {self._frame(pose)}{self._c()}")

    def move_linear(self, pose, conf=None) -> None:
        self.body.append(f"LIN {self._frame(pose)}{self._c()}")

    def move_circular(self, via, end, conf=None) -> None:
        self.body.append(f"CIRC {self._frame(via)}, {self._frame(end)}{self._c()}")

    def move_joints(self, q) -> None:
        self.body.append("PTP {" + ", ".join(f"A{i + 1} {_n(v)}" for i, v in enumerate(q)) + "}")

    def raw(self, line: str) -> None:
        self.body.append(f"; {line}")

    def end(self) -> list[str]:
        src = [f"DEF {self.name}( )", *self.body, "END", ""]
        dat = [f"DEFDAT {self.name}", "ENDDAT", ""]  # every target is written inline
        return ["\r\n".join(src), "\r\n".join(dat)]


def write_program(tp: Toolpath, dialect: str, name: str = "converted") -> list[str]:
    """Texts of a new program (RAPID: [module]; KRL: [src, dat]) with every target of tp."""
    writer = {"rapid": RapidWriter, "krl": KrlWriter}.get(dialect)
    if writer is None:
        raise EmitError(f"cannot write a new {dialect} program (rapid or krl)")
    w = writer(name)
    w.start(name)
    bad = np.nonzero(np.isnan(tp.position).any(axis=1) & (tp.kind != Kind.ABSJ))[0]
    if len(bad):
        raise EmitError(f"line {tp.line[bad[0]]}: target position unknown in the input; cannot write it")
    poses = tp.target_poses()
    no_ori = np.isnan(tp.orientation).any(axis=1)
    if no_ori.any():
        poses[no_ori, :3, :3] = quat_wxyz_to_matrix(TOOL_DOWN[None])[0]
    frame = tool = -1
    speed = zone = None
    # G-code feeds are mm/min (the IR keeps speeds as written); the writers take mm/s.
    per_second = 1.0 / 60.0 if tp.dialect == "gcode" else 1.0
    i = 0
    while i < len(tp):
        if tp.frame[i] != frame:
            frame = int(tp.frame[i])
            w.frame(tp.frame_names[frame], tp.frames[frame])
        if tp.tool[i] != tool:
            tool = int(tp.tool[i])
            w.tool(tp.tool_names[tool], tp.tools[tool])
        if speed is None or not np.array_equal(tp.speed[i], speed, equal_nan=True):
            speed = tp.speed[i]
            w.speed(float(speed) * per_second)
        if zone is None or not np.array_equal(tp.zone[i], zone, equal_nan=True):
            zone = tp.zone[i]
            w.zone(float(zone))
        kind = int(tp.kind[i])
        if kind == Kind.CIRC_VIA and i + 1 < len(tp):
            w.move_circular(poses[i], poses[i + 1], tp.conf[i + 1])
            i += 2
            continue
        if kind == Kind.ABSJ:
            w.move_joints(tp.joints[i])
        elif kind in (Kind.JOINT, Kind.RAPID):
            w.move_joint(poses[i], tp.conf[i])
        else:
            # G2/G3 arcs become their end points (a chord); the source line is noted.
            if kind in (Kind.ARC_CW, Kind.ARC_CCW):
                w.raw(f"arc of line {tp.line[i]} written as a straight move to its end point")
            w.move_linear(poses[i], tp.conf[i])
        i += 1
    return w.end()
