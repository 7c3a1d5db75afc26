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

from postproc.errors import EmitError, InputError, JobError
from postproc.fivex.errormap import GridMap
from postproc.fivex.kinematics import _head_tip, fk, ik, rotary_solutions, table_to_machine
from postproc.fivex.machine import Machine
from postproc.programs import dialects
from postproc.programs.ir import F_EXT, Toolpath
from postproc.robot.frames import axis_to_quat_wxyz

from .offsets import machine_angles, program_to_machine, to_machine, to_program, tool_length
from .program import ROTARY_FIELD, _filled_axis


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


def commanded(controller: Machine, tp: Toolpath, placement: np.ndarray, input_axes: str, tool_length: float = 0.0) -> np.ndarray:
    """(N, 5) machine axes the controller commands for a program's numbers: its rotary words,
    or, for tool-axis vectors, the rotary solution nearest the previous one (the first from 0, 0)."""
    if tp.orientation_kind == "axis":
        axis = np.einsum("nij,nj->ni", placement[:, :3, :3], _filled_axis(tp))
        return ik(controller, to_machine(placement, tp.position), axis, tool_length=tool_length).axes
    cols = [ROTARY_FIELD[n] for n in controller.rotary_names]
    return controller_axes(controller, to_machine(placement, tp.position), tp.ext[:, cols], input_axes, tool_length)


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
    dialects.of(tp).refuse_compensation(tp)  # what a language's text cannot carry as block numbers (Klartext: a tilted plane)
    if tp.orientation_kind == "axis":  # which rotary solution a vector gets is the controller's rule (the dialect states it)
        if dialects.of(tp).controller.vector_solution != "nearest":
            raise InputError(f"{tp.sources[0].path}: tool-axis vectors (I J K) are compensated only where the controller's rotary "
                             "solution rule is known (SINUMERIK: the shorter travel); write rotary angles")
        return _compensate_vectors(tp, true, controller, grid, input_axes)
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
    if tp.ccomp is not None and (tp.ccomp == 1).any():  # under radius compensation the text may hold the contour (Klartext RL / RR)
        return dialects.of(tp).contour_for(moved, xyz)
    return moved.with_positions(xyz)


VECTOR = slice(3, 6)  # the IR's tool-axis vector words (G43.5 I J K, SINUMERIK A3= B3= C3=)


def _compensate_vectors(tp: Toolpath, true: Machine, controller: Machine, grid: GridMap | None, input_axes: str) -> tuple[Toolpath, FiveReport]:
    """Tool tips with tool-axis vectors (in the program's frame; TRAORI with A3= B3= C3=, G43.5):
    the controller turns each vector into the rotary solution nearest the axes' current
    position (840D: the shorter travel); the true machine's axes for the same tip and axis
    are written back as the tip and vector the controller's model turns into those axes."""
    path = tp.sources[0].path
    if input_axes != "tip":
        raise InputError(f"{path}: tool-axis vectors are given with the tool tip (RTCP, TRAORI / G43.5): use --input-axes tip")
    if np.isnan(tp.position).any():
        i = int(np.nonzero(np.isnan(tp.position).any(axis=1))[0][0])
        raise InputError(f"{path}:{int(tp.line[i])}: tool tip position not known at this target")
    placement, length = program_to_machine(tp), tool_length(tp, controller)
    tip = to_machine(placement, tp.position)
    axis = np.einsum("nij,nj->ni", placement[:, :3, :3], _filled_axis(tp))
    _require_one_first_solution(tp, controller, axis[:1])
    nominal = ik(controller, tip, axis, tool_length=length)  # the first block's solution is the only one in the limits (checked above)
    sol = ik(true, tip, axis, start_deg=np.nan_to_num(nominal.axes[0, 3:5]), tool_length=length)
    for result in (nominal, sol):
        if not result.reachable.all():
            i = int(np.nonzero(~result.reachable)[0][0])
            raise JobError(f"{path}:{int(tp.line[i])}: target outside the machine's limits; nothing was written")
    before = np.linalg.norm(actual_tip(true, grid, nominal.axes, length) - tip, axis=1)
    axes = sol.axes.copy()
    if grid is not None:
        axes[:, :3] = _grid_inverse(grid, axes[:, :3], tp.line)
    after = np.linalg.norm(actual_tip(true, grid, axes, length) - tip, axis=1)
    new_tip, new_axis = fk(controller, axes, length)  # what the controller's model must be told to command ``axes``
    again = ik(controller, new_tip, new_axis, start_deg=axes[0, 3:5], tool_length=length).axes[:, 3:5]
    other = np.abs((again - axes[:, 3:5] + 180.0) % 360.0 - 180.0).max(axis=1) > 1e-6
    if other.any():
        i = int(np.nonzero(other)[0][0])
        raise JobError(f"{path}:{int(tp.line[i])}: for the compensated vector the controller would take the other rotary solution; "
                       "nothing was written")
    new = _with_vectors(tp, np.einsum("nji,nj->ni", placement[:, :3, :3], new_axis))
    notes = tuple(grid.notes) if grid is not None else ()
    moved = new.with_positions(to_program(placement, new_tip))
    return moved, FiveReport(tp.line.copy(), before, after, np.linalg.norm(axes[:, :3] - nominal.axes[:, :3], axis=1), notes, placement, length)


def _require_one_first_solution(tp: Toolpath, controller: Machine, first_axis: np.ndarray) -> None:
    """The controller turns the first vector into the rotary solution nearest where the axes
    stand (840D: the shorter travel), which the program does not say: compensated only where
    the machine's limits leave one of the two solutions (else refused with the line, not guessed)."""
    cand, free = rotary_solutions(controller, first_axis)
    ok = ~np.isnan(cand[0]).any(axis=1)
    for i, ax in enumerate(controller.rotary):
        if not ax.periodic:
            ok &= (cand[0, :, i] >= ax.limits[0] - 1e-9) & (cand[0, :, i] <= ax.limits[1] + 1e-9)
    distinct = np.abs((cand[0, 0] - cand[0, 1] + 180.0) % 360.0 - 180.0).max() > 1e-6
    if ok.all() and distinct and not free[0].any():
        raise InputError(f"{tp.sources[0].path}:{int(tp.line[0])}: the first tool-axis vector has two rotary solutions within the machine's "
                         f"limits ({', '.join(f'{v:.3f}' for v in cand[0, 0])} and {', '.join(f'{v:.3f}' for v in cand[0, 1])} deg): the "
                         "controller takes the one nearest where the axes stand, which the program does not say; position the rotary axes "
                         "(angles) before the first vector block")


def _with_vectors(tp: Toolpath, unit_axis: np.ndarray) -> Toolpath:
    """New tool-axis vectors (program frame), each written at the length of the block's own
    vector; a block that keeps the previous vector (no words) cannot change: refused."""
    old = tp.values[:, VECTOR]
    has_words = (tp.spans[:, VECTOR, 1] >= 0).all(axis=1)
    changes = np.abs(unit_axis - _filled_axis(tp)).max(axis=1) > 5e-7
    bad = changes & ~has_words
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        raise EmitError(f"{tp.sources[0].path}:{int(tp.line[i])}: the tool-axis vector changes but the block has no vector words to change "
                        "(write the vector on every five-axis block)")
    values = tp.values.copy()
    values[:, VECTOR] = np.where(has_words[:, None], unit_axis * np.linalg.norm(np.nan_to_num(old), axis=1, keepdims=True), old)
    orientation = tp.orientation.copy()
    orientation[has_words] = axis_to_quat_wxyz(values[has_words, VECTOR])
    return replace(tp, values=values, orientation=orientation)
