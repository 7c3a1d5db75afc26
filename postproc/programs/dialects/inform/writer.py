"""A new INFORM job (.JBI) from the writer events (see postproc.programs.emit.writer).

Every target is a ``///POSTYPE ROBOT`` ``///RECTAN`` position in the robot frame (a frame
the input places its targets in is applied: INFORM jobs cannot define a user frame), X Y Z
with 3 decimals (the controller's 0.001 mm) and Rx Ry Rz with 4 (0.0001 deg). Tools are
numbered in the order the input uses them (``///TOOL n``): the controller's tool files
must hold them. A joint move to a Cartesian position takes the posture its ``///RCONF``
form names, which no other language states in Yaskawa's terms: from an INFORM job it is
written with the job's form, from another language with the form of the joints its controller
takes (``convert --robot``), else refused. A joint target is a ``///PULSE`` position: its
angles in encoder pulses by the robot's ``[pulses]`` (``convert --robot``, a robot file whose
pulse data are the controller's, not estimates), else refused.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import matrix_to_abc

from ...emit.writer import legal_name, short_number
from .pulses import pulses_of_angles

COMMENT_LIMIT = 32  # characters of an INFORM comment (') line


class InformWriter:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "JOB").upper()[:32]
        self.frame_t = np.eye(4)
        self.tool_numbers: dict[str, int] = {}
        self.tool_number = 0
        self.positions: list[tuple[int, tuple | None, str, str]] = []  # (tool number, ///RCONF form or None, numbers, ///POSTYPE)
        self.source = None  # the input's language (postproc.programs.emit.writer.drive sets it)
        self.robot = None  # the robot the job runs on (postproc.programs.write_program sets it with convert --robot)
        self.body: list[str] = []
        self.tags = ""
        self.speed_tag = ""
        self.last: np.ndarray | None = None
        self.last_was_circle = False

    def start(self, name: str) -> None:
        pass

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        self.frame_t = np.asarray(base_T_frame, dtype=float)

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        self.tool_number = self.tool_numbers.setdefault(name, len(self.tool_numbers))

    def speed(self, mm_s: float) -> None:
        self.speed_tag = f" V={short_number(mm_s, 1)}" if np.isfinite(mm_s) and mm_s > 0 else ""

    def zone(self, mm: float) -> None:
        # PL=0: reach the point; a rounding distance maps to no PL level without the
        # controller's parameters, so those points are reached too (no PL tag).
        self.tags = " PL=0" if mm == 0 else ""

    def _position(self, pose: np.ndarray, form: tuple | None = None) -> str:
        base = self.frame_t @ pose
        rz, ry, rx = matrix_to_abc(base[None, :3, :3])[0]  # R = Rz Ry Rx (KUKA A B C)
        numbers = [_fixed(v, 3) for v in base[:3, 3]] + [_fixed(v, 4) for v in (rx, ry, rz)]
        self.positions.append((self.tool_number, form, ",".join(numbers), "ROBOT"))
        return f"C{len(self.positions) - 1:05d}"

    def _move(self, word: str, pose: np.ndarray, form: tuple | None = None) -> None:
        tags = self.speed_tag if word != "MOVJ" else ""  # V= is a TCP speed; VJ= (a % of joint speed) has no source
        self.body.append(f"{word} {self._position(pose, form)}{tags}{self.tags}")
        self.last = pose

    def move_joint(self, pose, conf=None) -> None:
        # conf: the input's own form (an INFORM job), or computed from the joints the input's
        # controller takes (convert --robot); postproc.programs.write_program hands on no other
        if conf is None or not np.isfinite(conf).all():
            raise EmitError("a joint move to a Cartesian target: INFORM's MOVJ takes the posture from the position's ///RCONF form, "
                            f"which the input does not state in Yaskawa's terms (target at {np.round(self.frame_t @ pose, 3)[:3, 3].tolist()} mm); "
                            "give --robot to compute it from the joints, or write the move as a linear one in the input")
        flip, arm, side, turns = (int(v) for v in conf)
        self._move("MOVJ", pose, (flip, arm, side, turns & 1, turns >> 1 & 1, turns >> 2 & 1, 0, 0))
        self.last_was_circle = False

    def move_linear(self, pose, conf=None) -> None:
        self._move("MOVL", pose)
        self.last_was_circle = False

    def move_circular(self, via, end, conf=None) -> None:
        """Three MOVC lines: the start (where the robot is), the via and the end point; a
        zero-length MOVL first where the previous line closed a circle (a run of MOVC is one circle)."""
        if self.last is None:
            raise EmitError("a circular move as the program's first move: its start is not known")
        if self.last_was_circle:
            self._move("MOVL", self.last)
        for pose in (self.last, via, end):
            self._move("MOVC", pose)
        self.last_was_circle = True

    def move_joints(self, q) -> None:
        q = np.asarray(q, float)
        robot = self.robot
        why = ("no robot is given (--robot: a robot file with your controller's [pulses])" if robot is None else
               f"{robot.source_path} has no [pulses] section" if robot.pulses_per_deg is None else
               f"the [pulses] of {robot.source_path} are estimates" if robot.estimates.get("pulses") else None)
        if why is not None:
            raise EmitError(f"a joint target {np.round(q, 4).tolist()} deg: INFORM joint positions are encoder pulses, which need the "
                            f"robot's pulse data: {why}; not written")
        pulses = pulses_of_angles(robot, q[None])[0]
        self.positions.append((self.tool_number, None, ",".join(str(int(v)) for v in pulses), "PULSE"))
        self.body.append(f"MOVJ C{len(self.positions) - 1:05d}{self.tags}")
        self.last = None  # (a joint target's TCP is not a pose of this writer's)
        self.last_was_circle = False

    def raw(self, line: str) -> None:
        self.body.append(f"'{line[:COMMENT_LIMIT - 1]}")

    def end(self) -> list[str]:
        pos = ["/JOB", f"//NAME {self.name}", "//POS", f"///NPOS {len(self.positions)},0,0,0,0,0"]
        tool = form_written = postype = None
        for k, (number, form, numbers, kind) in enumerate(self.positions):
            if number != tool:
                pos.append(f"///TOOL {number}")
                tool = number
            if kind != postype:  # (a form written above pulse positions no longer applies below them)
                pos += [f"///POSTYPE {kind}", "///PULSE" if kind == "PULSE" else "///RECTAN"]
                postype, form_written = kind, None
            if form is not None and form != form_written:  # (a MOVL position keeps the form above it: MOVL does not use it)
                pos.append("///RCONF " + ",".join(map(str, form)))
                form_written = form
            pos.append(f"C{k:05d}={numbers}")
        inst = ["//INST", "///ATTR SC,RW", "///GROUP1 RB1", "NOP", *self.body, "END", ""]
        return ["\r\n".join(pos + inst)]


def _fixed(value: float, decimals: int) -> str:
    """``value`` with exactly ``decimals`` decimals, never '-0.000'."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text
