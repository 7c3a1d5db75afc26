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
refused. Its rotary-axis offsets (G10 L2 A.., G92 A..) add to the A B C words: a program that
sets one is refused (not followed here), and a ``--frame`` is taken as having none (said in
the CLI help).

Tool length: a head machine turns the tool about its pivot, ``gauge_to_tip`` (machine file)
plus the tool length in force above the tip (LinuxCNC 5axiskins: pivot-length + the tool
offset), so its machine axes depend on the G43 H length: taken from the program (G49: 0; G10
L1 / L10 before the G43) or ``--tool H1=0,0,LENGTH``, one length per program, else refused. On
table-table machines the tool tip is the controlled point under G43 and the length does not
enter the kinematics.
"""

from __future__ import annotations

import re

import numpy as np

from ..emit.writer import where
from ..errors import InputError
from ..ir import Toolpath
from .machine import Machine

_ROTARY_OFFSET = re.compile(r"(?<![A-Z])G0*(10|92|52)(?![\d.])[^\n]*?(?<![A-Z])([ABC])\s*[-+.\d#\[]", re.IGNORECASE)


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
    _refuse_rotary_offsets(tp)
    return tp.frames[tp.frame]


def _refuse_rotary_offsets(tp: Toolpath) -> None:
    """G10 / G92 / G52 with an A B C word (comments blanked, one search over the whole text)."""
    for doc in tp.sources:
        code = re.sub(r"\([^)\n]*\)|;[^\n]*", lambda m: " " * len(m.group()), doc.text)
        found = _ROTARY_OFFSET.search(code)
        if found:
            start = code.rfind("\n", 0, found.start(2)) + 1
            line, column = code.count("\n", 0, start) + 1, found.start(2) - start + 1
            raise InputError(f"{doc.path}:{line}:{column}: a work offset on rotary axis {found.group(2).upper()} (G{found.group(1)} "
                             f"with {found.group(2).upper()}) shifts the angles the machine turns to: not followed in five-axis programs; "
                             "write the angles without it")


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
        raise InputError(f"{where(tp, i)}: the target is under tool length {name}, which the program does not set (it is in the controller's tool "
                         f"table): machine {machine.name} turns the tool about a pivot {machine.gauge_to_tip:g} mm + the tool length above the "
                         f"tip; give it with --tool {name}=0,0,LENGTH")
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
