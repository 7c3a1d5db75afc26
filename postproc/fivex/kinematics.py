"""Vectorised five-axis kinematics with the machine's (possibly calibrated) axis lines.

Machine axes (N, 5): X, Y, Z (mm) and the two rotary angles (deg) in the machine file's
chain order. Forward: the tool tip and the tool axis (tip -> spindle, unit) in the
workpiece frame, which is the machine frame with both rotary axes at zero. Inverse: both
rotary solutions of the tool axis (Paden-Kahan subproblem 2 with the real, possibly
skew and tilted axis directions), the branch chosen by continuity and limits, the
singular pole (tool axis along a rotary axis, where that axis's angle is free) held at
the previous angle and reported, then the linear axes from the tool tip.

Chain (``machine.py``): table axes turn the workpiece about their lines, T = T1 o T2 (T1 on
the bed carries T2); head axes turn the tool about lines through points given relative to
the spindle gauge point, which sits the machine's ``gauge_to_tip`` plus ``tool_length``
above the tip along the tool axis.
The controlled point (X, Y, Z) is the tool tip with both axes at zero (G43 compensation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .geometry import rotate_about_line, rotation, subproblem1, subproblem2
from .machine import Machine

# Per kind, for rotary axis i: which known vector its subproblem-1 pairs with x
# ("t0": the tool axis at zero in the machine frame, "u": the wanted tool axis in the
# workpiece frame) and whether x is the vector turned ("from") or the target ("to").
# Within this angle of the pole a rotary angle is held (as CAM posts do): with calibrated,
# slightly tilted axes a nominally vertical tool is a few 1e-4 rad off the pole, where the
# exact solution would swing the table through tens of degrees for nothing. The tool axis
# error this allows (at most about twice the tolerance) is reported per target.
POLE_TOL_DEG = 0.05

_PAIRS = {
    "table-table": (("t0", True), ("u", False)),  # R1 R2 u = t0: x = R2 u = R1^T t0
    "head-table": (("t0", False), ("u", False)),  # R_h t0 = R_t u = x
    "head-head": (("u", True), ("t0", False)),  # u = R1 R2 t0: x = R2 t0 = R1^T u
}


def _chain(machine: Machine, theta: np.ndarray, carrier: str):
    """(axis, rotation (N,3,3)) of each axis on ``carrier``, in chain order."""
    return [(ax, rotation(ax.direction, theta[:, i])) for i, ax in enumerate(machine.rotary) if ax.carrier == carrier]


def _head_tip(machine: Machine, theta: np.ndarray, tool_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Tool tip offset from the controlled point (N, 3) and the tool axis (N, 3) in the machine frame."""
    n = theta.shape[0]
    t0 = machine.tool_axis
    tool_length = machine.gauge_to_tip + tool_length  # the machine's pivot distance + any extra tool
    tip = np.broadcast_to(-tool_length * t0, (n, 3)).copy()  # relative to the gauge point
    axis = np.broadcast_to(t0, (n, 3)).copy()
    for ax, rot in reversed(_chain(machine, theta, "head")):  # innermost first
        tip = rotate_about_line(tip, rot, ax.point)
        axis = np.einsum("nij,nj->ni", rot, axis)
    return tip + tool_length * t0, axis


def table_to_machine(machine: Machine, theta: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Workpiece points (N, 3) -> machine frame with the table turned by ``theta`` (N, 2) rad."""
    for ax, rot in reversed(_chain(machine, theta, "table")):  # T1(T2(p)): innermost first
        points = rotate_about_line(points, rot, ax.point)
    return points


def fk(machine: Machine, axes: np.ndarray, tool_length: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Machine axes (N, 5) -> tool tip (N, 3) mm and tool axis (N, 3) in the workpiece frame."""
    axes = np.atleast_2d(np.asarray(axes, dtype=float))
    theta = np.radians(axes[:, 3:5])
    offset, axis_m = _head_tip(machine, theta, tool_length)
    tip_m = axes[:, :3] + offset
    for ax, rot in _chain(machine, theta, "table"):  # T^-1 = T2^-1 o T1^-1: outermost first
        rt = np.swapaxes(rot, 1, 2)
        tip_m = rotate_about_line(tip_m, rt, ax.point)
        axis_m = np.einsum("nij,nj->ni", rt, axis_m)
    return tip_m, axis_m


def rotary_solutions(machine: Machine, tool_axis: np.ndarray, singular_tol_deg: float = POLE_TOL_DEG):
    """Both rotary solutions (N, 2 branches, 2 axes) deg of the tool axis (N, 3), NaN where
    the axis cannot be reached, and (N, 2) flags of a free (singular) axis, whose angle is
    then arbitrary (the value given is that of the other branch's computation)."""
    u = np.asarray(tool_axis, dtype=float)
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    n = u.shape[0]
    t0 = np.broadcast_to(machine.tool_axis, (n, 3))
    known = {"t0": t0, "u": u}
    (v0, _), (v1, _) = _PAIRS[machine.kind]
    k0, k1 = machine.rotary[0].direction, machine.rotary[1].direction
    x = subproblem2(k0, k1, known[v0] @ k0, known[v1] @ k1)  # (N, 2, 3)
    angles = np.full((n, 2, 2), np.nan)
    free = np.zeros((n, 2), bool)
    tol = np.radians(singular_tol_deg)
    for i, (vname, x_from) in enumerate(_PAIRS[machine.kind]):
        k, v = machine.rotary[i].direction, known[vname]
        for b in range(2):
            frm, to = (x[:, b], v) if x_from else (v, x[:, b])
            angle, _ = subproblem1(k, frm, to)
            angles[:, b, i] = np.degrees(angle)
        free[:, i] = np.linalg.norm(np.cross(v, k), axis=1) < tol
    return angles, free


@dataclass(frozen=True)
class IKResult:
    axes: np.ndarray  # (N, 5) X Y Z mm, rotary deg (NaN where unreachable)
    branch: np.ndarray  # (N,) 0 / 1, -1 where unreachable
    held: np.ndarray  # (N,) True where a rotary angle was held at the singular pole
    reachable: np.ndarray  # (N,) within all limits
    axis_error_rad: np.ndarray  # (N,) angle between the reached and the wanted tool axis


def ik(machine: Machine, tip: np.ndarray, tool_axis: np.ndarray, start_deg=(0.0, 0.0), tool_length: float = 0.0,
       singular_tol_deg: float = POLE_TOL_DEG) -> IKResult:
    """Machine axes reaching tool tips (N, 3) with tool axes (N, 3), workpiece frame."""
    tip = np.atleast_2d(np.asarray(tip, dtype=float))
    cand, free = rotary_solutions(machine, np.atleast_2d(tool_axis), singular_tol_deg)
    lo = np.array([ax.limits[0] for ax in machine.rotary])
    hi = np.array([ax.limits[1] for ax in machine.rotary])
    periodic = np.array([ax.periodic for ax in machine.rotary])
    lin_ok = np.stack([_linear_ok(machine, tip, np.nan_to_num(cand[:, b]), tool_length) for b in range(2)], axis=1)
    chosen, branch = _choose_kernel(cand, free, lin_ok, lo, hi, periodic, np.asarray(start_deg, dtype=float))
    # A program that starts at the pole takes the free axis where it will be needed first
    # (CAM posts' look-ahead), instead of turning it at speed on the first tilted move.
    settled = np.nonzero(~free.any(axis=1) & (branch >= 0))[0]
    if len(settled) and settled[0] > 0:
        lead = slice(0, settled[0])
        chosen[lead] = np.where(free[lead], chosen[settled[0]], chosen[lead])
    chosen = _resolve_held(machine, np.atleast_2d(tool_axis), chosen, free & (branch >= 0)[:, None], periodic)
    axes = np.full((len(tip), 5), np.nan)
    axes[:, 3:5] = chosen
    ok = branch >= 0
    theta = np.radians(np.nan_to_num(chosen))
    offset, _ = _head_tip(machine, theta, tool_length)
    axes[:, :3] = np.where(ok[:, None], table_to_machine(machine, theta, tip) - offset, np.nan)
    lin = machine.linear_limits
    inside = ok & np.all((axes[:, :3] >= lin[:, 0] - 1e-9) & (axes[:, :3] <= lin[:, 1] + 1e-9), axis=1)
    _, reached = fk(machine, np.nan_to_num(axes), tool_length)
    u = np.atleast_2d(tool_axis) / np.linalg.norm(np.atleast_2d(tool_axis), axis=1, keepdims=True)
    err = np.where(ok, np.arccos(np.clip(np.einsum("ni,ni->n", reached, u), -1.0, 1.0)), np.nan)
    return IKResult(axes, branch, free.any(axis=1) & ok, inside, err)


def _resolve_held(machine: Machine, tool_axis: np.ndarray, chosen: np.ndarray, held: np.ndarray, periodic: np.ndarray) -> np.ndarray:
    """With one axis held, the other's angle that brings the tool axis nearest the wanted one
    (subproblem 1 with the held rotation applied), at the turn nearest the kernel's choice."""
    out = chosen.copy()
    u = tool_axis / np.linalg.norm(tool_axis, axis=1, keepdims=True)
    known = {"t0": np.broadcast_to(machine.tool_axis, u.shape), "u": u}
    for i in (0, 1):
        rows = held[:, i] & ~held[:, 1 - i]
        if not rows.any():
            continue
        j = 1 - i
        (vi, from_i), (vj, from_j) = _PAIRS[machine.kind][i], _PAIRS[machine.kind][j]
        ki, kj = machine.rotary[i].direction, machine.rotary[j].direction
        theta = np.radians(chosen[rows, i])
        rot = rotation(ki, -theta if from_i else theta)
        x = np.einsum("nij,nj->ni", rot, known[vi][rows])  # R(ki, th) x = v  or  R(ki, th) v = x
        frm, to = (x, known[vj][rows]) if from_j else (known[vj][rows], x)
        angle = np.degrees(subproblem1(kj, frm, to)[0])
        if periodic[j]:
            angle = angle + 360.0 * np.round((chosen[rows, j] - angle) / 360.0)
        out[rows, j] = angle
    return out


def _linear_ok(machine: Machine, tip: np.ndarray, angles_deg: np.ndarray, tool_length: float) -> np.ndarray:
    """(N,) the linear axes needed for these rotary angles are inside their limits."""
    theta = np.radians(angles_deg)
    offset, _ = _head_tip(machine, theta, tool_length)
    lin = table_to_machine(machine, theta, tip) - offset
    lim = machine.linear_limits
    return np.all((lin >= lim[:, 0] - 1e-9) & (lin <= lim[:, 1] + 1e-9), axis=1)


@numba.njit(cache=True)
def _choose_kernel(cand, free, lin_ok, lo, hi, periodic, start):
    """Greedy continuity: per target, the branch nearest the previous angles (periodic axes
    taken at the nearest equivalent turn) among those inside the limits; a free axis keeps
    the previous angle (the CAM posts' hold at the pole)."""
    n = cand.shape[0]
    out = np.full((n, 2), np.nan)
    branch = np.full(n, -1, np.int64)
    prev = start.copy()
    val = np.empty(2)
    for i in range(n):
        best = np.inf
        for b in range(2):
            valid = lin_ok[i, b]
            cost = 0.0
            for j in range(2):
                v = prev[j] if free[i, j] else cand[i, b, j]
                if np.isnan(v):
                    valid = False
                    break
                if periodic[j]:
                    v = v + 360.0 * np.round((prev[j] - v) / 360.0)
                    if v > hi[j]:
                        v -= 360.0
                    elif v < lo[j]:
                        v += 360.0
                if v < lo[j] - 1e-9 or v > hi[j] + 1e-9:
                    valid = False
                    break
                val[j] = v
                cost += abs(v - prev[j])
            if valid and cost < best - 1e-12:
                best = cost
                out[i, 0], out[i, 1] = val[0], val[1]
                branch[i] = b
        if branch[i] >= 0:
            prev[0], prev[1] = out[i, 0], out[i, 1]
    return out, branch
