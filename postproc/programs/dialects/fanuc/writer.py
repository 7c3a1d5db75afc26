"""A new Fanuc TP listing (.ls) from the writer events (see postproc.programs.emit.writer).

Positions go to /POS, each motion to /MN (R-30iB Operator's Manual, "Program structure").
User frames and tools are numbered in the order they come (0: the world frame and the
faceplate); their values are set on the controller, not in a TP program, so each is
written as a remark with its X Y Z W P R for the person who sets it. A Cartesian position
needs a CONFIG, which only the robot's joints determine: a Fanuc input's CONFIG is kept, and
from another language it is computed from the joints the input's controller takes
(``convert --robot``: postproc.jobs.convert_conf); without a robot a J motion from another language
is refused (postproc.programs.write_program), and an L or C position, whose CONFIG the
controller does not take (it keeps the posture the robot is in: controller.py), gets
'N U T, 0, 0, 0', which a remark names.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import matrix_to_abc

from ...emit.writer import legal_name
from .controller import config_text

PLACEHOLDER = "N U T, 0, 0, 0"
MAX_FRAMES, MAX_TOOLS = 9, 10  # UFRAME[1..9], UTOOL[1..10] on an R-30iB (manual, "Setting a user frame", "Setting a tool frame")


def _wpr(t: np.ndarray) -> np.ndarray:
    """W, P, R (deg) of a rotation: R = Rz(R) Ry(P) Rx(W), KUKA's A, B, C reversed."""
    return matrix_to_abc(t[None, :3, :3])[0][::-1]


def _num(v: float, width: int = 9) -> str:
    """``v`` with 3 decimals, as the controller lists positions ('-0.000' written as '0.000')."""
    text = f"{v:{width}.3f}"
    return text.replace("-0.000", " 0.000") if text.strip() == "-0.000" else text


class FanucWriter:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "PROG").upper()[:36]
        self.mn: list[str] = []
        self.pos: list[str] = []
        self.remarks: list[str] = []
        self.frames: dict[str, int] = {}
        self.tools: dict[str, int] = {}
        self.uf = self.ut = 0
        self.mm_s = np.nan
        self.term = "FINE"
        self.placeholders = 0

    def start(self, name: str) -> None:
        pass

    def _number(self, table: dict, name: str, transform: np.ndarray, identity_names: tuple[str, ...], limit: int, what: str) -> int:
        if name in identity_names and np.allclose(transform, np.eye(4)):
            return 0
        key = f"{name}:{np.round(transform, 9).tobytes().hex()}"
        if key not in table:
            if len(table) == limit:
                raise EmitError(f"more than {limit} {what}s: a Fanuc controller numbers {what}s 1..{limit}")
            table[key] = len(table) + 1
            xyz, wpr = transform[:3, 3], _wpr(transform)
            values = ", ".join(f"{k} {_num(v, 0).strip()}" for k, v in zip(("X", "Y", "Z", "W", "P", "R"), [*xyz, *wpr]))
            self.remarks.append(f"set {what} {table[key]} ({name}) on the controller: {values}")
        return table[key]

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.uf = self._number(self.frames, name, base_T_frame, ("<base>", "wobj0"), MAX_FRAMES, "UFRAME")
        self._statement(f"  UFRAME_NUM={self.uf}")

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.ut = self._number(self.tools, name, flange_T_tcp, ("<flange>", "tool0"), MAX_TOOLS, "UTOOL")
        self._statement(f"  UTOOL_NUM={self.ut}")

    def speed(self, mm_s: float) -> None:
        self.mm_s = mm_s

    def zone(self, mm: float) -> None:
        # CNT is a rounding the controller sizes from speeds, no distance maps to it: a
        # corner distance is written as CNT100 and the remark says so.
        self.term = "FINE" if not np.isfinite(mm) or mm <= 0 else "CNT100"
        if self.term != "FINE" and not any(r.startswith("corner") for r in self.remarks):
            self.remarks.append("corner distances of the input are written as CNT100 (the controller sizes the rounding)")

    def _statement(self, text: str) -> None:
        self.mn.append(f"{len(self.mn) + 1:4d}:{text} ;")

    def _linear_speed(self) -> str:
        """The TCP speed in whole mm/sec (as the pendant takes it, at least 1); 100mm/sec, said
        in a remark, where the input gives none."""
        if np.isfinite(self.mm_s):
            return f"{max(1, round(self.mm_s))}mm/sec"
        if not any(r.startswith("speed") for r in self.remarks):
            self.remarks.append("speeds the input does not give are written as 100mm/sec")
        return "100mm/sec"

    def _position(self, pose: np.ndarray, conf=None) -> str:
        """A Cartesian P[n] with the CONFIG of a Fanuc input (``conf``: arm code, turns), else the placeholder."""
        n = len([p for p in self.pos if p.startswith("P[")]) + 1
        given = conf is not None and np.isfinite(conf).all()
        self.placeholders += not given
        xyz, wpr = pose[:3, 3], _wpr(pose)
        self.pos += [f"P[{n}]{{", "   GP1:", f"\tUF : {self.uf}, UT : {self.ut},\t\tCONFIG : '{config_text(conf) if given else PLACEHOLDER}',",
                     f"\tX = {_num(xyz[0])}  mm,\tY = {_num(xyz[1])}  mm,\tZ = {_num(xyz[2])}  mm,",
                     f"\tW = {_num(wpr[0])} deg,\tP = {_num(wpr[1])} deg,\tR = {_num(wpr[2])} deg", "};"]
        return f"P[{n}]"

    def move_joint(self, pose, conf=None) -> None:
        """A J motion: the controller takes the position's CONFIG (controller.py)."""
        before = self.placeholders
        self._statement(f"J {self._position(pose, conf)} 100% {self.term}")
        if self.placeholders > before and not any(r.startswith("CONFIG") for r in self.remarks):
            self.remarks.append(f"CONFIG '{PLACEHOLDER}' is written where the input gives no Fanuc configuration: "
                                "J motions take it; check their postures")

    def _path_placeholder_remark(self, before: int) -> None:
        """The remark that names the placeholder CONFIG of L and C positions, once."""
        if self.placeholders > before and not any(r.startswith("CONFIG") for r in self.remarks):
            self.remarks.append(f"CONFIG '{PLACEHOLDER}' is written where the input gives no Fanuc configuration: "
                                "L and C motions keep the posture the robot is in, a J motion to such a position would take it")

    def move_linear(self, pose, conf=None) -> None:
        before = self.placeholders
        self._statement(f"L {self._position(pose, conf)} {self._linear_speed()} {self.term}")
        self._path_placeholder_remark(before)

    def move_circular(self, via, end, conf=None) -> None:
        before = self.placeholders
        via_p = self._position(via, conf)
        end_p = self._position(end, conf)
        self._path_placeholder_remark(before)
        self.mn.append(f"{len(self.mn) + 1:4d}:C {via_p}    ")
        self.mn.append(f"    :  {end_p} {self._linear_speed()} {self.term} ;")

    def move_joints(self, q) -> None:
        q = np.asarray(q, dtype=float)
        fanuc = q.copy()
        fanuc[2] = q[2] - q[1]  # the controller's J3 is the forearm to the horizontal (J2/J3 interaction)
        n = len([p for p in self.pos if p.startswith("P[")]) + 1
        joints = [f"J{i + 1}= {_num(v)} deg" for i, v in enumerate(fanuc)]
        self.pos += [f"P[{n}]{{", "   GP1:", f"\tUF : {self.uf}, UT : {self.ut},\t", "\t" + ",\t".join(joints[:3]) + ",", "\t" + ",\t".join(joints[3:]), "};"]
        self._statement(f"J P[{n}] 100% {self.term}")

    def raw(self, line: str) -> None:
        self._statement(f"  !{line.replace(';', ',')}")

    def end(self) -> list[str]:
        remarks = [f"{k + 1:4d}:  !{r.replace(';', ',')} ;" for k, r in enumerate(self.remarks)]
        body = remarks + [f"{len(remarks) + int(line[:4]):4d}{line[4:]}" if line[:4].strip() else line for line in self.mn]
        head = ["/PROG  " + self.name, "/ATTR", "OWNER\t\t= MNEDITOR;", "COMMENT\t\t= \"postproc\";", "PROG_SIZE\t= 0;",
                f"LINE_COUNT\t= {sum(1 for line in body if line[:4].strip())};", "PROTECT\t\t= READ_WRITE;", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN"]
        return ["\n".join(head + body + ["/POS"] + self.pos + ["/END", ""])]
