"""Programs as five-axis tool paths: tool tip + tool axis in the workpiece frame, per target.

From the IR (``Toolpath``) of
- five-axis G-code with rotary words: tool tip + rotary angles (``input_axes="tip"``, RTCP
  on: G43.4, TRAORI, LinuxCNC TCP) or machine axes (``"machine"``, RTCP off), turned into
  tip + tool axis with the machine's forward kinematics;
- G-code with tool-axis vectors (G43.5 I J K);
- three-axis G-code (no rotary words, no vectors): the tool along +Z of the workpiece;
- robot programs (RAPID, KRL): the TCP position in the program's work object (RAPID wobj,
  KRL BASE), which becomes the workpiece frame, and the tool axis (tip -> spindle) opposite
  to the TCP's z axis (the tool's z points out of the spindle into the work).
Feeds are mm/min of the tool tip; G93 (inverse time) blocks keep their time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from postproc.errors import InputError
from postproc.fivex.kinematics import fk
from postproc.fivex.machine import Machine
from postproc.programs import dialects
from postproc.programs.ir import Kind, Toolpath
from postproc.robot.frames import axis_to_quat_wxyz

from .offsets import machine_angles, program_to_machine, to_machine, tool_length

ROTARY_FIELD = {"A": 0, "B": 1, "C": 2}  # IR ext columns of the G-code rotary words
_RTCP_ON = re.compile(r"G43\.4|G43\.5|TRAORI|\bM128\b|FUNCTION\s+TCPM", re.IGNORECASE)  # Klartext: M128 / FUNCTION TCPM (dialects/heidenhain)


@dataclass(frozen=True)
class FivePath:
    tip: np.ndarray  # (N, 3) mm, workpiece frame
    axis: np.ndarray  # (N, 3) unit, tip -> spindle
    rapid: np.ndarray  # (N,) bool: positioning move (G0)
    feed: np.ndarray  # (N,) mm/min of the tool tip (NaN for rapids)
    time_min: np.ndarray  # (N,) G93 block time in minutes (NaN where the feed is a rate)
    line: np.ndarray  # (N,) source line
    angles: np.ndarray | None  # (N, 2) the machine's rotary angles (deg): the input's + its A B C work offsets (offsets.machine_angles), else None
    source: str
    notes: tuple[str, ...] = ()
    tool_length: float = 0.0  # mm the head machine's kinematics add to gauge_to_tip (offsets.tool_length)


def inverse_time_rows(tp: Toolpath) -> np.ndarray:
    """(N,) True where the target's block runs in G93 inverse-time mode (the IR's feed_mode;
    dialects without feed modes: none)."""
    if tp.feed_mode is None:
        return np.zeros(len(tp), bool)
    return tp.feed_mode == 93


def _check_kinds(tp: Toolpath) -> None:
    bad = ~np.isin(tp.kind, [Kind.RAPID, Kind.LINEAR, Kind.JOINT])
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: a circular or joint-value move cannot be written as a "
                         "five-axis linear move without changing the path (linearise it in the CAM system)")


def from_toolpath(tp: Toolpath, machine: Machine, input_axes: str | None = None) -> FivePath:
    """The program's targets as tool tip + tool axis in the workpiece frame."""
    if len(tp) == 0:
        raise InputError(f"{tp.sources[0].path}: no motion targets")
    _check_kinds(tp)
    tp = dialects.of(tp).for_machine(tp, machine)  # what the controller decides by its machine (Klartext PLANE: the rotary solution)
    if not tp.placed().all():
        i = int(np.nonzero(~tp.placed())[0][0])
        where = f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}"
        if not dialects.of(tp).machine_program:
            raise InputError(f"{where}: the target's frame or tool is not defined in the program")
    if not tp.resolved.all():  # a target the text does not determine (G28 home, a probe, #<_hal[..]>, cutter compensation)
        i = int(np.argmin(tp.resolved))
        raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: the target's position depends on what the program "
                         "text does not determine (see the notes of `postproc inspect`): it cannot be read as a five-axis path")
    if dialects.of(tp).machine_program:
        return _from_gcode(tp, machine, input_axes)
    frames = np.unique(tp.frame)
    if len(frames) > 1:
        i = int(np.nonzero(tp.frame != tp.frame[0])[0][0])
        raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: the program changes its work object ({tp.frame_names[tp.frame[0]]} -> "
                         f"{tp.frame_names[tp.frame[i]]}); a five-axis program has one workpiece frame")
    poses = tp.target_poses()  # in the work object: the workpiece frame of the five-axis program
    if np.isnan(poses[:, :3, 3]).any():
        i = int(np.nonzero(np.isnan(poses[:, :3, 3]).any(axis=1))[0][0])
        raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: the target has no Cartesian position")
    rapid = tp.kind == Kind.JOINT
    feed = np.where(rapid, np.nan, tp.speed * 60.0)  # robot speeds are mm/s
    _require_feed(tp, rapid, feed)
    return FivePath(poses[:, :3, 3], -poses[:, :3, 2], rapid, feed, np.full(len(tp), np.nan), tp.line.copy(), None, tp.sources[0].path,
                    ("robot joint moves (MoveJ / PTP) are written as rapid positioning moves (G0)",) if rapid.any() else ())


def _from_gcode(tp: Toolpath, machine: Machine, input_axes: str | None) -> FivePath:
    """Tips and axes in the machine frame: each target read through its work offset, the
    head machine's pivot with the program's tool length (offsets.py)."""
    path = tp.sources[0].path
    placement = program_to_machine(tp)
    length = tool_length(tp, machine)
    position = to_machine(placement, tp.position)
    names = machine.rotary_names
    used = [k for k in "ABC" if not np.isnan(tp.ext[:, ROTARY_FIELD[k]]).all()]
    foreign = [k for k in used if k not in names]
    if foreign:
        i = int(np.nonzero(~np.isnan(tp.ext[:, ROTARY_FIELD[foreign[0]]]))[0][0])
        raise InputError(f"{path}:{int(tp.line[i])}: the program moves rotary axis {foreign[0]}; machine {machine.name} has {', '.join(names)}")
    g93 = inverse_time_rows(tp)
    notes = list(tp.notes)
    angles = None
    if tp.orientation_kind == "axis":
        axis = np.einsum("nij,nj->ni", placement[:, :3, :3], _filled_axis(tp))  # I J K are in the program's frame
        tip = position
    elif used:
        angles = np.stack([tp.ext[:, ROTARY_FIELD[k]] for k in names], axis=1)
        unknown = np.isnan(angles).any(axis=1)
        if unknown.any():
            i = int(np.nonzero(unknown)[0][0])
            raise InputError(f"{path}:{int(tp.line[i])}: rotary axis position not known yet (no {' or '.join(names)} word before this move)")
        angles = machine_angles(tp, angles, names)  # + the A B C work offsets: the angles the machine turns to
        notes.append("rotary axes' work offsets (G5x / G92 A B C) that the program does not set are taken as zero, as rs274 starts")
        mode = input_axes or ("tip" if _RTCP_ON.search(tp.sources[0].text) else None)
        if mode not in ("tip", "machine"):
            raise InputError(f"{path}: the program has rotary words but no G43.4 / G43.5 / TRAORI: give --input-axes tip (tool tip + "
                             "rotary angles, RTCP on) or --input-axes machine (machine axes, RTCP off)")
        tip_m, axis = fk(machine, np.c_[position, angles], length)
        tip = position if mode == "tip" else tip_m
    else:
        tip = position
        axis = np.broadcast_to(machine.tool_axis, tip.shape).copy()
        notes.append("no rotary words and no tool-axis vectors: the tool is along the machine's tool axis (three-axis program)")
    if np.isnan(tip).any():
        i = int(np.nonzero(np.isnan(tip).any(axis=1))[0][0])
        raise InputError(f"{path}:{int(tp.line[i])}: tool tip position not known yet (an axis word is missing before this move)")
    rapid = tp.kind == Kind.RAPID
    time_min = np.where(g93 & ~rapid, 1.0 / tp.speed, np.nan)
    dist = np.linalg.norm(np.diff(tip, axis=0, prepend=tip[:1]), axis=1)
    feed = np.where(rapid, np.nan, np.where(g93, dist * tp.speed, tp.speed))
    _require_feed(tp, rapid, feed)
    if (np.abs(placement - np.eye(4)) > 0).any() or (tp.rotary_offset is not None and (tp.rotary_offset != 0).any()):
        notes.append("positions are in the machine frame (the program's work offsets applied): an output runs with a zero work offset")
    return FivePath(tip, axis, rapid, feed, time_min, tp.line.copy(), angles, path, tuple(notes), length)


def _require_feed(tp: Toolpath, rapid: np.ndarray, feed: np.ndarray) -> None:
    bad = ~rapid & ~(np.isfinite(feed) & (feed >= 0))
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: feed move without a known feed rate (no F word / speed before it)")


def _filled_axis(tp: Toolpath) -> np.ndarray:
    """G43.5 tool-axis vectors, modal: a block without I J K keeps the previous vector."""
    ijk = tp.values[:, 3:6].copy()
    has = ~np.isnan(ijk).any(axis=1)
    idx = np.where(has, np.arange(len(tp)), -1)
    np.maximum.accumulate(idx, out=idx)
    if (idx < 0).any():
        i = int(np.nonzero(idx < 0)[0][0])
        raise InputError(f"{tp.sources[0].path}:{int(tp.line[i])}: no tool-axis vector (I J K) given yet")
    v = ijk[idx]
    norm = np.linalg.norm(v, axis=1)
    if (norm < 1e-9).any():
        i = int(np.nonzero(norm < 1e-9)[0][0])
        raise InputError(f"{tp.sources[0].path}:{int(tp.line[i])}: tool-axis vector I J K is zero")
    return v / norm[:, None]


def to_robot_toolpath(tp: Toolpath, path: FivePath) -> Toolpath:
    """The G-code program's IR with robot orientations: the TCP's z axis opposite to the tool
    axis (as the writer's tool-down default), the rotation about it from the base x axis;
    positions the tips in the machine frame (the robot's base; the work offsets are in them);
    speeds the tool tip's mm/min (G93 blocks' times already turned into feeds), so every
    target is per minute (G94): the writer takes the G-code dialect's mm/min to mm/s.
    For writing a robot program from a five-axis one."""


    quat = axis_to_quat_wxyz(-path.axis)
    speed = np.where(path.rapid, np.nan, path.feed)
    per_minute = np.full(len(tp), 94, np.int8)
    machine = dict(frames=np.eye(4)[None], frame_names=("machine",), frame_known=np.ones(1, bool), frame=np.zeros(len(tp), tp.frame.dtype))
    return replace(tp, position=path.tip.copy(), orientation=quat, orientation_kind="quat", speed=speed, feed_mode=per_minute, **machine)
