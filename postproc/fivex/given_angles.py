"""The input's own rotary positions, where they reach the tool axis, kept by the writer.

``fivex.emit`` solves every target's machine axes by continuity (the branch nearest the
previous target). Where the input states the rotary positions its controller turns to (a
SINUMERIK CYCLE800 plane: the cycle's ``_DIR`` solution; rotary words of a five-axis program)
and those positions give the target's tool axis, within the machine's limits, they are what the
converted program must write: the other branch reaches the same tip and axis but is not what
the input's machine does (it turns the table the other way round).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .kinematics import IKResult, fk
from .machine import Machine

_AXIS_TOL_RAD = 1e-9  # the input's angles give the tool axis they were read with (fk): equal to rounding


def keep_given(machine: Machine, tip: np.ndarray, axis: np.ndarray, given: np.ndarray | None, result: IKResult,
               tool_length: float = 0.0) -> IKResult:
    """``result`` with the rotary positions ``given`` (N, 2, NaN where none) taken where they
    reach ``axis`` and their linear axes are inside the limits; the linear axes solved for them."""
    if given is None:
        return result
    lo, hi = np.array([ax.limits for ax in machine.rotary], float).T
    ok = ~np.isnan(given).any(axis=1) & np.all((given >= lo - 1e-9) & (given <= hi + 1e-9), axis=1)
    ok &= ~np.isclose(given, result.axes[:, 3:5], rtol=0.0, atol=1e-9).all(axis=1)
    if not ok.any():
        return result
    rows = np.nonzero(ok)[0]
    angles = given[rows]
    base = np.c_[np.zeros((len(rows), 3)), angles]
    origin, reached = fk(machine, base, tool_length)
    unit = axis[rows] / np.linalg.norm(axis[rows], axis=1, keepdims=True)
    same_axis = np.arccos(np.clip(np.einsum("ni,ni->n", reached, unit), -1.0, 1.0)) <= _AXIS_TOL_RAD
    # tip = Q xyz + origin with Q the table's rotation (fk is rigid in the linear axes): xyz = Q^T (tip - origin)
    columns = np.stack([fk(machine, base + np.c_[np.eye(3)[k][None].repeat(len(rows), 0), np.zeros((len(rows), 2))], tool_length)[0] - origin
                        for k in range(3)], axis=2)
    xyz = np.einsum("nji,nj->ni", columns, tip[rows] - origin)
    lin = machine.linear_limits
    inside = np.all((xyz >= lin[:, 0] - 1e-9) & (xyz <= lin[:, 1] + 1e-9), axis=1)
    take = same_axis & inside
    axes, held, error = result.axes.copy(), result.held.copy(), result.axis_error_rad.copy()
    axes[rows[take], :3] = xyz[take]
    axes[rows[take], 3:5] = angles[take]
    held[rows[take]] = False
    error[rows[take]] = 0.0
    reachable = result.reachable.copy()
    reachable[rows[take]] = True
    return replace(result, axes=axes, held=held, reachable=reachable, axis_error_rad=error)
