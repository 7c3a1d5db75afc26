"""Compensating a five-axis G-code program for a machine model (seeds 003, 004).

The controller runs the program with its own (nominal) kinematics; the machine really has
the calibrated rotary axes (``true``) and, optionally, linear-axis errors measured on a
grid (``errormap.GridMap``: actual = commanded + error(commanded)). For every target the
intended tool tip and tool axis are what the program means under the controller's model;
the compensated numbers make the real machine reach them:
machine axes from the calibrated inverse kinematics, then the linear axes corrected for
the grid error by fixed-point iteration, then (for tip programs, RTCP on) turned back into
the tip coordinates the controller must be given to command exactly those axes.
The output differs from the program only in the numbers of the compensated targets.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import dialects
from ..errors import EmitError, InputError, JobError
from ..ir import F_EXT, Toolpath
from .errormap import GridMap
from .kinematics import _head_tip, fk, ik, table_to_machine
from .machine import Machine
from .offsets import machine_angles, program_to_machine, to_machine, to_program, tool_length
from .program import ROTARY_FIELD


@dataclass(frozen=True)
class FiveReport:
    line: np.ndarray
    before_mm: np.ndarray  # tip error of the program as written, on the real machine
    after_mm: np.ndarray  # tip error of the compensated numbers (before rounding into the text)
    correction_mm: np.ndarray  # change of the linear axes
    notes: tuple[str, ...]
    placement: np.ndarray | None = None  # (N, 4, 4) machine_T_program of each target (its work offset, offsets.py)
    tool_length: float = 0.0  # mm, head machines (offsets.tool_length)


def controller_axes(controller: Machine, program_xyz: np.ndarray, angles: np.ndarray, input_axes: str, tool_length: float = 0.0) -> np.ndarray:
    """(N, 5) machine axes the controller commands for the program's numbers (X Y Z in the
    machine frame: the work offsets applied, offsets.to_machine)."""
    if input_axes == "machine":
        return np.c_[program_xyz, angles]
    theta = np.radians(angles)
    offset, _ = _head_tip(controller, theta, tool_length)
    return np.c_[table_to_machine(controller, theta, program_xyz) - offset, angles]


def actual_tip(true: Machine, grid: GridMap | None, axes: np.ndarray, tool_length: float = 0.0) -> np.ndarray:
    """Tool tip the real machine reaches for commanded axes (N, 5)."""
    real = axes.copy()
    if grid is not None:
        real[:, :3] = real[:, :3] + grid.offset(axes[:, :3])
    return fk(true, real, tool_length)[0]


def _grid_inverse(grid: GridMap, want: np.ndarray, lines: np.ndarray, iterations: int = 50) -> np.ndarray:
    """Commanded linear axes c with c + error(c) = want (fixed point; the error's gradient is small)."""
    c = want.copy()
    for _ in range(iterations):
        err = grid.offset(c)
        outside = np.isnan(err).any(axis=1)
        if outside.any():
            shown = ", ".join(str(int(v)) for v in lines[outside][:20])
            raise JobError(f"{outside.sum()} target(s) outside the measured grid {grid.path} (lines {shown}); nothing was written")
        new = want - err
        if np.abs(new - c).max() < 1e-10:
            return new
        c = new
    return c


def compensate_five(tp: Toolpath, true: Machine, controller: Machine, grid: GridMap | None, input_axes: str) -> tuple[Toolpath, FiveReport]:
    """The program's numbers changed so that the real machine reaches what the controller's model means."""
    if not dialects.of(tp).machine_program:
        raise InputError(f"{tp.sources[0].path}: five-axis compensation works on G-code programs")
    if input_axes not in ("tip", "machine"):
        raise InputError("--input-axes: tip (tool tip + rotary angles, RTCP on) or machine (machine axes, RTCP off) is needed")
    if tp.relative.any():
        i = int(np.nonzero(tp.relative)[0][0])
        raise InputError(f"{tp.sources[0].path}:{int(tp.line[i])}: incremental (G91) five-axis blocks are not compensated; write the program in G90")
    refuse = getattr(dialects.of(tp), "refuse_compensation", None)  # what a dialect's text cannot carry as block numbers (Klartext: a tilted plane)
    if refuse is not None:
        refuse(tp)
    names = controller.rotary_names
    cols = [ROTARY_FIELD[n] for n in names]
    angles = tp.ext[:, cols]
    known = ~np.isnan(angles).any(axis=1) & ~np.isnan(tp.position).any(axis=1)
    if not known.all():
        i = int(np.nonzero(~known)[0][0])
        raise InputError(f"{tp.sources[0].path}:{int(tp.line[i])}: tool tip or rotary position not known at this target")
    placement, length = program_to_machine(tp), tool_length(tp, controller)
    programmed = angles
    angles = machine_angles(tp, programmed, names)  # the angles the machine turns to (the A B C work offsets added)
    cmd = controller_axes(controller, to_machine(placement, tp.position), angles, input_axes, length)
    tip, axis = fk(controller, cmd, length)
    before = np.linalg.norm(actual_tip(true, grid, cmd, length) - tip, axis=1)
    sol = ik(true, tip, axis, start_deg=angles[0], tool_length=length)
    if not sol.reachable.all():
        i = int(np.nonzero(~sol.reachable)[0][0])
        raise JobError(f"{tp.sources[0].path}:{int(tp.line[i])}: target outside the machine's limits after compensation; nothing was written")
    axes = sol.axes.copy()
    if grid is not None:
        axes[:, :3] = _grid_inverse(grid, axes[:, :3], tp.line)
    after = np.linalg.norm(actual_tip(true, grid, axes, length) - tip, axis=1)
    machine_xyz = axes[:, :3] if input_axes == "machine" else fk(controller, axes, length)[0]
    new = _with_numbers(tp, to_program(placement, machine_xyz), axes[:, 3:5] - (angles - programmed), cols)  # written in the program's offsets
    notes = tuple(grid.notes) if grid is not None else ()
    if sol.held.any():
        notes += (f"{int(sol.held.sum())} target(s) near the singular pole: a rotary angle was held",)
    return new, FiveReport(tp.line.copy(), before, after, np.linalg.norm(axes[:, :3] - cmd[:, :3], axis=1), notes, placement, length)


def _with_numbers(tp: Toolpath, xyz: np.ndarray, angles: np.ndarray, cols: list[int]) -> Toolpath:
    """The toolpath with new positions and rotary angles; a rotary angle that must change on
    a block without its word (modal) cannot be written in place: refused, naming the line."""
    ext = tp.ext.copy()
    values = tp.values.copy()
    for j, c in enumerate(cols):
        field = F_EXT.start + c
        has_word = tp.spans[:, field, 1] >= 0
        changes = np.abs(angles[:, j] - tp.ext[:, c]) > 5e-7
        bad = changes & ~has_word
        if bad.any():
            i = int(np.nonzero(bad)[0][0])
            raise EmitError(f"{tp.sources[0].path}:{int(tp.line[i])}: the rotary angle changes but the block has no {'ABC'[c]} word to change "
                            "(write every rotary word on every five-axis block)")
        ext[:, c] = angles[:, j]
        values[:, field] = np.where(has_word, angles[:, j], values[:, field])
    moved = replace(tp, ext=ext, values=values)
    contour = getattr(dialects.of(tp), "contour_for", None)  # a dialect whose text holds the contour of a compensated tool path (Klartext RL / RR)
    return contour(moved, xyz) if contour is not None and tp.ccomp is not None and (tp.ccomp == 1).any() else moved.with_positions(xyz)
