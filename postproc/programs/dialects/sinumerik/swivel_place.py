"""CYCLE800 swivel planes on a five-axis machine: the rotary positions the 840D turns to.

Under a CYCLE800 (without TRAORI) the program's X Y Z are tool-tip positions in the swivelled
frame and the tool stands along the swivel frame's Z: the cycle turns the rotary axes to the
solution ``_DIR`` picks (``swivel.rotary_positions``: SINUMERIK Operating Manual, "Swivel plane
(CYCLE800)", "Direction (minus/plus)"; the direction reference axis is the machine file's first
rotary axis). ``place`` puts those targets where a five-axis reader wants them: the tip in the
settable frame (G54 ...), the rotary positions in the ``ext`` columns of the machine's axes.
What the program leaves open stays flagged with a note: ``_DIR=0`` (the axes stay where they
were), a swivel that is not known, and the targets outside any active swivel plane in a program
that has one (where the rotary axes stand there is not in the text).

``refuse_compensation``: a calibrated machine's error under a swivel plane is corrected by other
rotary positions (the tool axis's tilt on the part), which are the cycle's, computed by the
controller from its angles, not numbers of the blocks: refused with the CYCLE800 line.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from postproc.errors import InputError

from ...ir import Toolpath
from . import swivel
from .ori_reference import settable_frames
from .swivel_rows import STATES

ROTARY_FIELD = {"A": 0, "B": 1, "C": 2}  # the IR's ext columns of the rotary words (G-code reader)


def place(tp: Toolpath, machine) -> Toolpath:
    """``tp`` with the targets of active CYCLE800 planes placed on ``machine`` (see the module)."""
    state = tp.extras.get("sinumerik.swivel_state")
    if state is None or not np.isin(state, (STATES["active"], STATES["unknown"])).any():
        return tp  # no swivel plane (or only deselections): a three-axis program
    line = tp.extras["sinumerik.swivel_line"]
    rotation, direction = tp.extras["sinumerik.swivel_rotation"], tp.extras["sinumerik.swivel_dir"]
    cols = [ROTARY_FIELD[name] for name in machine.rotary_names]
    position, ext, resolved, frame = tp.position.copy(), tp.ext.copy(), tp.resolved.copy(), tp.frame.copy()
    notes = list(tp.notes)
    own_angles = ~np.isnan(tp.ext).all(axis=1) | ~np.isnan(tp.orientation).all(axis=1)
    if own_angles.any():
        notes.append(f"line {int(tp.line[np.argmax(own_angles)])}: rotary words or tool orientation in a program with CYCLE800: "
                     "the swivel planes' rotary positions are not placed (the blocks' own angles are read)")
        return replace(tp, notes=tuple(notes))
    unknown = state == STATES["unknown"]
    if unknown.any():
        notes.append(f"line {int(line[np.argmax(unknown)])}: CYCLE800 whose swivel frame is not known here: the rotary positions "
                     f"are not placed, {int(unknown.sum())} target(s) flagged")
    open_rows = np.isin(state, (STATES["none"], STATES["deselected"]))
    if open_rows.any():
        notes.append(f"line {int(tp.line[np.argmax(open_rows)])}: outside a CYCLE800 swivel plane the program does not say where the "
                     f"rotary axes stand: {int(open_rows.sum())} such target(s) flagged")
    resolved[open_rows | unknown] = False
    base = settable_frames(tp)
    for group in _groups(line, rotation, state == STATES["active"]):
        first = int(group[0])
        where = f"line {int(line[first])}"
        try:
            angles = swivel.rotary_positions(machine, rotation[first], float(direction[first]))
        except swivel.Unknown as exc:
            notes.append(f"{where}: {exc}; its targets stay flagged")
            resolved[group] = False
            continue
        relative = np.linalg.inv(tp.frames[base[tp.frame[group]]]) @ tp.frames[tp.frame[group]]  # swivel @ programmable, per target
        position[group] = np.einsum("nij,nj->ni", relative[:, :3, :3], tp.position[group]) + relative[:, :3, 3]
        frame[group] = base[tp.frame[group]]
        ext[np.ix_(group, cols)] = angles
        shown = " ".join(f"{n}{a:+.4f}" for n, a in zip(machine.rotary_names, angles, strict=True))
        notes.append(f"{where}: CYCLE800 on {machine.name}: the 840D's rotary positions {shown} (_DIR={direction[first]:+g})")
    return replace(tp, position=position, ext=ext, resolved=resolved, frame=frame, notes=tuple(notes))


def refuse_compensation(tp: Toolpath) -> None:
    """InputError naming the first CYCLE800 whose plane has targets (see the module)."""
    state = tp.extras.get("sinumerik.swivel_state")
    if state is None or not (state == STATES["active"]).any():
        return
    at = int(tp.extras["sinumerik.swivel_line"][np.argmax(state == STATES["active"])])
    raise InputError(f"{tp.sources[0].path}:{at}: targets in a CYCLE800 swivel plane are not compensated: the 840D turns the rotary "
                     "axes to positions the cycle computes from its angles, and the block numbers (X Y Z in the swivel frame) move "
                     "only the linear axes: they could put the tips right but not the tool axis's tilt on the part, which needs other "
                     "cycle angles (and the rotary solution with them); convert the program to TRAORI (convert --to sinumerik "
                     "--machine M --input-axes tip) and compensate that")


def _groups(line: np.ndarray, rotation: np.ndarray, active: np.ndarray) -> list[np.ndarray]:
    """Rows of each swivel plane: the same CYCLE800 line and rotation (a call run again with
    other values, in a loop, is a plane of its own)."""
    rows = np.nonzero(active)[0]
    if not len(rows):
        return []
    keys = np.c_[line[rows], np.round(rotation[rows].reshape(len(rows), 9), 12)]
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    return [rows[inverse.reshape(-1) == k] for k in range(inverse.max() + 1)]
