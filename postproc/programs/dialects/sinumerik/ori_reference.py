"""ORIWKS / ORIMKS (orientation reference) for A3= B3= C3= vectors under TRAORI.

SINUMERIK Job Planning programming manual (6FC5398-2BP40), "Orientation axis reference
(ORIWKS, ORIMKS)": "For orientation programming in the workpiece coordinate system using
Euler or RPY angles or an orientation vector, the course of the rotary motion can be set using
ORIMKS/ORIWKS"; with ORIMKS, for an orientation change at a fixed tool tip "linear interpolation
takes place between the rotary axis positions", with ORIWKS "the tool moves in the plane set up
by the start and end vectors". So the vector of a block end is read the same under both (in
the workpiece coordinate system); ORIMKS changes the orientation between block ends, which the
IR (block ends) does not hold: a note says so.
What the manual does not settle is the reference of a vector under ORIMKS in a *rotated* frame
("With active ORIWKS, the surface normal vectors relate to the active frame and rotate when
the frame rotates", said of surface normals, suggests that under ORIMKS they do not): a vector
under ORIMKS where a programmable or swivel frame turns the axes is refused, not guessed.
"""

from __future__ import annotations

import numpy as np

from ...ir import Toolpath

VECTOR = slice(3, 6)  # the IR's tool-axis vector words (A3= B3= C3= read as G43.5 I J K)


def turned_vector_row(tp: Toolpath, machine_reference: np.ndarray) -> int | None:
    """The first target with a vector under ORIMKS (``machine_reference``, per target) whose
    frame is turned against its settable frame, or None."""
    rows = np.nonzero(machine_reference & ~np.isnan(tp.values[:, VECTOR]).all(axis=1))[0]
    if not len(rows):
        return None
    base = settable_frames(tp)[tp.frame[rows]]
    relative = np.linalg.inv(tp.frames[base]) @ tp.frames[tp.frame[rows]]
    turned = ~np.isclose(relative[:, :3, :3], np.eye(3), rtol=0.0, atol=1e-12).all(axis=(1, 2))
    return int(rows[turned][0]) if turned.any() else None


def settable_frames(tp: Toolpath) -> np.ndarray:
    """(F,) each frame's settable frame (the name before the first '+': G54 of G54+FRAME@line3)."""
    index = {name: i for i, name in enumerate(tp.frame_names)}
    return np.array([index.get(name.split("+")[0], i) for i, name in enumerate(tp.frame_names)], dtype=np.int64)
