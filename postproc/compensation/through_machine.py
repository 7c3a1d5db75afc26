"""Compensation of a program for any ``Machine``, asking only the protocol's own methods.

A machine that is not a robot under a fitted error model (a user's gantry, a five-axis
machine in a script, a test double) is compensated by asking the object it is given:

- the targets: the program's tool points in the machine frame (``Toolpath.base_poses``);
- ``inverse``: the axis commands that reach an intended pose under the nominal kinematics;
- ``predict``: where those commands really take the tool (the machine's error model).

The solve is a fixed-point iteration on the commanded pose, vectorised over targets: the
commanded point moves by the predicted error it leaves, ``c <- c - (predict(inverse(c)) - goal)``,
until the residual is under ``tol_mm`` or ``max_iter`` steps have run (a target still off
then fails, with its line). Joint targets and targets given in axis values are not moved.
Circular moves are refused: their centres would have to move with their end points, which
only the robot core fits (``postproc.programs.arcs``).
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError
from postproc.programs.ir import Kind, Toolpath

from .core import Report
from .machine import Machine

_NOT_MOVED = (Kind.ABSJ, Kind.JOINT)
_ARCS = (Kind.ARC_CW, Kind.ARC_CCW, Kind.CIRC_VIA, Kind.CIRC_END)


def compensate_on(machine: Machine, tp: Toolpath, *, tol_mm: float = 0.01, max_iter: int = 25,
                  frames: dict | None = None, tools: dict | None = None) -> tuple[Toolpath, Report]:
    """``tp`` with every Cartesian target moved so that ``machine.predict`` puts the tool on
    the programmed point, and the per-target report (``postproc.compensation.core.Report``)."""
    written = tp
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    rows = np.nonzero(~np.isin(tp.kind, _NOT_MOVED))[0]
    _refuse_what_cannot_be_moved(tp, rows, machine)
    goal = tp.base_poses()[rows]
    commanded = goal.copy()
    commands = machine.inverse(commanded)
    iterations = np.zeros(len(rows), dtype=np.int64)
    error = _predicted_error(machine, commands, goal)
    before = np.linalg.norm(error, axis=1)
    for _ in range(max_iter):
        moving = ~(np.linalg.norm(error, axis=1) < tol_mm) & np.isfinite(error).all(axis=1)
        if not moving.any():
            break
        commanded[moving, :3, 3] -= error[moving]
        commands[moving] = machine.inverse(commanded[moving])
        error[moving] = _predicted_error(machine, commands[moving], goal[moving])
        iterations[moving] += 1
    after = np.linalg.norm(error, axis=1)
    position = tp.position.copy()
    position[rows] = (np.linalg.inv(tp.frames[tp.frame[rows]]) @ commanded)[:, :3, 3]  # back into each target's own frame
    return written.with_positions(position), _report(tp, rows, iterations, before, after, commanded, goal, commands, tol_mm)


def _predicted_error(machine: Machine, commands: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """(M, 3) mm: where the machine really takes the tool for ``commands``, less the goal."""
    return np.asarray(machine.predict(commands), dtype=float).reshape(len(goal), 3) - goal[:, :3, 3]


def _refuse_what_cannot_be_moved(tp: Toolpath, rows: np.ndarray, machine: Machine) -> None:
    """InputError naming the first target that is not placed in the machine frame, or a circular move."""
    unplaced = ~(tp.placed() & ~np.isnan(tp.position).any(axis=1))[rows]
    arcs = np.isin(tp.kind[rows], _ARCS)
    for bad, why in ((unplaced, "cannot be placed in the machine frame (undefined point, frame or tool)"),
                     (arcs, f"a circular move: compensating it for a {machine.kind} would move its end point off its circle "
                            "(only robot compensation fits arc centres)")):
        if bad.any():
            i = int(rows[np.argmax(bad)])
            raise InputError(f"{tp.sources[int(tp.file[i])].path}:{int(tp.line[i])}: {why}")


def _report(tp, rows, iterations, before, after, commanded, goal, commands, tol_mm) -> Report:
    n = len(tp)

    def full(values, fill, dtype):
        out = np.full(n, fill, dtype=dtype)
        out[rows] = values
        return out

    reached = np.isfinite(np.asarray(commands, dtype=float).reshape(len(rows), -1)).all(axis=1)
    return Report(line=tp.line.copy(), compensated=full(True, False, bool), iterations=full(iterations, 0, np.int64),
                  before_mm=full(before, np.nan, float), after_mm=full(after, np.nan, float),
                  correction_mm=full(np.linalg.norm(commanded[:, :3, 3] - goal[:, :3, 3], axis=1), np.nan, float),
                  converged=full(after < tol_mm, True, bool), within_limits=full(reached, True, bool),
                  singular=np.zeros(n, bool), branch_changed=np.zeros(n, bool))
