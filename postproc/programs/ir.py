"""The toolpath IR: a frozen struct of arrays over the motion targets of a program.

The program text is kept (``SourceDoc``, decoded as Latin-1 so that every byte survives
and character offsets are byte offsets); every number the IR took from the text has its
span, so writing back splices new numbers into the original text and nothing else.

Per target (N rows, program order):
- ``kind``: Kind code; ``line``: 1-based line of its motion statement; ``file``: which source
- ``position`` (N, 3) mm and ``orientation`` (N, 4) quaternion w, x, y, z of the target in
  its own frame (work object / base / work offset), NaN where the dialect gives none
- ``joints`` (N, 6) degrees for joint targets, ``ext`` (N, 6) external axes
- ``conf`` (N, 4): ABB cf1, cf4, cf6, cfx or KUKA Status, Turn (NaN when absent)
- ``speed``, ``zone`` (N,): as written (mm/s, mm/min feed, mm), NaN when unknown
- ``tool`` / ``frame`` (N,): indices into ``tools`` (flange_T_tcp) and ``frames``
  (base_T_frame), with their names; ``resolved`` (N,) False where a frame or tool could not
  be evaluated from the program (then the identity was used and the target is flagged)
- ``spans`` (N, FIELDS, 3): (source index, start, end) of each field's number, -1 if none
- ``scale`` (N, FIELDS): IR value = text value x scale (inches, unit changes), and
  ``relative`` (N,) True where the numbers are increments from the previous target (G91)
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import IntEnum

import numpy as np

from postproc.errors import InputError
from postproc.robot.frames import make_transform, quat_wxyz_to_matrix

from . import rotation_forms


class Kind(IntEnum):
    JOINT = 0  # PTP / MoveJ to a Cartesian target
    LINEAR = 1  # LIN / MoveL / G1
    CIRC_VIA = 2  # the auxiliary point of CIRC / MoveC
    CIRC_END = 3
    ABSJ = 4  # a target given in joint values (MoveAbsJ, PTP with E6AXIS)
    RAPID = 5  # G0
    ARC_CW = 6  # G2
    ARC_CCW = 7  # G3


FIELDS = ("x", "y", "z", "o1", "o2", "o3", "o4", "j1", "j2", "j3", "j4", "j5", "j6", "e1", "e2", "e3", "e4", "e5", "e6", "i", "j", "k", "r")
F_POS = slice(0, 3)
F_ORI = slice(3, 7)
F_JOINT = slice(7, 13)
F_EXT = slice(13, 19)
F_ARC = slice(19, 23)  # G-code arc words I J K (mm, as the text gives them: see postproc.programs.arcs) and R
NF = len(FIELDS)


@dataclass(frozen=True)
class SourceDoc:
    path: str
    text: str  # decoded as Latin-1: one character per byte
    role: str = "program"  # what the file is to its dialect: "program", KRL "src"/"dat"/"config", RAPID "pgf"/"module"

    @classmethod
    def read(cls, path, role: str = "program") -> "SourceDoc":
        with open(path, "rb") as fh:
            return cls(str(path), fh.read().decode("latin-1"), role)

    def encode(self) -> bytes:
        return self.text.encode("latin-1")


@dataclass(frozen=True)
class Toolpath:
    dialect: str
    sources: tuple[SourceDoc, ...]
    kind: np.ndarray
    line: np.ndarray
    file: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    orientation_kind: str  # the notation of the orientation numbers: a name in postproc.programs.rotation_forms.FORMS ("quat" RAPID, "abc" KRL, "axis" G-code tool axis, "none", ...)
    joints: np.ndarray
    ext: np.ndarray
    conf: np.ndarray
    speed: np.ndarray
    zone: np.ndarray
    tool: np.ndarray
    frame: np.ndarray
    tools: np.ndarray  # (T, 4, 4) flange_T_tcp
    tool_names: tuple[str, ...]
    frames: np.ndarray  # (F, 4, 4) base_T_frame
    frame_names: tuple[str, ...]
    resolved: np.ndarray
    target_name: tuple[str, ...]  # declaration name of the target ('' for inline literals)
    spans: np.ndarray
    scale: np.ndarray
    relative: np.ndarray
    values: np.ndarray = field(repr=False)  # (N, FIELDS) the numbers as the IR reads them (NaN where absent)
    offset: np.ndarray = field(repr=False, default=None)  # (N, FIELDS): IR value = text value x scale + offset (RAPID Offs)
    offset_span: np.ndarray = field(repr=False, default=None)  # (N, FIELDS, 3): the number the offset was read from, -1 if none
    insert_at: np.ndarray = field(repr=False, default=None)  # (N, 2) (source, offset) where a missing field may be written, -1 if nowhere
    frame_known: np.ndarray = field(repr=False, default=None)  # (F,) False where the program does not define the frame
    tool_known: np.ndarray = field(repr=False, default=None)  # (T,) False where the program does not define the tool
    notes: tuple[str, ...] = ()
    # What only some languages state, per target: {"<dialect>.<what>": (N, ...) array}, e.g. a
    # Fanuc CNT value, a UR blend radius, or the NC family's arc geometry, feed mode, spindle
    # speed, rotary offsets and cutter compensation ("nc.*": postproc.programs.parse.nc_columns). A new language keeps
    # its own here instead of adding a field to the core; ``take`` slices them with the rest.
    extras: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    # What the program states once, not per target: {"<dialect>.<what>": immutable value}, e.g. the
    # loads its declarations and statements give (RAPID tooldata / loaddata / GripLoad, KRL $LOAD),
    # each naming its file, line and column. A value holds no row number: which statement is in
    # force at a target is an ``extras`` column (an index into the fact), so ``take``, a
    # streamed chunk or any other row operation keeps it right without knowing the fact.
    # The parser writes these; a controller reads them (and never the program text).
    facts: dict[str, object] = field(repr=False, default_factory=dict)

    PER_TARGET = ("kind", "line", "file", "position", "orientation", "joints", "ext", "conf", "speed", "zone", "tool", "frame",
                  "resolved", "spans", "scale", "relative", "values", "offset", "offset_span", "insert_at")

    def take(self, rows) -> "Toolpath":
        """The targets ``rows`` (indices or a mask) of this toolpath, with the same sources, frames
        and program-level ``facts`` (row-free: what is in force per target is in ``extras``)."""
        rows = np.asarray(rows)
        if rows.dtype == bool:
            rows = np.nonzero(rows)[0]
        picked = {k: getattr(self, k)[rows] for k in self.PER_TARGET if getattr(self, k) is not None}
        extras = {name: column[rows] for name, column in self.extras.items()}
        return replace(self, **picked, extras=extras, target_name=tuple(self.target_name[i] for i in rows.tolist()))

    def __len__(self) -> int:
        return self.kind.shape[0]

    # ------------------------------------------------------------ frames

    def placed(self) -> np.ndarray:
        """(N,) True where the target's point, frame and tool are all known from the program."""
        ok = self.resolved.copy()
        if self.frame_known is not None:
            ok &= self.frame_known[self.frame]
        if self.tool_known is not None:
            ok &= self.tool_known[self.tool]
        return ok

    def with_frames(self, frames: dict | None = None, tools: dict | None = None) -> "Toolpath":
        """A copy where frames and tools the program leaves undefined are given by name
        (base_T_frame, flange_T_tcp as 4x4); an unknown name is an error naming the known ones."""

        new_frames, new_tools = self.frames.copy(), self.tools.copy()
        frame_known = np.ones(len(self.frames), bool) if self.frame_known is None else self.frame_known.copy()
        tool_known = np.ones(len(self.tools), bool) if self.tool_known is None else self.tool_known.copy()
        for table, names, known, given, what in ((new_frames, self.frame_names, frame_known, frames or {}, "frame"), (new_tools, self.tool_names, tool_known, tools or {}, "tool")):
            for name, transform in given.items():
                exact = [i for i, n in enumerate(names) if n == name]
                # A frame composed on an undefined one (G54+G68.2@line4) is placed with it.
                composed = [i for i, n in enumerate(names) if n.startswith(name + "+") and not known[i]]
                if not exact and not composed:
                    raise InputError(f"the program has no {what} named '{name}' (it has: {', '.join(names)})")
                for i in exact:
                    table[i] = transform
                    known[i] = True
                for i in composed:
                    table[i] = transform @ table[i]  # the unknown base stood in as identity
                    known[i] = True
        return replace(self, frames=new_frames, tools=new_tools, frame_known=frame_known, tool_known=tool_known)

    def target_poses(self) -> np.ndarray:
        """(N, 4, 4) target poses in their own frame (identity rotation where none is given)."""
        rot = np.repeat(np.eye(3)[None], len(self), axis=0)
        has = ~np.isnan(self.orientation).any(axis=1)
        if has.any():
            rot[has] = quat_wxyz_to_matrix(self.orientation[has])
        return make_transform(rot, self.position)

    def base_poses(self) -> np.ndarray:
        """(N, 4, 4) TCP poses in the robot base / machine frame: base_T_frame . frame_T_target."""
        return self.frames[self.frame] @ self.target_poses()

    def flange_poses(self) -> np.ndarray:
        """(N, 4, 4) flange poses in the robot base frame: base_T_tcp . inv(flange_T_tcp)."""
        return self.base_poses() @ np.linalg.inv(self.tools[self.tool])

    def base_positions(self) -> np.ndarray:
        return self.base_poses()[:, :3, 3]

    # ---------------------------------------------------------- editing

    def with_positions(self, position: np.ndarray) -> "Toolpath":
        """A copy with new target positions (N, 3), mm, in each target's own frame."""
        position = np.asarray(position, dtype=float)
        values = self.values.copy()
        values[:, F_POS] = np.where(np.isnan(self.values[:, F_POS]), np.nan, position)
        return replace(self, position=position, values=values)

    def with_orientations(self, orientation: np.ndarray) -> "Toolpath":
        """A copy with new target orientations (N, 4) quaternion w, x, y, z (emitted in the dialect's notation)."""
        orientation = np.asarray(orientation, dtype=float)
        notation = rotation_forms.form(self.orientation_kind)
        values = self.values.copy()
        ori = slice(3, 3 + notation.width)
        if notation.width:
            values[:, ori] = np.where(np.isnan(self.values[:, ori]), np.nan, notation.numbers(orientation, self.values[:, ori]))  # spelled near the text's own
        return replace(self, orientation=orientation, values=values)

    def with_joints(self, joints: np.ndarray) -> "Toolpath":
        joints = np.asarray(joints, dtype=float)
        values = self.values.copy()
        values[:, F_JOINT] = np.where(np.isnan(self.values[:, F_JOINT]), np.nan, joints)
        return replace(self, joints=joints, values=values)
