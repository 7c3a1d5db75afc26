"""Simulated probing of a machine with known rotary-axis errors (tests, examples, benchmarks).

A calibration sphere sits on the table; each rotary axis is turned through its positions
(the other at zero) and the sphere centre (or probe touches on the sphere) is recorded in
machine coordinates with the true machine's geometry, plus noise and gross outliers.
"""

from __future__ import annotations

import numpy as np

from .geometry import rotation
from .kinematics import table_to_machine
from .machine import Machine


def perturbed(machine: Machine, rng: np.random.Generator, tilt_rad=(1e-4, 5e-4), offset_mm=(0.02, 0.2)) -> Machine:
    """A 'true' machine: each rotary axis tilted by a random angle in ``tilt_rad`` and its
    line moved perpendicular to itself by a random distance in ``offset_mm``."""
    updates = {}
    for ax in machine.rotary:
        d = ax.direction
        perp = np.cross(d, rng.normal(size=3))
        perp /= np.linalg.norm(perp)
        tilt = rng.uniform(*tilt_rad)
        new_d = rotation(perp, np.array([tilt]))[0] @ d
        shift = np.cross(d, rng.normal(size=3))
        shift *= rng.uniform(*offset_mm) / np.linalg.norm(shift)
        updates[ax.name] = (new_d, ax.point + shift)
    return machine.with_axes(updates, {"simulated": "true machine of a simulation"})


def sphere_centres(machine: Machine, axis: str, angles_deg: np.ndarray, sphere_w: np.ndarray) -> np.ndarray:
    """(N, 3) machine-frame centres of a sphere at ``sphere_w`` (workpiece frame) with rotary
    ``axis`` at each angle and the other rotary axis at zero (table axes)."""
    i = machine.rotary_names.index(axis)
    theta = np.zeros((len(angles_deg), 2))
    theta[:, i] = np.radians(angles_deg)
    return table_to_machine(machine, theta, np.broadcast_to(sphere_w, (len(angles_deg), 3)).copy())


def touches(centres: np.ndarray, radius: float, rng: np.random.Generator, per_sphere: int = 5) -> np.ndarray:
    """(N * per_sphere, 3) probe-tip centres touching each sphere from above (a cap of
    directions up to 60 degrees from +Z and one at the top), radius = sphere + tip radius."""
    az = np.linspace(0, 2 * np.pi, per_sphere - 1, endpoint=False)[None, :] + rng.uniform(0, 2 * np.pi, (len(centres), 1))
    pol = np.radians(60.0)
    dirs = np.stack([np.sin(pol) * np.cos(az), np.sin(pol) * np.sin(az), np.full_like(az, np.cos(pol))], axis=-1)
    top = np.broadcast_to([0.0, 0.0, 1.0], (len(centres), 1, 3))
    dirs = np.concatenate([dirs, top], axis=1)
    return (centres[:, None, :] + radius * dirs).reshape(-1, 3)


def probe_rows(machine: Machine, plan: dict, rng: np.random.Generator, noise_mm: float = 0.001, outliers: dict | None = None,
               touch_radius: float | None = None) -> list[dict]:
    """CSV rows (probing.md) for ``plan`` = {axis: (angles_deg, sphere_w)}; ``outliers`` =
    {axis: {row index: displacement (3,) mm}} added to that sphere centre. With
    ``touch_radius`` the rows are touches (5 per sphere) instead of centres."""
    rows = []
    for axis, (angles, sphere_w) in plan.items():
        centres = sphere_centres(machine, axis, np.asarray(angles, float), np.asarray(sphere_w, float))
        for k, disp in (outliers or {}).get(axis, {}).items():
            centres[k] = centres[k] + np.asarray(disp, float)
        ids = [f"{axis}{k + 1}" for k in range(len(angles))]
        if touch_radius is None:
            pts, owner = centres + rng.normal(0, noise_mm, centres.shape), np.arange(len(angles))
        else:
            pts = touches(centres, touch_radius, rng)
            pts = pts + rng.normal(0, noise_mm, pts.shape)
            owner = np.repeat(np.arange(len(angles)), len(pts) // len(angles))
        for j, (p, k) in enumerate(zip(pts, owner)):
            row = {"id": ids[k], "axis": axis, "angle": float(angles[k]), "x": p[0], "y": p[1], "z": p[2]}
            if touch_radius is not None:
                row["touch"] = j % (len(pts) // len(angles)) + 1
            rows.append(row)
    return rows


def rows_csv(rows: list[dict]) -> str:
    cols = [c for c in ("id", "axis", "angle", "touch", "x", "y", "z") if c in rows[0]]
    lines = [",".join(cols)]
    for r in rows:
        lines.append(",".join(f"{r[c]:.6f}" if isinstance(r[c], float) else str(r[c]) for c in cols))
    return "\n".join(lines) + "\n"
