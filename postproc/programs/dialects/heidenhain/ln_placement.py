"""LN blocks on a machine: the rotary positions the TNC turns to for T under M128, and the
text numbers of an LN block whose tip is displaced along N (ln.py for the rules).

Which of the two rotary solutions the TNC takes for T is not stated for LN in the TNC 640
manual's "Three-dimensional tool compensation"; the rule its "Tilting the working plane"
states where the program leaves the choice (no SEQ: "the shortest possible solution" within
the traverse ranges) is taken, step by step from where the axes are: the machine's inverse
kinematics with continuity (fivex.kinematics.ik), which also holds an axis free at the pole.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from postproc.errors import InputError
from postproc.fivex.kinematics import ik

from ...ir import Toolpath

OFFSET, AXIS = "heidenhain.ln_offset", "heidenhain.ln_axis"


def ln_extras(ln_rows: dict, n: int) -> dict:
    """Per target: the tip's offset from the LN block's X Y Z (mm), the LN tool axis under M128 (NaN: none)."""
    offset, axis = np.zeros((n, 3)), np.full((n, 3), np.nan)
    for row, (off, ax) in ln_rows.items():
        offset[row], axis[row] = off, ax
    return {OFFSET: offset, AXIS: axis}


def text_positions(tp: Toolpath, xyz: np.ndarray) -> np.ndarray:
    """The X Y Z the text must hold for tips ``xyz``: an LN block's tip is off its numbers by its offset."""
    offset = tp.extras.get(OFFSET)
    return xyz if offset is None else xyz - offset


def place_ln(tp: Toolpath, machine) -> Toolpath:
    """``tp`` with the rotary positions of LN blocks under M128 (and the blocks after them that
    keep those positions) placed on ``machine``, resolved where nothing else leaves them open."""
    axis = tp.extras.get(AXIS)
    rows = np.nonzero(~np.isnan(axis).any(axis=1))[0] if axis is not None else np.zeros(0, int)
    if not len(rows):
        return tp
    plane = tp.extras.get("heidenhain.plane_line")
    if plane is not None and (plane[rows] > 0).any():
        line = int(tp.line[rows[np.argmax(plane[rows] > 0)]])
        return replace(tp, notes=tp.notes + (f"line {line}: LN under M128 in a tilted working plane: not placed; its targets stay flagged",))
    cols = ["ABC".index(k) for k in machine.rotary_names]
    ext, notes = tp.ext.copy(), list(tp.notes)
    runs = np.split(rows, np.nonzero(np.diff(rows) > 1)[0] + 1)  # consecutive LN blocks: one walk of the inverse kinematics
    placed, kept = np.zeros(len(tp), bool), np.zeros(len(tp), bool)
    for k, run in enumerate(runs):
        start = ext[run[0] - 1, cols] if run[0] > 0 else np.full(2, np.nan)
        if np.isnan(start).any():
            notes.append(f"line {int(tp.line[run[0]])}: LN under M128: the TNC takes the rotary solution nearest where the axes are, which "
                         "the text does not give before this block; its targets stay flagged")
            continue
        frames = tp.frames[tp.frame[run]]
        tips = np.einsum("nij,nj->ni", frames[:, :3, :3], tp.position[run]) + frames[:, :3, 3]
        axes_w = np.einsum("nij,nj->ni", frames[:, :3, :3], axis[run])
        result = ik(machine, tips, axes_w, start, float(tp.tools[tp.tool[run[0]]][2, 3]))
        if (result.branch < 0).any():
            i = int(run[np.argmax(result.branch < 0)])
            raise InputError(f"{tp.sources[0].path}:{int(tp.line[i])}: LN under M128: no rotary position of machine {machine.name} "
                             "within its traverse range turns the tool to T")
        ext[np.ix_(run, cols)] = result.axes[:, 3:5]
        placed[run] = True
        until = runs[k + 1][0] if k + 1 < len(runs) else len(tp)
        kept[run[-1] + 1:until] = _carry(tp, ext, cols, run[-1], until)
    resolved = tp.resolved.copy()
    rows_open = placed | kept
    resolved[rows_open] = tp.extras["heidenhain.resolved_but_plane"][rows_open] & ~np.isnan(ext[np.ix_(rows_open, cols)]).any(axis=1)
    notes = [n for n in notes if "LN under M128 / TCPM" not in n]
    notes.append(f"LN under M128: rotary positions of {machine.name} for T, from where the axes are (the shorter way, TNC 640 manual, PLANE without SEQ)")
    return replace(tp, ext=ext, resolved=resolved, notes=tuple(notes))


def _carry(tp: Toolpath, ext: np.ndarray, cols: list[int], last: int, until: int) -> np.ndarray:
    """Targets last+1..until-1 that keep the rotary positions of LN block ``last`` (modal:
    ln_rotary, not yet programmed again), filled in ``ext``; their mask."""
    span = slice(last + 1, until)
    kept = np.zeros(until - last - 1, bool)
    for c in cols:
        fill = tp.extras["heidenhain.ln_rotary"][span, c] & np.isnan(ext[span, c])
        ext[span, c] = np.where(fill, ext[last, c], ext[span, c])
        kept |= fill
    return kept
