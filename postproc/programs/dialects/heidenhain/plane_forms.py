"""The orientation each PLANE form defines, as a rotation of the working plane.

Every function returns R (3, 3): its columns are the tilted X, Y and Z (tool axis) axes in
the untilted workpiece system, so a point p of the tilted plane is R p in the workpiece.
Definitions from the TNC 640 User's Manual (Klartext programming), "Tilting the working
plane: PLANE function", by form:
- PLANE SPATIAL SPA SPB SPC: rotations about the fixed (machine-based) X, then Y, then Z:
  R = Rz(SPC) Ry(SPB) Rx(SPA). Cycle 19 with spatial angles is the same ("Cycle 19 WORKING
  PLANE": the angles in the order A, B, C).
- PLANE EULER EULPR EULNU EULROT: precession about Z, nutation about the rotated X, rotation
  about the rotated Z: R = Rz(EULPR) Rx(EULNU) Rz(EULROT).
- PLANE PROJECTED PROPR PROMIN PROROT: the plane's traces on the ZX plane (PROPR, measured as
  SPB turns X) and on the YZ plane (PROMIN, as SPA turns Y); the tilted X is the ZX trace, the
  tool axis the normal of the two traces, then PROROT about the tilted tool axis. With one angle
  zero it is PLANE SPATIAL with the other.
- PLANE VECTOR BX BY BZ NX NY NZ: the base vector is the tilted X, the normal vector the tilted
  tool axis; the TNC normalizes both and, where they are not perpendicular, corrects the base
  vector (the normal vector stays).
- PLANE POINTS P1 P2 P3: P1 to P2 is the tilted X; the tool axis is the right-hand normal of
  P1 P2 and P1 P3 (P3 on the side of positive tilted Y).
- PLANE RELATIV SPA|SPB|SPC: one angle, about the axis of the working plane in force
  (incremental on the active tilt): R = R_active R_axis(angle).
"""

from __future__ import annotations

import numpy as np


class PlaneError(ValueError):
    """A PLANE block's values define no plane (zero or parallel vectors)."""


def rx(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def ry(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def rz(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def spatial(spa: float, spb: float, spc: float) -> np.ndarray:
    return rz(spc) @ ry(spb) @ rx(spa)


def euler(precession: float, nutation: float, rotation: float) -> np.ndarray:
    return rz(precession) @ rx(nutation) @ rz(rotation)


def _frame(x: np.ndarray, z: np.ndarray, what: str) -> np.ndarray:
    """Orthonormal R from a tilted X direction and a tool axis (X corrected onto the plane)."""
    nz = np.linalg.norm(z)
    if nz < 1e-12:
        raise PlaneError(f"{what}: the tool axis (normal) is a zero vector")
    z = z / nz
    x = x - (x @ z) * z
    nx = np.linalg.norm(x)
    if nx < 1e-12:
        raise PlaneError(f"{what}: the base direction is parallel to the normal")
    x = x / nx
    return np.column_stack([x, np.cross(z, x), z])


def projected(propr: float, promin: float, rot: float) -> np.ndarray:
    trace_zx = ry(propr)[:, 0]
    trace_yz = rx(promin)[:, 1]
    return _frame(trace_zx, np.cross(trace_zx, trace_yz), "PLANE PROJECTED") @ rz(rot)


def vector(base: np.ndarray, normal: np.ndarray) -> np.ndarray:
    return _frame(np.asarray(base, float), np.asarray(normal, float), "PLANE VECTOR")


def points(p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> np.ndarray:
    x = np.asarray(p2, float) - p1
    if np.linalg.norm(x) < 1e-12:
        raise PlaneError("PLANE POINTS: points 1 and 2 are the same")
    return _frame(x, np.cross(x, np.asarray(p3, float) - p1), "PLANE POINTS (the three points are on one line)")


def relative(active: np.ndarray | None, axis: str, deg: float) -> np.ndarray:
    turn = {"SPA": rx, "SPB": ry, "SPC": rz}[axis](deg)
    return turn if active is None else active @ turn
