"""What the Klartext reader's parts share: the IR fields of the words, the per-target columns."""

from __future__ import annotations

import numpy as np

from ...ir import F_EXT, FIELDS

COLUMNS = 16  # per target: kind, line, feed, tool, frame, resolved, insert offset, X Y Z A B C, TCPM on,
# radius compensation side (+1 RL, -1 RR, 0 R0), its radius (mm, NaN: not in the program)
AXES = {"X": 0, "Y": 1, "Z": 2, "A": F_EXT.start, "B": F_EXT.start + 1, "C": F_EXT.start + 2}
R_FIELD = FIELDS.index("r")
SIDE = {"R0": 0, "RL": 1, "RR": -1}  # TNC 640 manual, 5.3: RL the tool left of the contour (as LinuxCNC G41), RR right


def along_z(length: float) -> np.ndarray:
    """A tool transform: the tip ``length`` mm along the spindle."""
    t = np.eye(4)
    t[2, 3] = length
    return t


def translation(v) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = v
    return t
