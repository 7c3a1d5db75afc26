"""G2/G3 arc words into the IR: centre words I J K (or R), plane, IJK mode, full turns.

As LinuxCNC reads them (G-code reference, "G2, G3 Arc Feed"): the arc lies in the plane
G17 (XY), G18 (ZX) or G19 (YZ); in centre format the centre is I J K, offsets from the
arc's start under G91.1 (the default) or coordinates under G90.1, a word left out reading
as 0; in radius format R is the radius, negative for an arc of more than 180 degrees. A
centre-format block without any end-point word is a full circle back to the start
(``G2 I5``); a radius-format one cannot be (the controller refuses it, so does the
parser). ``P`` asks for that many turns (default 1).

The IR keeps the words as the text gives them, times the unit scale (mm), in fields
``i j k r`` with their spans; ``Toolpath.arc`` holds plane, IJK mode and turns per row.
postproc.programs.arcs turns them into centres and back.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from ...ir import F_ARC, Toolpath
from .blockwords import AXES

WORDS = "IJKR"  # the parser's letters of the arc words, in IR field order (F_ARC)
_IN_PLANE = {17.0: "IJ", 18.0: "IK", 19.0: "JK"}
_P_WORD = re.compile(r"[Pp][ \t]*([+-]?(?:\d+\.?\d*|\.\d+))?")


def _letter_columns(axes: str) -> list[int]:
    return [axes.index(c) for c in WORDS]


def full_circles(t: dict, arc_blocks: np.ndarray, error_at) -> np.ndarray:
    """(n,) True for the G2/G3 blocks without end-point words that give centre words: full
    circles (the target is where the tool is). A radius-format one is refused."""
    i, j, k, r = _letter_columns(AXES)
    values = t["values"]
    has_centre = ~np.isnan(values[:, [i, j, k]]).all(axis=1)
    radius_only = arc_blocks & ~has_centre & ~np.isnan(values[:, r])
    if radius_only.any():
        b = int(np.nonzero(radius_only)[0][0])
        at = t["spans"][b, r, 0] if t["spans"][b, r, 0] >= 0 else t["offset"][b]
        raise error_at(at, "radius-format arc (R) without an end point: its end would be its start, which no circle of radius R joins")
    return arc_blocks & has_centre


def arc_words(t: dict, rows: np.ndarray, arc_rows: np.ndarray, plane: np.ndarray, ijk_mode: np.ndarray, linear_scale: np.ndarray,
              ir_values: np.ndarray, ir_spans: np.ndarray, scale: np.ndarray, text: str, error_at) -> np.ndarray | None:
    """Arc words of the targets ``rows`` (blocks of ``t``) into IR fields i j k r (in place);
    returns ``Toolpath.arc`` (m, 3), or None when no target is an arc."""
    if not arc_rows.any():
        return None
    cols = _letter_columns(AXES)
    at = np.nonzero(arc_rows)[0]
    blocks = rows[at]
    words = t["values"][blocks][:, cols]
    uvw = ~np.isin(plane[at], list(_ALLOWED))
    if uvw.any():  # rs274: "Cannot do an arc in planes G17.1, G18.1, or G19.1"
        raise error_at(t["offset"][blocks[np.argmax(uvw)]], "an arc in the G17.1, G18.1 or G19.1 plane (LinuxCNC refuses it)")
    _refuse_mixed(t, blocks, words, plane[at], error_at)
    for n, col in enumerate(cols):
        f = F_ARC.start + n
        ir_values[at, f] = words[:, n] * linear_scale[at]
        spans = t["spans"][blocks, col]
        have = spans[:, 0] >= 0
        ir_spans[at[have], f, 0] = 0
        ir_spans[at[have], f, 1:] = spans[have]
        scale[at, f] = linear_scale[at]
    arc = np.full((len(rows), 3), np.nan)
    arc[at, 0] = plane[at]
    arc[at, 1] = (ijk_mode[at] == 90.1).astype(float)
    arc[at, 2] = _all_turns(text, t["offset"][blocks], t["code_end"][blocks])
    return arc


_ALLOWED = {17.0: [True, True, False], 18.0: [True, False, True], 19.0: [False, True, True]}


def _refuse_mixed(t: dict, blocks: np.ndarray, words: np.ndarray, plane: np.ndarray, error_at) -> None:
    """An arc has either centre words of its plane or R, never both, never an off-plane one
    (LinuxCNC refuses `G17 G2 ... K1`)."""
    given = ~np.isnan(words)
    allowed = np.array([_ALLOWED[p] for p in np.unique(plane)])[np.searchsorted(np.unique(plane), plane)]
    both = given[:, 3] & given[:, :3].any(axis=1)
    off = given[:, :3] & ~allowed
    bad = both | off.any(axis=1)
    if not bad.any():
        return
    n = int(np.nonzero(bad)[0][0])
    b, p = blocks[n], plane[n]
    letters = [c for c, g in zip("IJK", (given[n, :3] if both[n] else off[n])) if g]
    if both[n]:
        reason = "an arc takes either a radius (R) or centre words, not both"
    else:
        reason = f"{'/'.join(letters)} is not a centre word of the G{p:g} plane (it takes {' and '.join(_IN_PLANE[p])})"
    col = AXES.index(letters[0])
    at = t["spans"][b, col, 0] if t["spans"][b, col, 0] >= 0 else t["offset"][b]
    raise error_at(at, reason)


def _all_turns(text: str, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """P of each arc block (1 where the block has no P at all: found vectorised)."""
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    p_at = np.nonzero((raw == ord("P")) | (raw == ord("p")))[0]
    maybe = np.searchsorted(p_at, ends) > np.searchsorted(p_at, starts)
    turns = np.ones(len(starts))
    for i in np.nonzero(maybe)[0]:
        turns[i] = _turns(text, int(starts[i]), int(ends[i]))
    return turns


def _turns(text: str, start: int, end: int) -> float:
    """P of an arc block (full turns, 1 when absent; NaN when it is not a plain number)."""
    code = re.sub(r"\([^)]*\)", "", text[start:end])
    found = _P_WORD.search(code)
    if found is None:
        return 1.0
    return float(found.group(1)) if found.group(1) is not None else np.nan


def carry_tool_axis(tp: Toolpath, rows: np.ndarray) -> Toolpath:
    """Arc targets under G43.5 keep the tool axis of the target before them (their I J K
    are the arc's centre, not an axis)."""
    if not rows.any():
        return tp
    orientation = tp.orientation.copy()
    has = ~np.isnan(orientation).any(axis=1)
    idx = np.where(has, np.arange(len(tp)), -1)
    np.maximum.accumulate(idx, out=idx)
    fill = rows & (idx >= 0)
    orientation[fill] = orientation[idx[fill]]
    return replace(tp, orientation=orientation)
