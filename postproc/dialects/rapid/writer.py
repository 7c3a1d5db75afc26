"""A new RAPID module from the writer events (see postproc.emit.writer)."""

from __future__ import annotations

import numpy as np

from ...emit.writer import legal_name, short_number
from ...frames import matrix_to_quat_wxyz
from .parse import NO_AXIS_TEXT

NO_EXTERNAL_AXES = "[" + ",".join([NO_AXIS_TEXT] * 6) + "]"  # extax of a robot without external axes


def _pose_literal(t: np.ndarray) -> str:
    """A pose as RAPID writes one: [[x,y,z],[q1,q2,q3,q4]] (mm, unit quaternion)."""
    q = matrix_to_quat_wxyz(t[None, :3, :3])[0]
    return f"[[{','.join(short_number(v) for v in t[:3, 3])}],[{','.join(short_number(v, 7) for v in q)}]]"


class RapidWriter:
    def __init__(self, module: str = "Converted"):
        self.module = legal_name(module, "Module")
        self.decl: list[str] = []
        self.body: list[str] = []
        self.tool_name, self.wobj_name = "tool0", "wobj0"
        self.v, self.z = 100.0, 0.0
        self.proc = "main"
        self.placeholder_conf = False  # a target was written without configuration data
        self.tool_load = None  # emit.tool_load.ToolLoad: convert --tool-load
        self.gripping = False  # a GripLoad of the tool load is in force (tool0)

    def set_tool_load(self, load) -> None:
        self.tool_load = load

    def _load_literal(self) -> str:
        """[mass,[cog],[aom],ix,iy,iz] of the given load (axes of moment along the tool0 frame)."""
        load = self.tool_load
        cog = ",".join(short_number(v) for v in load.cog_mm)
        return f"[{short_number(load.mass_kg, 6)},[{cog}],[1,0,0,0],{','.join(short_number(v, 6) for v in load.inertia_kgm2)}]"

    def start(self, name: str) -> None:
        self.proc = legal_name(name, "main")

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.wobj_name = legal_name(name, "wobj")
        if self.wobj_name != "wobj0":  # user frame = the frame, object frame = identity
            self.decl.append(f"  TASK PERS wobjdata {self.wobj_name} := [FALSE,TRUE,\"\",{_pose_literal(base_T_frame)},[[0,0,0],[1,0,0,0]]];")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.tool_name = legal_name(name, "tool")
        if self.tool_name == "tool0":
            self._grip(self.tool_load is not None)  # tool0 is the controller's (0 kg): the load is gripped instead
        elif self.tool_load is not None:
            self._grip(False)
            self.decl.append(f"  PERS tooldata {self.tool_name} := [TRUE,{_pose_literal(flange_T_tcp)},{self._load_literal()}];")
        else:
            # tooldata must carry a load (mass > 0); the input gives none, so the program says so where the robot programmer looks
            self.decl.append(f"  ! {self.tool_name}: load 1 kg at [0,0,1] mm is a placeholder (the input program gives no tool load; "
                             "give it with --tool-load): set the real one")
            self.decl.append(f"  PERS tooldata {self.tool_name} := [TRUE,{_pose_literal(flange_T_tcp)},[1,[0,0,1],[1,0,0,0],0,0,0]];")

    def _grip(self, on: bool) -> None:
        """GripLoad of the tool load on (tool0 carries it) or off (a tooldata carries it)."""
        if on and not self.gripping:
            self.decl.append(f"  PERS loaddata tool_load := {self._load_literal()};")
            self.body.append("    GripLoad tool_load;")
        elif self.gripping and not on:
            self.body.append("    GripLoad load0;")
        self.gripping = on

    def speed(self, mm_s: float) -> None:
        self.v = mm_s

    def zone(self, mm: float) -> None:
        self.z = mm

    def _args(self) -> str:
        speed = f"v1000\\V:={short_number(self.v, 3)}" if np.isfinite(self.v) else "v100"
        zone = "fine" if not np.isfinite(self.z) or self.z <= 0 else f"z10\\Z:={short_number(self.z, 3)}"
        wobj = "" if self.wobj_name == "wobj0" else f"\\WObj:={self.wobj_name}"
        return f"{speed}, {zone}, {self.tool_name}{wobj}"

    def _target(self, pose: np.ndarray, conf=None) -> str:
        missing = conf is None or np.isnan(conf).any()
        self.placeholder_conf |= missing
        c = [0, 0, 0, 0] if missing else [int(v) for v in conf]
        return f"[{_pose_literal(pose)[1:-1]},[{','.join(map(str, c))}],{NO_EXTERNAL_AXES}]"

    def move_joint(self, pose, conf=None) -> None:
        self.body.append(f"    MoveJ {self._target(pose, conf)}, {self._args()};")

    def move_linear(self, pose, conf=None) -> None:
        self.body.append(f"    MoveL {self._target(pose, conf)}, {self._args()};")

    def move_circular(self, via, end, conf=None) -> None:
        self.body.append(f"    MoveC {self._target(via, conf)}, {self._target(end, conf)}, {self._args()};")

    def move_joints(self, q) -> None:
        self.body.append(f"    MoveAbsJ [[{','.join(short_number(v) for v in q)}],{NO_EXTERNAL_AXES}]\\NoEOffs, {self._args()};")

    def raw(self, line: str) -> None:
        self.body.append(f"    ! {line}")

    def end(self) -> list[str]:
        # Targets without configuration data get [0,0,0,0]: under the default ConfJ\On /
        # ConfL\On the controller would try to reach exactly that configuration (and stop
        # where no solution has it), so the program lets it take the nearest one instead.
        free = ["    ! no configuration data in the input: the robot keeps the configuration nearest its current one",
                "    ConfJ\\Off;", "    ConfL\\Off;"] if self.placeholder_conf else []
        lines = [f"MODULE {self.module}", *dict.fromkeys(self.decl), f"  PROC {self.proc}()", *free, *self.body, "  ENDPROC", "ENDMODULE", ""]
        return ["\n".join(lines)]
