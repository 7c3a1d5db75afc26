"""RL / RR radius compensation: the tool-centre path the TNC cuts beside the programmed contour.

TNC 640 User's Manual (Klartext / DIN/ISO, 34059x-05), section 5.3 "Tool compensation":
- "Tool radius compensation": RL keeps the tool left of the contour in the direction of
  travel, RR right; the compensation value is the tool's radius R (TOOL DEF in the program or
  the tool table) + DR of TOOL CALL (+ DR of the tool table: a TOOL DEF tool has no table
  row). It "becomes effective as soon as a tool is called and is moved with a straight line
  block in the working plane with RL or RR"; "You cannot activate radius compensation in a
  circle block"; R0 ends it (the tool centre then moves to the programmed coordinates);
  between RL and RR blocks "you must program at least one traversing block ... with R0".
- "Radius compensation: Machining corners": "Outside corners: ... the TNC moves the tool
  around outside corners on a transitional arc"; "Inside corners: The TNC calculates the
  intersection of the tool center paths ... From this point it then starts the next contour
  element."
These are the rules LinuxCNC's G41 / G42 follow (arc about the programmed corner outside, the
offset paths' intersection inside, the entry move ending one radius beside its end,
perpendicular to it; the move after R0 / G40 going from the compensated point to its
programmed end), so the geometry is postproc.programs.dialects.gcode.cutter_comp's. Where the TNC
differs it is handled here: an outside corner after an FMAX move is a transitional arc too
(LinuxCNC traverses straight after G0), and the TNC refuses what LinuxCNC would not meet
(compensation opened in a circle block, RL straight to RR).

The IR keeps, as for G-code (``Toolpath.ccomp``): position = the tool-centre path, values =
the text's numbers (the contour); a transitional arc is a target without a block of its own.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from postproc.errors import EmitError, ParseError

from ...ir import F_ARC, Kind, Toolpath
from ...parse.common import LineIndex
from ..gcode.cutter_comp import CutterComp, Unfollowed

_ARC_KINDS = (int(Kind.ARC_CW), int(Kind.ARC_CCW))
# Toolpath.extras of a program read with RL / RR: the programmed point of each target (the
# contour), True on the transitional arcs the TNC adds, the side and radius in force.
CONTOUR, CORNER, SIDE, RADIUS = "heidenhain.contour", "heidenhain.corner", "heidenhain.comp_side", "heidenhain.comp_radius"
MAX_PASSES = 50
CONVERGED_MM = 1e-7
WRITE_TOLERANCE_MM = 5e-4  # the writer's tolerance for positions (emit.splice.TOLERANCE)


class _Run:
    """One stretch of compensation (RL or RR up to R0 / the end): rows in, path moves out."""

    def __init__(self, tp: Toolpath, side: int, radius: float, start: list):
        self.tp = tp
        self.path = CutterComp(side, radius, 1.0, prog=list(start))  # mm, so rs274's tolerances in mm

    def feed(self, r: int) -> None:
        tp = self.tp
        end = [float(v) for v in tp.position[r]]
        # FMAX moves go through the geometry as feed moves: the TNC rounds their outside corners too
        motion = {int(Kind.ARC_CW): 2, int(Kind.ARC_CCW): 3}.get(int(tp.kind[r]), 1)
        if motion == 1:
            self.path.straight(r, 1, end, {})
        else:
            centre = (float(tp.values[r, F_ARC.start]), float(tp.values[r, F_ARC.start + 1]))
            self.path.arc(r, motion, end, centre, {})


def follow(tp: Toolpath, side: np.ndarray, radius: np.ndarray) -> Toolpath:
    """The toolpath with each RL / RR stretch of known radius as the TNC cuts it: positions on
    the offset path, transitional arcs added as targets; stretches it cannot follow stay as
    programmed, flagged, with the line and the reason in the notes."""
    n = len(tp)
    out_rows: list[int] = []  # source row of each output target
    out_pos: list = []  # (x, y, z) or None: keep the row's own
    out_gen: list = []  # (kind, centre) of a transitional arc, else None
    ccomp = np.zeros(n, np.int8)
    notes = list(tp.notes)
    lines = LineIndex(tp.sources[0].text)
    r = 0
    while r < n:
        s = int(side[r])
        if s == 0 or math.isnan(radius[r]):
            r += 1
            continue
        first = r
        while r < n and side[r] == s:
            r += 1
        _check_stretch(tp, side, first, r, lines)
        stretch = range(first, r)
        if radius[first] == 0.0:  # no offset: the contour itself (T0 or R+DR = 0)
            continue
        start = [float(v) for v in tp.position[first - 1]] if first > 0 else [math.nan] * 3
        try:
            if any(math.isnan(v) for v in start[:2]):
                raise Unfollowed("the tool's position before the compensation is not known")
            if not tp.resolved[first:r].all():  # a value from the control, a cycle's moves: the contour itself is not known
                raise Unfollowed(f"the contour is not determined by the text at line {int(tp.line[first + int(np.argmin(tp.resolved[first:r]))])}")
            run = _Run(tp, s, float(radius[first]), start)
            for i in stretch:
                run.feed(i)
            moves = run.path.off()  # R0 / the end: the pending moves end where they stand
        except (Unfollowed, ValueError, ZeroDivisionError) as exc:
            notes.append(f"line {int(tp.line[first])}: radius compensation {'RL' if s > 0 else 'RR'}: {exc}; the targets up to R0 are flagged (positions as programmed)")
            ccomp[first:r] = 2
            continue
        ccomp[first:r] = 1
        _place(moves, out_rows, out_pos, out_gen)
    return _rebuild(tp, ccomp, out_rows, out_pos, out_gen, notes, side, radius)


def _check_stretch(tp: Toolpath, side: np.ndarray, first: int, end: int, lines: LineIndex) -> None:
    """What the TNC refuses: compensation opened in a circle block, RL straight to RR."""
    if int(tp.kind[first]) in _ARC_KINDS:
        raise _error(tp, lines, first, "radius compensation cannot be opened in a circle block: open it in a straight-line block "
                     "(TNC 640 manual, 5.3 Tool compensation)")
    if end < len(tp) and side[end] == -side[first]:
        raise _error(tp, lines, end, "RL and RR need a block with R0 between them (TNC 640 manual, 5.3 Tool compensation)")


def _error(tp: Toolpath, lines: LineIndex, row: int, message: str) -> ParseError:
    """A ParseError at the RL / RR word of the row's line (its first column if not found)."""
    text = tp.sources[0].text.upper()
    line = int(tp.line[row])
    begin = int(lines.starts[line - 1])
    stop = text.find("\n", begin)
    stop = len(text) if stop < 0 else stop
    found = [p for p in (text.find(k, begin, stop) for k in (" RL", " RR")) if p >= 0]
    return lines.error(tp.sources[0].path, min(found) + 1 if found else begin, message)


def _place(moves: list, out_rows: list, out_pos: list, out_gen: list) -> None:
    """The path moves of one stretch: source row, end (x, y, z), (kind, centre x, centre y) of an added arc (NaN: a block's own move)."""
    for o in moves:
        out_rows.append(o.row)
        out_pos.append(tuple(o.end))
        out_gen.append((int(Kind.ARC_CW) if o.motion == 2 else int(Kind.ARC_CCW), *o.centre) if o.generated else (np.nan, np.nan, np.nan))


def _rebuild(tp: Toolpath, ccomp: np.ndarray, out_rows: list, out_pos: list, out_gen: list, notes: list, side: np.ndarray, radius: np.ndarray) -> Toolpath:
    """The toolpath in execution order with the compensated stretches' moves in place of their
    rows (the moves come out in row order: a transitional arc just before its row's own move)."""
    n = len(tp)
    out_rows_a = np.asarray(out_rows, np.int64)
    count = np.ones(n, np.int64)
    followed = ccomp == 1
    count[followed] = np.bincount(out_rows_a, minlength=n)[followed]
    order = np.repeat(np.arange(n), count)
    new = tp.take(order)
    slots = np.nonzero(ccomp[order] == 1)[0]  # the output targets that are path moves, in the order they came out
    gen = np.asarray(out_gen, float).reshape(-1, 3)
    added = slots[~np.isnan(gen[:, 0])]
    position, kind, values = new.position.copy(), new.kind.copy(), new.values.copy()
    position[slots, :2] = np.asarray(out_pos, float).reshape(-1, 3)[:, :2]  # the tool axis coordinate stays the block's own
    kind[added] = gen[~np.isnan(gen[:, 0]), 0].astype(kind.dtype)  # a transitional arc: no words of its own, its centre the programmed corner
    values[added] = np.nan
    values[added, F_ARC.start:F_ARC.start + 2] = gen[~np.isnan(gen[:, 0]), 1:]
    spans, insert_at = new.spans.copy(), new.insert_at.copy()
    spans[added], insert_at[added] = -1, -1
    arc = new.arc.copy() if new.arc is not None else np.full((len(new), 3), np.nan)
    arc[added] = (17, 1, 1)
    corner = np.zeros(len(new), bool)
    corner[added] = True
    resolved = new.resolved & (ccomp[order] != 2)
    has_arc = np.isin(kind, _ARC_KINDS).any()
    extras = dict(new.extras, **{CONTOUR: new.position.copy(), CORNER: corner, SIDE: side[order], RADIUS: radius[order]})
    return replace(new, position=position, kind=kind, values=values, spans=spans, insert_at=insert_at, resolved=resolved,
                   arc=arc if has_arc else new.arc, ccomp=ccomp[order], notes=tuple(notes), extras=extras)


def contour_for(tp: Toolpath, xyz: np.ndarray) -> Toolpath:
    """``tp`` (read with RL / RR) with the tool-centre path moved to ``xyz`` (N, 3), written as
    the programmed contour that puts it there: the text holds the contour, and the TNC offsets
    it again, so each compensated block's point is moved until the offset path of the new
    contour lands on ``xyz`` (a few fixed-point passes: the offset is a translation along each
    side's normal). Refused (EmitError, with the line) where no contour does: a transitional
    arc's ends are fixed by its corner, and two ends of one corner moved apart are not a
    number rewrite."""
    xyz = np.asarray(xyz, float)
    comp = tp.ccomp == 1
    own, corner = comp & ~tp.extras[CORNER], tp.extras[CORNER]
    contour = tp.extras[CONTOUR].copy()
    contour[~comp] = xyz[~comp]  # outside compensation the text holds the tool path itself
    contour[own, 2] = xyz[own, 2]  # the offset is in the working plane: Z as it is
    before = tp.take(~corner)
    side, radius = before.extras[SIDE], before.extras[RADIUS]
    for _ in range(MAX_PASSES):
        offset = follow(replace(before, position=contour[~corner]), side, radius)
        if len(offset) != len(tp) or (offset.ccomp != tp.ccomp).any():
            return _refuse(tp, int(np.argmax(offset.ccomp == 2)) if len(offset) == len(tp) else int(np.argmax(comp)),
                           "the moved contour changes the offset path's shape (a corner turns or the tool no longer fits)")
        miss = xyz - offset.position
        miss[~comp] = 0.0
        if np.abs(miss).max() < CONVERGED_MM:
            break
        contour[own, :2] += miss[own, :2]
    off = np.linalg.norm(miss, axis=1)
    if off.max() > WRITE_TOLERANCE_MM:
        return _refuse(tp, int(np.argmax(off)), f"no programmed contour puts the tool centre there (off by {off.max():.4f} mm): the "
                       "corrections differ along one corner's transitional arc")
    _require_words(tp, own, contour)
    values = tp.values.copy()
    values[:, :3] = np.where(np.isnan(tp.values[:, :3]), np.nan, contour)
    return replace(tp, position=xyz.copy(), values=values, extras=dict(tp.extras, **{CONTOUR: contour}))


def _require_words(tp: Toolpath, own: np.ndarray, contour: np.ndarray) -> None:
    """A compensated block whose contour point moves must write X and Y itself: a word added
    there would be written from the tool path (the writer's rule for modal axes), not the contour."""
    moved = own & (np.abs(contour[:, :2] - tp.extras[CONTOUR][:, :2]) > 1e-9).any(axis=1)
    lacking = moved & np.isnan(tp.values[:, :2]).any(axis=1)
    if lacking.any():
        _refuse(tp, int(np.argmax(lacking)), "the block's point moves but it does not write both X and Y (modal), and no word is added "
                "to a compensated block; write X and Y on every RL / RR block")


def _refuse(tp: Toolpath, row: int, why: str):
    raise EmitError(f"{tp.sources[0].path}:{int(tp.line[row])}: under RL / RR radius compensation the text holds the contour, which the TNC "
                    f"offsets by the tool radius: {why}; nothing was written")
