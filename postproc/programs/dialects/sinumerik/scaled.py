"""SCALE / MIRROR: the targets read under a scaled or mirrored programmable frame.

The IR's frames are rigid. Under ``rigid @ diag(d) @ p`` (``frames.py``) the reader keeps the
rigid part as the target's frame and puts the axes' factors d into the numbers: the position
is ``d * p`` in the rigid frame, and each axis word's IR scale (IR value = text value x scale)
is multiplied by its factor, so a number written back (compensate) is the text the 840D
scales into the intended point again. An unchanged program stays byte for byte (the text is
never rewritten where a value did not change).

SINUMERIK 840D sl Fundamentals (6FC5398-1BP40), "Programmable scaling factor (SCALE,
ASCALE)": "For circles, the same factor should be used in both axes" (an ellipse is not
defined: an arc whose plane axes have different factors is refused); the radius CR= takes
the plane's factor. "Programmable mirroring (MIRROR, AMIRROR)": under a mirror of one axis
of the plane the control swaps G2 and G3, so the arc the tool runs turns the other way in
the (unmirrored) frame: the target's kind is swapped, its G2/G3 word left as written.

Refused (the 840D's rule is not modelled, or not in the manual): tool orientation (rotary
axis words, A3= vectors, TRAORI) under a scale or mirror; G91 increments, G93 inverse-time
feeds and cutter radius compensation under one; and the
first block after the factors change that leaves out X, Y or Z (which number the 840D keeps
for that axis across the change is not stated).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...arcs import PLANE_AXES, R_
from ...ir import F_ARC, F_POS, Kind, Toolpath
from ...parse.nc_columns import ARC, CCOMP, FEED_MODE


class NotRead(ValueError):
    """A target that cannot be read under its scale or mirror: row, the word to point at, why."""

    def __init__(self, row: int, word: str, message: str):
        super().__init__(message)
        self.row, self.word, self.message = row, word, message


def apply(tp: Toolpath, factors: np.ndarray) -> Toolpath:
    """``tp`` with the axes' factors (N, 3) of each target put into its positions and numbers."""
    if len(factors) != len(tp):
        raise NotRead(0, "", "SCALE / MIRROR in a program whose targets are not one block each (generated moves) is not read")
    rows = np.nonzero((factors != 1.0).any(axis=1))[0]
    _refuse(tp, factors, rows)
    d = factors[rows]
    position, values, scale = tp.position.copy(), tp.values.copy(), tp.scale.copy()
    position[rows] *= d
    values[rows, F_POS] *= d
    scale[rows, F_POS] *= d
    ijk = slice(F_ARC.start, F_ARC.start + 3)
    values[rows, ijk] *= d  # centre offsets (or a CIP's absolute centre): a point's coordinates, scaled as one
    scale[rows, ijk] *= d
    kind, offset = tp.kind.copy(), None if tp.offset is None else tp.offset.copy()
    if offset is not None:
        offset[rows, :3] *= d
        offset[rows, ijk] *= d
    arcs = rows[np.isin(tp.kind[rows], (Kind.ARC_CW, Kind.ARC_CCW))]
    if len(arcs):
        plane = np.array([PLANE_AXES[int(p)][:2] for p in tp.extras[ARC][arcs, 0]], dtype=int).reshape(-1, 2)
        first, second = np.take_along_axis(factors[arcs], plane, axis=1).T
        uneven = np.abs(first) != np.abs(second)
        if uneven.any():
            raise NotRead(int(arcs[uneven][0]), "", "an arc under SCALE with different factors for the two axes of its plane is "
                          "not a circle (840D Fundamentals, SCALE: the same factor in both axes for circles): not read")
        values[arcs, R_] *= np.abs(first)
        scale[arcs, R_] *= np.abs(first)
        swapped = arcs[first * second < 0]  # one axis of the plane mirrored: the 840D swaps G2 / G3
        kind[swapped] = np.where(tp.kind[swapped] == Kind.ARC_CW, Kind.ARC_CCW, Kind.ARC_CW)
    return replace(tp, position=position, values=values, scale=scale, kind=kind, offset=offset)


def _refuse(tp: Toolpath, factors: np.ndarray, rows: np.ndarray) -> None:
    """NotRead at the first target under a scale or mirror whose reading is not the 840D's for sure."""
    oriented = ~np.isnan(tp.values[rows, F_POS.stop : F_ARC.start]).all(axis=1) | ~np.isnan(tp.orientation[rows]).all(axis=1)
    if oriented.any():
        raise NotRead(int(rows[oriented][0]), "", "tool orientation (rotary axes, A3= B3= C3=, TRAORI) under SCALE / MIRROR is not "
                      "read: how the 840D scales or mirrors an orientation is not modelled")
    if tp.relative[rows].any():
        raise NotRead(int(rows[tp.relative[rows]][0]), "", "G91 increments under SCALE / MIRROR are not read (write G90 positions)")
    ccomp = tp.extras.get(CCOMP)
    if ccomp is not None and (ccomp[rows] != 0).any():
        raise NotRead(int(rows[ccomp[rows] != 0][0]), "", "cutter radius compensation under SCALE / MIRROR is not read "
                      "(the 840D swaps G41 / G42 under a mirror and does not scale the radius)")
    feed_mode = tp.extras.get(FEED_MODE)
    if feed_mode is not None and (feed_mode[rows] == 93).any():
        raise NotRead(int(rows[feed_mode[rows] == 93][0]), "F", "G93 inverse-time feed under SCALE / MIRROR is not read (the IR "
                      "keeps the program unit in the axes' scale, which SCALE / MIRROR change)")
    before = np.vstack([np.ones((1, 3)), factors[:-1]])
    changed = (factors != before).any(axis=1) & np.isnan(tp.values[:, F_POS]).any(axis=1) & (tp.kind != Kind.ABSJ)
    if changed.any():
        raise NotRead(int(np.argmax(changed)), "", "the first block after SCALE / MIRROR changes leaves out X, Y or Z: which value "
                      "the 840D keeps for that axis across the change is not modelled; program all three")
