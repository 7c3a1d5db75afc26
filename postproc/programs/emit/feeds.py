"""The speed a G-code machine really moves at, from F and the feed rate mode in force.

LinuxCNC manual, "G93, G94, G95 Feed Rate Mode":
- G94 (units per minute): F is the speed; the IR's ``speed`` holds it in mm/min.
- G93 (inverse time): "the F word means the move should be completed in [one divided by
  the F number] minutes", so the move runs at its length x F: a straight move's length, an
  arc's length along the arc. A move with no length (zero, or rotary axes only) has no tool
  speed to give a robot, and is refused.
- G95 (units per revolution): F is mm per spindle revolution, so the speed is F x S; a move
  where S is not known (or 0) is refused.
rs274 prints the same numbers as SET_FEED_RATE for G93 moves (tests/test_feed_modes.py).
The IR's ``speed`` column keeps F as written (times the program's unit in mm), whatever the
mode: the five-axis writer re-emits a G93 F as read.
"""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError

from ..arcs import PLANE_AXES, arc_rows, geometry
from ..ir import Kind, Toolpath

MIN_LENGTH_MM = 1e-9  # a G93 move shorter than this has no tool speed
_F_WORD = re.compile(r"[Ff][ \t]*[-+.\d#\[]")
_COMMENT = re.compile(r"\([^()\n]*\)|;.*")


def machine_speeds(tp: Toolpath) -> np.ndarray:
    """(N,) mm/min each target's move runs at (rapids: the speed column as it is); raises
    EmitError with file:line:column for a G93 or G95 feed move whose speed cannot be known."""
    speeds, why = _speeds(tp)
    bad = np.nonzero(why != "")[0]
    if len(bad):
        i = int(bad[0])
        raise EmitError(f"{where(tp, i)}: {why[i]}")
    return speeds


def describe(tp: Toolpath) -> dict[int, dict]:
    """For ``inspect --json``: per target, its feed mode and, under G93 / G95, F with its
    unit and the derived speed in mm/min (None where it cannot be known, with the reason)."""
    if tp.feed_mode is None:
        return {}
    speeds, why = _speeds(tp)
    out = {}
    for i, mode in enumerate(tp.feed_mode.tolist()):
        entry = {"feed_mode": f"G{mode}"}
        if mode != 94 and tp.kind[i] != Kind.RAPID:
            f = _f_word(tp, i)
            entry["f"] = None if not np.isfinite(f) else round(float(f), 6)
            entry["f_unit"] = "1/min (inverse time)" if mode == 93 else "mm/rev"
            entry["speed_derived_mm_per_min"] = None if why[i] else round(float(speeds[i]), 6)
            if why[i]:
                entry["speed_unknown_because"] = why[i]
        out[i] = entry
    return out


def _speeds(tp: Toolpath) -> tuple[np.ndarray, np.ndarray]:
    """Speeds (N,) mm/min and, per target, why it cannot be known ('' where it can)."""
    speeds = np.asarray(tp.speed, dtype=float).copy()
    why = np.full(len(tp), "", dtype=object)
    if tp.feed_mode is None:
        return speeds, why
    feed = tp.kind != Kind.RAPID
    inverse = feed & (tp.feed_mode == 93)
    if inverse.any():
        length, rotary_only = move_lengths(tp)
        length = _programmed_lengths(tp, length)
        per_min = _f_word(tp, np.arange(len(tp)))
        speeds[inverse] = (length * per_min)[inverse]
        no_start = inverse & np.isnan(length)
        why[no_start] = "a G93 inverse-time move whose start is not known (the first move, or after an unknown position): its speed (length x F) cannot be known"
        short = inverse & ~no_start & (length < MIN_LENGTH_MM)
        why[short & rotary_only] = "a G93 inverse-time move of rotary axes only: it has no tool speed to write for a robot"
        why[short & ~rotary_only] = "a G93 inverse-time move of zero length: it has no tool speed to write for a robot"
        why[inverse & ~(why != "") & ~(per_min > 0)] = "a G93 inverse-time move with F not above 0"
    per_rev = feed & (tp.feed_mode == 95)
    if per_rev.any():
        spindle = np.asarray(tp.spindle, dtype=float) if tp.spindle is not None else np.full(len(tp), np.nan)
        speeds[per_rev] = (tp.speed * spindle)[per_rev]
        why[per_rev & np.isnan(spindle)] = "a G95 feed-per-revolution move with no known spindle speed (S): its speed (F x S) cannot be known"
        why[per_rev & (spindle == 0)] = "a G95 feed-per-revolution move with the spindle speed S0: the machine does not move"
        why[per_rev & ~(why != "") & ~(speeds > 0)] = "a G95 feed-per-revolution move with F not above 0"
    return speeds, why


def move_lengths(tp: Toolpath) -> tuple[np.ndarray, np.ndarray]:
    """(N,) path length (mm) of each target's move from the target before it, in the machine
    frame (arcs along the arc), NaN where the start is not known; and (N,) True where only
    rotary axes (A B C) change."""

    base = tp.base_positions()
    length = np.full(len(tp), np.nan)
    length[1:] = np.linalg.norm(base[1:] - base[:-1], axis=1)
    ext = np.nan_to_num(tp.ext, nan=0.0)
    rotary_only = np.zeros(len(tp), bool)
    rotary_only[1:] = np.any(ext[1:] != ext[:-1], axis=1)
    rows = arc_rows(tp)
    if len(rows):
        length[rows] = np.nan  # only arcs the geometry holds get a length
        geo = geometry(tp)
        if len(geo.rows):
            _, sweep = geo.sweep()
            radius = np.linalg.norm(geo.in_plane(geo.start) - geo.centre, axis=1)
            rise = geo.normal(geo.end) - geo.normal(geo.start)
            length[geo.rows] = np.hypot(radius * np.abs(sweep), rise)  # a helix: along the helix, as LinuxCNC
    return length, rotary_only


def _programmed_lengths(tp: Toolpath, length: np.ndarray) -> np.ndarray:
    """Under cutter radius compensation (G41/G42, ``Toolpath.ccomp`` 1) LinuxCNC times a G93
    move by its programmed length (rs274ngc: the move from the programmed point, not the offset
    one), and the corner arc it adds runs at the rate of the move it belongs to: the lengths
    of those moves, so that length x F is the feed rate the machine runs them at. The
    programmed points are the text's numbers (``values``; a word left out keeps the programmed
    value before it), the arcs' centres their absolute I J (G18: K I). The move after G40
    runs from the programmed point too (rs274: its length from there, times F)."""
    if tp.ccomp is None or not (tp.ccomp == 1).any():
        return length

    own = tp.insert_at[:, 1] >= 0 if tp.insert_at is not None else np.ones(len(tp), bool)
    prog = tp.position.copy()
    out = length.copy()
    for r in np.nonzero(tp.ccomp == 1)[0].tolist():  # compensated moves only (a few per program)
        prev = prog[r - 1] if r > 0 else np.full(3, np.nan)
        if not own[r]:
            prog[r] = prev  # a corner arc: the programmed point stays at the corner
            continue
        prog[r] = np.where(np.isnan(tp.values[r, :3]), prev, tp.values[r, :3])
        if tp.kind[r] in (Kind.ARC_CW, Kind.ARC_CCW):
            first, second, normal = PLANE_AXES[int(tp.arc[r, 0])]  # G17: X Y Z; G18: Z X Y
            centre = tp.values[r, [19 + first, 19 + second]]  # I J (G18: K I): absolute under compensation
            a0 = np.arctan2(prev[second] - centre[1], prev[first] - centre[0])
            a1 = np.arctan2(prog[r, second] - centre[1], prog[r, first] - centre[0])
            turn = a1 - a0 if tp.kind[r] == Kind.ARC_CCW else a0 - a1
            sweep = np.mod(turn, 2 * np.pi) or 2 * np.pi  # the end on the start: a full circle
            out[r] = np.hypot(np.linalg.norm(prog[r, [first, second]] - centre) * sweep, prog[r, normal] - prev[normal])
        else:
            out[r] = np.linalg.norm(prog[r] - prev)
    after = np.nonzero((tp.ccomp[1:] == 0) & (tp.ccomp[:-1] == 1))[0] + 1
    for r in after.tolist():  # the move after G40: from the programmed point too (its start is the offset one)
        out[r] = np.linalg.norm(tp.position[r] - prog[r - 1])
    generated = np.nonzero((tp.ccomp == 1) & ~own)[0]
    for r in generated[::-1].tolist():  # a corner arc: the rate of the next move of its block
        if r + 1 < len(tp) and tp.line[r + 1] == tp.line[r]:
            out[r] = out[r + 1] * (tp.speed[r + 1] / tp.speed[r]) if tp.speed[r] else np.nan
    return out


def _f_word(tp: Toolpath, rows) -> np.ndarray:
    """F as the program writes it (the IR's speed is F times the program unit in mm)."""
    unit = tp.scale[rows, 0]  # G-code: 25.4 under G20, 1 under G21, on every target
    return tp.speed[rows] / unit


def where(tp: Toolpath, i: int) -> str:
    """'file:line:column' of target ``i``: the column of its block's F word, else 1."""
    doc = tp.sources[int(tp.file[i])]
    line_no = int(tp.line[i])
    lines = doc.text.split("\n", line_no)
    text = lines[line_no - 1] if len(lines) >= line_no else ""
    code = _COMMENT.sub(lambda m: " " * len(m.group(0)), text)
    m = _F_WORD.search(code)
    return f"{doc.path}:{line_no}:{m.start() + 1 if m else 1}"
