"""Circular and helical moves (G2/G3 in a plane) as straight segments within a chord tolerance.

A robot program from G-code gets straight moves: each arc becomes the fewest segments
whose sagitta (the largest distance between the arc and a chord) is at most ``tol_mm``;
the segments' end points lie on the arc (the helix), the last one exactly at the arc's end.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError

# The two in-plane axes and the normal axis of G17 / G18 / G19 (indices into X, Y, Z).
PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


def linearise_arc(start: np.ndarray, end: np.ndarray, centre: np.ndarray, clockwise: bool, tol_mm: float, plane: int = 17, where: str = "") -> np.ndarray:
    """(n, 3) points after ``start`` up to ``end`` (included) along the arc about ``centre`` (absolute, mm)."""
    u, v, w = PLANES[plane]
    p0 = np.array([start[u] - centre[u], start[v] - centre[v]])
    p1 = np.array([end[u] - centre[u], end[v] - centre[v]])
    r0, r1 = np.hypot(*p0), np.hypot(*p1)
    if r0 < 1e-9:
        raise InputError(f"{where}: arc of zero radius")
    # The end must lie on the circle; CAM output differs by rounding only (LinuxCNC allows 0.002 mm, 0.1 %).
    if abs(r1 - r0) > max(0.002, 1e-3 * r0):
        raise InputError(f"{where}: arc end is {r1:.4f} mm from the centre but the start {r0:.4f} mm (not one circle)")
    a0, a1 = np.arctan2(p0[1], p0[0]), np.arctan2(p1[1], p1[0])
    sweep = (a0 - a1) if clockwise else (a1 - a0)
    sweep = np.mod(sweep, 2 * np.pi)
    if sweep < 1e-12:
        sweep = 2 * np.pi  # start = end: a full circle
    step = 2 * np.arccos(max(1.0 - tol_mm / r0, -1.0))  # the angle whose chord has sagitta tol_mm
    n = max(int(np.ceil(sweep / step)), 1)
    frac = np.arange(1, n + 1) / n
    ang = a0 + (-1.0 if clockwise else 1.0) * sweep * frac
    r = r0 + (r1 - r0) * frac  # a small radius mismatch is spread along the arc, ending exactly on ``end``
    out = np.empty((n, 3))
    out[:, u] = centre[u] + r * np.cos(ang)
    out[:, v] = centre[v] + r * np.sin(ang)
    out[:, w] = start[w] + (end[w] - start[w]) * frac
    out[-1] = end
    return out
