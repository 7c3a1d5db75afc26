"""CIP arcs (circle through an intermediate point) as the plane arcs the IR holds.

SINUMERIK 840D sl Fundamentals (6FC5398-1BP40), "Circular interpolation", "Circular
interpolation with intermediate and end points (CIP)": ``CIP X.. Y.. Z.. I1=.. J1=.. K1=..``
moves on the circle through the start, the intermediate point (I1 J1 K1 for X Y Z, absolute
under G90) and the end point, in that order; the circle's plane is the one of the three
points, whatever G17 / G18 / G19 say. The IR's arcs lie in G17 / G18 / G19: a CIP circle in a
plane parallel to one of them is read as that plane's G2 / G3 (the centre the circumcentre,
the direction the turn start -> intermediate -> end seen from the plane's normal); one in a
tilted plane, or through three points on a line, is refused (``NotRead``).
"""

from __future__ import annotations

import numpy as np

from ...arcs import PLANE_AXES

_PLANE_OF_NORMAL = {2: 17, 1: 18, 0: 19}  # normal along Z: G17 (X, Y); Y: G18 (Z, X); X: G19 (Y, Z)
PARALLEL_TOL = 1e-9  # |sin| of the angle between the circle's normal and the plane's


class NotRead(ValueError):
    """A CIP circle the IR cannot hold (the message says why)."""


def plane_arc(start: np.ndarray, middle: np.ndarray, end: np.ndarray) -> tuple[int, np.ndarray, bool]:
    """(plane G code, centre (3,) with the start's normal coordinate, counter-clockwise) of the
    circle through three points (3,) taken in that order."""
    normal = np.cross(middle - start, end - start)
    size = np.linalg.norm(normal)
    scale = max(np.linalg.norm(middle - start), np.linalg.norm(end - start), 1e-300)
    if size <= 1e-12 * scale**2:
        raise NotRead("CIP: start, intermediate and end point lie on a line (no circle through them)")
    axis = int(np.argmax(np.abs(normal)))
    off_plane = np.delete(normal, axis)
    if np.linalg.norm(off_plane) > PARALLEL_TOL * size:
        raise NotRead("CIP circle in a plane not parallel to G17 / G18 / G19: postproc's arcs lie in those planes")
    plane = _PLANE_OF_NORMAL[axis]
    first, second, _ = PLANE_AXES[plane]
    s, m, e = (np.array([p[first], p[second]]) for p in (start, middle, end))
    # circumcentre: equidistant from s, m, e (two perpendicular bisectors)
    lhs = 2.0 * np.array([m - s, e - s])
    rhs = np.array([m @ m - s @ s, e @ e - s @ s])
    c2 = np.linalg.solve(lhs, rhs)
    centre = np.array(start, dtype=float)
    centre[first], centre[second] = c2
    return plane, centre, bool(normal[axis] > 0)
