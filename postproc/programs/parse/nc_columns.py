"""The per-target columns the NC readers share (G-code, SINUMERIK, Heidenhain), kept in
``Toolpath.extras`` under the family name ``nc.``; no other language has them.

- ``nc.arc`` (N, 3) float: the circle of a G2/G3 (or Heidenhain CC + C, SINUMERIK CIP / CT)
  target: plane (17, 18, 19), IJK absolute (1: G90.1) or incremental from the start (0:
  G91.1), full turns P (1 when absent); NaN on other rows. The centre words themselves are
  the core's ``values`` I J K R (``F_ARC``). Absent: the program has no arc (postproc.programs.arcs
  fits the centres; KRL CIRC and RAPID MoveC circles are CIRC_VIA / CIRC_END targets instead).
- ``nc.feed_mode`` (N,) int8: the feed mode in force at each target: 93 inverse time (F =
  1/minutes of the move), 94 units per minute, 95 units per spindle revolution; ``speed``
  keeps F as written whatever the mode (postproc.programs.emit.feeds turns it into mm/min).
- ``nc.spindle`` (N,) float: the S word in force (rev/min, NaN unknown).
- ``nc.rotary_offset`` (N, 3) float: the A B C offsets in force at each target (G5x origin +
  G92 + G43.1's, deg; NaN where the program sets one from what its text does not determine):
  the machine's rotary axis is at ext's A B C + these (LinuxCNC emccanon.cc
  rotate_and_offset_pos). Absent: no program sets one (all zero).
- ``nc.ccomp`` (N,) int8: cutter radius compensation (G41/G42, Heidenhain RL/RR) at each
  target: 0 none, 1 the position is the offset path the controller cuts (the text's numbers
  are in ``values``; a corner arc the controller adds has none), 2 under a compensation the
  program text does not determine (position as programmed, not resolved). Absent: the
  program has none.

A column no block of a program gives is left out of ``extras`` (``tp.extras.get(name)`` is
None), as the core fields they replace were None.
"""

from __future__ import annotations

import numpy as np

ARC = "nc.arc"
FEED_MODE = "nc.feed_mode"
SPINDLE = "nc.spindle"
ROTARY_OFFSET = "nc.rotary_offset"
CCOMP = "nc.ccomp"

# name -> (dtype, the value of a target whose block gives none, shape of one row)
COLUMNS = {ARC: (float, np.nan, (3,)), FEED_MODE: (np.int8, 94, ()), SPINDLE: (float, np.nan, ()), ROTARY_OFFSET: (float, 0.0, (3,)), CCOMP: (np.int8, 0, ())}


def declare(builder) -> None:
    """Declare the NC columns on a reader's ``postproc.programs.parse.common.Builder`` (each left out
    of the Toolpath where no block gives it)."""
    for name, (dtype, fill, shape) in COLUMNS.items():
        builder.declare_extra(name, dtype, fill, shape, optional=True)
