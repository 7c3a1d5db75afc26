"""Transform from the robot base to the measurement frame (6 DOF).

measured = R p + t with R = Rot(r) R0, t = t0 + dt, where (R0, t0) is a closed-form
point-set registration (Kabsch/Umeyama) done before the fit when the data are far from
the robot base frame, e.g. in a laser tracker's own frame.
"""

from __future__ import annotations

import numpy as np

from .base import Effect, Param


class BaseFrame(Effect):
    name = "base_frame"
    kind = "base"

    def params(self, robot) -> list[Param]:
        trans = [Param(f"base_frame.t{axis}", "mm", 0.1, 0.5) for axis in "xyz"]
        rots = [Param(f"base_frame.r{axis}", "deg", 0.01, typ) for axis, typ in zip("xyz", (0.01, 0.02, 0.01))]
        return trans + rots


def kabsch(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid (R, t) minimising |R source + t - target|^2 over (N, 3) point sets (no scaling)."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    cov = (target - mu_t).T @ (source - mu_s)
    u, _, vt = np.linalg.svd(cov)
    d = np.sign(np.linalg.det(u @ vt))
    rot = u @ np.diag([1.0, 1.0, d]) @ vt
    return rot, mu_t - rot @ mu_s


def rotvec_to_matrix(rotvec_deg: np.ndarray) -> np.ndarray:
    """Rotation vector (degrees) -> matrix (Rodrigues)."""
    r = np.deg2rad(np.asarray(rotvec_deg, dtype=float))
    angle = np.linalg.norm(r)
    if angle < 1e-15:
        return np.eye(3)
    k = r / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx
