"""Where a five-axis G-code program's numbers are in the kinematics' frame (issue 12, "G-code
work offsets and tool length").

The five-axis kinematics (kinematics.py) work in the machine frame with both rotary axes at
zero: the rotary axes' points in machines/*.toml are given there. The controller turns a
program point into that frame with the work offset in force (LinuxCNC: machine =
rotate_R(p + G92) + G5x origin, then the kinematics; Fanuc G43.4 / Siemens TRAORI the same
way), so a target is read through its work offset: the one the program sets (G10 L2 / L20,
G92 / G52, G53: the identity), or the one given by name (``Toolpath.with_frames``, CLI
``--frame G54=X,Y,Z,A,0,0``). A work offset neither gives is refused with the target's
file:line:column: reading it as the identity would put the part somewhere else relative to
the rotary axes and every machine-axis number would be wrong.

A G-code work offset moves X Y Z and turns about Z only (G10 L2 R); one given with a tilt is
refused. Its rotary-axis components (G10 L2 / L20 P.. A B C, G92 / G52 A B C, and a G43.1
A B C tool offset) are followed as LinuxCNC applies them: the machine's rotary axis turns to
the programmed angle + the G92 + the G5x + the tool offset's A B C (src/emc/task/emccanon.cc
rotate_and_offset_pos: ``a += g92Offset.a ... a += g5xOffset.a ... a += toolOffset.a``; the
interpreter keeps the programmed angle, dialects/gcode/offsets.py, interp.py). This is
done before the kinematics, in both input modes: with RTCP off the kinematics get the
machine axes; with RTCP on (LinuxCNC TCP kinematics, trtfuncs.c / 5axiskins.c) the
kinematics get the offset world pose, whose X Y Z is the tool tip in the workpiece frame and
whose A B C are the joint angles, so the offset turns the axis (and with it the tool axis
relative to the part) while the tip stays at the programmed point. The angles of a
FivePath are the machine's (an output runs with zero offsets). A rotary offset the program
sets from what its text does not determine is refused; a ``--frame`` (and a G5x the program
never sets) is taken as having none (said in the CLI help).

Tool length: a head machine turns the tool about its pivot, ``gauge_to_tip`` (machine file)
plus the tool length in force above the tip (LinuxCNC 5axiskins: pivot-length + the tool
offset), so its machine axes depend on the length: taken from the program (G49: 0; G43 H
after G10 L1 / L10 sets the entry; G43.1 Z.. the length in the block; G43.2 H.. adds entry
H's length to the one in force: LinuxCNC manual "G43.1", "G43.2") or ``--tool
H1=0,0,LENGTH`` (``--tool G43.1@line5=0,0,LENGTH`` for a G43.2 on a length the program does
not give), one length per program, else refused. On table-table machines the tool tip is the
controlled point under G43 and the length does not enter the kinematics.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError
from postproc.fivex.machine import Machine
from postproc.programs.emit.writer import where
from postproc.programs.ir import Toolpath


def program_to_machine(tp: Toolpath) -> np.ndarray:
    """(N, 4, 4) machine_T_program of every target (its work offset); refused where the program
    does not define the offset, or the offset tilts the tool axis."""
    known = np.ones(len(tp.frames), bool) if tp.frame_known is None else tp.frame_known
    bad = ~known[tp.frame]
    if bad.any():
        i = int(np.argmax(bad))
        name = tp.frame_names[tp.frame[i]].split("+")[0]
        raise InputError(f"{where(tp, i)}: the target is in work offset {name}, which the program does not set (it is on the controller): the "
                         f"five-axis kinematics need where it puts the part relative to the rotary axes; give it with --frame {name}=X,Y,Z,A,0,0 "
                         "(its origin in the machine frame with the rotary axes at zero, mm, and its turn about Z, deg)")
    rz = tp.frames[:, 2, 2]
    tilted = np.abs(rz[tp.frame] - 1.0) > 1e-12
    if tilted.any():
        i = int(np.argmax(tilted))
        raise InputError(f"{where(tp, i)}: work offset {tp.frame_names[tp.frame[i]]} is tilted (it turns about X or Y): a G-code work offset "
                         "turns about Z only; give --frame with B and C zero")
    return tp.frames[tp.frame]


def machine_angles(tp: Toolpath, angles: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """(N, 2) the machine's rotary axes ``names`` (deg): the programmed angles + the A B C work
    offsets in force (tp.rotary_offset); refused with file:line:column where an offset the
    program sets is not known."""
    if tp.rotary_offset is None:
        return angles
    offset = tp.rotary_offset[:, ["ABC".index(k) for k in names]]
    bad = np.isnan(offset).any(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{where(tp, i)}: the rotary axes' work offset (G10 L2 / L20 A B C, G92 / G52 A B C) in force here is set from what the "
                         "program text does not determine: the angle the machine turns to is not known")
    return angles + offset


def to_machine(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Points (N, 3) through per-target transforms (N, 4, 4)."""
    return np.einsum("nij,nj->ni", transform[:, :3, :3], points) + transform[:, :3, 3]


def to_program(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Machine-frame points (N, 3) back into each target's own frame."""
    return np.einsum("nji,nj->ni", transform[:, :3, :3], points - transform[:, :3, 3])


def tool_length(tp: Toolpath, machine: Machine) -> float:
    """The tool length (mm) the head machine's kinematics add to ``gauge_to_tip``; 0 on
    machines without head axes (it does not enter their kinematics)."""
    if not any(r.carrier == "head" for r in machine.rotary):
        return 0.0
    known = np.ones(len(tp.tools), bool) if tp.tool_known is None else tp.tool_known
    bad = ~known[tp.tool]
    if bad.any():
        i = int(np.argmax(bad))
        name = tp.tool_names[tp.tool[i]]
        why = ("which is not followed (a G43.1 / G43.2 offset with an X or Y part: the tool is off the spindle axis; or G43.2 adding a tool the program does not set, "
               "or on a length it does not give)" if name.startswith(("G43.1", "G43.2")) else
               "which the program does not set (it is in the controller's tool table)")
        raise InputError(f"{where(tp, i)}: the target is under tool length {name}, {why}: machine {machine.name} turns the tool about a pivot "
                         f"{machine.gauge_to_tip:g} mm + the tool length above the tip; give it with --tool {name}=0,0,LENGTH")
    tools = tp.tools[tp.tool]
    odd = (np.abs(tools[:, :2, 3]) > 1e-9).any(axis=1) | (np.abs(tools[:, :3, :3] - np.eye(3)) > 1e-12).any(axis=(1, 2))
    if odd.any():
        i = int(np.argmax(odd))
        raise InputError(f"{where(tp, i)}: tool {tp.tool_names[tp.tool[i]]} is given with an X/Y offset or a turn: a five-axis tool length is "
                         "along the spindle only (--tool NAME=0,0,LENGTH)")
    lengths = np.unique(tools[:, 2, 3])
    if len(lengths) > 1:
        i = int(np.argmax(tools[:, 2, 3] != tools[0, 2, 3]))
        raise InputError(f"{where(tp, i)}: the tool length changes here ({tools[0, 2, 3]:g} -> {tools[i, 2, 3]:g} mm): five-axis programs for "
                         f"head machine {machine.name} are read with one tool length; split the program at the tool change")
    return float(lengths[0])
