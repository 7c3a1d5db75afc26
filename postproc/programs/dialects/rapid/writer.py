"""A new RAPID module from the writer events (see postproc.programs.emit.writer)."""

from __future__ import annotations

import numpy as np

from postproc.robot.frames import matrix_to_quat_wxyz

from ...emit.tool_load import NO_LOAD, combined
from ...emit.writer import legal_name, short_number
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
        self.tool_frame = np.eye(4)
        self.tooldata: dict[tuple, str] = {}  # (tool, its load) -> the tooldata declared for it
        self.loaddata: dict = {}  # a gripped load -> the loaddata declared for it
        self.gripping = None  # the load of the GripLoad in force (None: load0)

    @staticmethod
    def _load_literal(load) -> str:
        """[mass,[cog],[aom],ix,iy,iz]: cog in the tool0 frame, moments about the aom axes."""
        cog = ",".join(short_number(v) for v in load.cog_mm)
        aom = ",".join(short_number(v, 7) for v in load.aom_wxyz)
        return f"[{short_number(load.mass_kg, 6)},[{cog}],[{aom}],{','.join(short_number(v, 6) for v in load.inertia_kgm2)}]"

    def start(self, name: str) -> None:
        self.proc = legal_name(name, "main")

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.wobj_name = legal_name(name, "wobj")
        if self.wobj_name != "wobj0":  # user frame = the frame, object frame = identity
            self.decl.append(f"  TASK PERS wobjdata {self.wobj_name} := [FALSE,TRUE,\"\",{_pose_literal(base_T_frame)},[[0,0,0],[1,0,0,0]]];")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.tool_base, self.tool_frame = legal_name(name, "tool"), flange_T_tcp
        self.tool_name = None  # declared by load(), or at the first motion without one

    def load(self, state) -> None:
        """The tool's tooldata with the tool load (one tooldata per tool and load: NAME, NAME_2, ...;
        tool0 is the controller's, 0 kg: its load is gripped) and the GripLoad in force."""
        tool_load, grip = (None, None) if state is None else (state.tool, state.grip)
        if self.tool_base == "tool0":
            self.tool_name = "tool0"
            self._grip(combined(tool_load or NO_LOAD, grip))
            return
        key = (self.tool_base, tool_load, tuple(np.round(self.tool_frame, 9).ravel()))
        if key not in self.tooldata:
            n = sum(k[0] == self.tool_base for k in self.tooldata)
            self.tooldata[key] = name = self.tool_base if n == 0 else f"{self.tool_base}_{n + 1}"
            if tool_load is None:
                # tooldata must carry a load (mass > 0); the input gives none, so the program says so where the robot programmer looks
                self.decl.append(f"  ! {name}: load 1 kg at [0,0,1] mm is a placeholder (the input program gives no tool load; "
                                 "give it with --tool-load): set the real one")
            self.decl.append(f"  PERS tooldata {name} := [TRUE,{_pose_literal(self.tool_frame)},"
                             f"{'[1,[0,0,1],[1,0,0,0],0,0,0]' if tool_load is None else self._load_literal(tool_load)}];")
        self.tool_name = self.tooldata[key]
        self._grip(grip)

    def _grip(self, load) -> None:
        """GripLoad of ``load`` (a loaddata declared for it) where it changes; GripLoad load0 to drop it."""
        load = None if load is None or load.mass_kg == 0 else load
        if load == self.gripping:
            return
        if load is None:
            self.body.append("    GripLoad load0;")
        else:
            if load not in self.loaddata:
                self.loaddata[load] = name = "tool_load" if not self.loaddata else f"tool_load_{len(self.loaddata) + 1}"
                self.decl.append(f"  PERS loaddata {name} := {self._load_literal(load)};")
            self.body.append(f"    GripLoad {self.loaddata[load]};")
        self.gripping = load

    def speed(self, mm_s: float) -> None:
        self.v = mm_s

    def zone(self, mm: float) -> None:
        self.z = mm

    def _args(self) -> str:
        if self.tool_name is None:
            self.load(None)
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
