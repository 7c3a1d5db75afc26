"""KRL: the controller facts a program states, written into the IR by the parser.

The KUKA controller (``controller.py``) reads this column of ``Toolpath.extras``, never the text:

- ``krl.circular_angle`` (N,) bool: the CIRC (or SCIRC) motion ending at the target is given a
  circular angle (``CA``): the robot then runs on past, or stops short of, its end point
  (KUKA System Software 8, 'CIRC ... CA'). False on every other target.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from ...ir import Kind, Toolpath

CIRCULAR_ANGLE = "krl.circular_angle"

_CA = re.compile(r"\bCA\b", re.IGNORECASE)


def with_controller_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with the ``krl.circular_angle`` column in its extras."""
    given = np.zeros(len(tp), dtype=bool)
    arcs = np.nonzero(tp.kind == Kind.CIRC_END)[0]  # only arcs' lines are read (a long program has few)
    if arcs.size:
        lines = [doc.text.split("\n") for doc in tp.sources]
        given[arcs] = [bool(_CA.search(lines[f][n - 1])) if 0 < n <= len(lines[f]) else False
                       for f, n in zip(tp.file[arcs].tolist(), tp.line[arcs].tolist())]
    return replace(tp, extras={**tp.extras, CIRCULAR_ANGLE: given})
