"""Where the tool tip goes when a tilted plane's rotary axes turn, and the working plane that
rotary-axis positions define, from a five-axis machine's kinematics (fivex.kinematics).

TNC 640 User's Manual, "Tilting the working plane", "Automatic positioning: MOVE/TURN/STAY":
- MOVE turns about the tool tip (it keeps its place on the workpiece); MOVE with DIST d about
  the point d along the tool axis from the tip ("the tool is at the same position relative to
  the workpiece after positioning" where it was d from it);
- TURN, and a block that programs only rotary axes (after STAY or Cycle 19, without M128),
  turns the rotary axes alone: the linear axes stay, so the tip moves with the table or swings
  with the head.
Axis angles (PLANE AXIAL, Cycle 19 as axis angles) tilt the working plane as the machine's
axes at those positions turn the tool against the workpiece: the tilted system is the
machine's X Y Z seen from the workpiece.
"""

from __future__ import annotations

import numpy as np

from postproc.fivex.geometry import rotation
from postproc.fivex.kinematics import fk


def tool_axes(machine, angles_deg: np.ndarray) -> np.ndarray:
    """(N, 3) tool axis in the workpiece frame with the rotary axes at ``angles_deg`` (N, 2)."""
    axes = np.zeros((len(angles_deg), 5))
    axes[:, 3:] = angles_deg
    return fk(machine, axes)[1]


def linear_axes(machine, tip: np.ndarray, angles_deg: np.ndarray, length: float) -> np.ndarray:
    """The linear axis positions that put the tip at ``tip`` (workpiece) with the rotary axes at
    ``angles_deg``: forward kinematics are affine in the linear axes, solved from four evaluations."""
    probe = np.zeros((4, 5))
    probe[1:, :3] = np.eye(3)
    probe[:, 3:] = angles_deg
    out = fk(machine, probe, length)[0]
    return np.linalg.solve((out[1:] - out[0]).T, tip - out[0])


def tip_after_turn(machine, tip: np.ndarray, before_deg: np.ndarray, after_deg: np.ndarray, length: float) -> np.ndarray:
    """The tip (workpiece) after the rotary axes turn from ``before_deg`` to ``after_deg`` with
    the linear axes where they are (TURN, a rotary-only block)."""
    linear = linear_axes(machine, tip, before_deg, length)
    return fk(machine, np.r_[linear, after_deg][None, :], length)[0][0]


def tip_after_move(machine, tip: np.ndarray, before_deg: np.ndarray, after_deg: np.ndarray, dist: float) -> np.ndarray:
    """The tip after MOVE (DIST ``dist``): the centre ``dist`` along the tool axis stays."""
    before, after = tool_axes(machine, np.array([before_deg, after_deg]))
    return tip + dist * (before - after)


def axis_plane(machine, angles_deg: np.ndarray) -> np.ndarray | None:
    """R (3, 3): the working plane the rotary positions ``angles_deg`` (machine.rotary order)
    tilt to, columns the tilted X Y Z in the workpiece frame; None on a machine with a head
    and a table axis (the TNC's reading there is the machine builder's)."""
    turns = [rotation(ax.direction, np.radians([a]))[0] for ax, a in zip(machine.rotary, angles_deg)]
    chain = turns[0] @ turns[1]  # outermost first: the table T = R1 R2, the head H = R1 R2
    if machine.kind == "table-table":
        return chain.T  # the machine's axes seen from the turned table
    if machine.kind == "head-head":
        return chain  # the machine's axes turned with the head
    return None
