"""What the controller does between targets, and how far the robot strays from the path.

A controller interpolates the commanded TCP: a straight line for LIN / MoveL / G1, the
circle through start, auxiliary and end point for CIRC / MoveC (KUKA KSS and ABB RAPID
both define the arc by those three points), orientation by the shortest rotation from the
start to the end orientation. Compensation moves the commanded targets; between them the
robot follows the interpolated commands, so the predicted actual path can leave the
intended one even where every target is exact. These functions sample the commanded
segment, and measure the distance of predicted actual points from the intended segment or
arc (distance to the geometric path, not to a point at the same time: the path is what is
cut).
"""

from __future__ import annotations

import numpy as np

from postproc.robot.posture import interpolate_poses

SAMPLES = 8  # interior samples per segment


def fractions(samples: int = SAMPLES) -> np.ndarray:
    """Interior parameters (0, 1) of a segment's samples."""
    return np.linspace(0.0, 1.0, samples + 2)[1:-1]


def linear_samples(start: np.ndarray, end: np.ndarray, samples: int = SAMPLES) -> np.ndarray:
    """Commanded TCP poses along straight segments: (M, 4, 4) x 2 -> (M, K, 4, 4)."""
    return interpolate_poses(start, end, fractions(samples))


def circle_through(a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Centre (M, 3), unit normal (M, 3) and radius (M,) of the circles through three points
    (rows of a, b, c); the normal follows a -> b -> c."""
    ab, ac = b - a, c - a
    normal = np.cross(ab, ac)
    nn = np.einsum("ij,ij->i", normal, normal)
    centre = a + (np.cross(normal, ab) * np.einsum("ij,ij->i", ac, ac)[:, None]
                  + np.cross(ac, normal) * np.einsum("ij,ij->i", ab, ab)[:, None]) / (2.0 * nn[:, None])
    radius = np.linalg.norm(a - centre, axis=1)
    return centre, normal / np.sqrt(nn)[:, None], radius


def arc_samples(start: np.ndarray, via: np.ndarray, end: np.ndarray, samples: int = SAMPLES) -> np.ndarray:
    """Commanded TCP poses along circular segments (start, auxiliary, end poses (M, 4, 4)):
    positions on the circle through the three points from start to end (through via),
    orientation interpolated from start to end."""
    return arc_at(start, via, end, fractions(samples))


def arc_at(start: np.ndarray, via: np.ndarray, end: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Commanded TCP poses (M, K, 4, 4) at fractions ``t`` (K,) of the sweep of circular
    segments (start, auxiliary, end poses (M, 4, 4)), as ``arc_samples``."""
    p0, p1, p2 = start[:, :3, 3], via[:, :3, 3], end[:, :3, 3]
    centre, normal, _ = circle_through(p0, p1, p2)
    u = p0 - centre
    v = np.cross(normal, u)
    sweep = _angle_around(p2 - centre, u, v)
    angle = sweep[:, None] * t[None, :]
    pos = centre[:, None] + np.cos(angle)[..., None] * u[:, None] + np.sin(angle)[..., None] * v[:, None]
    poses = interpolate_poses(start, end, t)
    poses[..., :3, 3] = pos
    return poses


def _angle_around(w: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle (0, 2 pi] of w from u in the plane spanned by u and v = n x u (|u| = |v|)."""
    ang = np.arctan2(np.einsum("ij,ij->i", w, v), np.einsum("ij,ij->i", w, u))
    return np.where(ang <= 0.0, ang + 2.0 * np.pi, ang)


def distance_to_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points (M, K, 3) from the straight segments a -> b (M, 3)."""
    d = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-30)
    t = np.clip(np.einsum("mkj,mj->mk", points - a[:, None], d) / length2[:, None], 0.0, 1.0)
    closest = a[:, None] + t[..., None] * d[:, None]
    return np.linalg.norm(points - closest, axis=-1)


def distance_to_circles(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance of points (M, K, 3) from the circles through a, b, c (M, 3): in-plane radial
    error and out-of-plane error combined."""
    centre, normal, radius = circle_through(a, b, c)
    rel = points - centre[:, None]
    off_plane = np.einsum("mkj,mj->mk", rel, normal)
    in_plane = np.linalg.norm(rel - off_plane[..., None] * normal[:, None], axis=-1)
    return np.hypot(in_plane - radius[:, None], off_plane)
