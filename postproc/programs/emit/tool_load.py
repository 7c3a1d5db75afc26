"""The load a converted robot program states for its tool (``convert --tool-load``).

A robot controller needs the mass on its flange to move right (ABB: tooldata's tload, KUKA:
$LOAD), and a model whose error depends on gravity is matched against it (program_check.py).
A program converted from G-code or from another robot's language carries none, so the user
gives it: mass (kg), centre of gravity in the flange frame (mm) and, optionally, the moments
of inertia about it (kg m^2, axes parallel to the flange's), as both ABB's loaddata and
KUKA's LOAD state them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from postproc.errors import InputError
from postproc.robot.frames import matrix_to_quat_wxyz, quat_wxyz_to_matrix


@dataclass(frozen=True)
class ToolLoad:
    mass_kg: float
    cog_mm: tuple[float, float, float]
    inertia_kgm2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # the axes the moments are about, as a rotation of the flange frame: RAPID loaddata's aom
    # quaternion [q1..q4] = [w, x, y, z]; KUKA's CM A, B, C (Rz(A) Ry(B) Rx(C)) is the same turn
    aom_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def tensor(self) -> np.ndarray:
        """Inertia tensor about the centre of gravity in flange axes (kg m^2): R diag(I) R^T."""
        rot = quat_wxyz_to_matrix(np.array(self.aom_wxyz))
        return rot @ np.diag(self.inertia_kgm2) @ rot.T

    def same_as(self, other: "ToolLoad") -> bool:
        """The same load on the flange (mass, centre of gravity, inertia tensor), whatever the axes are called."""
        return (abs(self.mass_kg - other.mass_kg) <= 1e-6 and np.allclose(self.cog_mm, other.cog_mm, atol=1e-4)
                and np.allclose(self.tensor(), other.tensor(), atol=1e-9))

    def text(self) -> str:
        return (f"{self.mass_kg:g} kg at ({', '.join(f'{v:g}' for v in self.cog_mm)}) mm, inertia ({', '.join(f'{v:g}' for v in self.inertia_kgm2)}) kg m^2"
                + ("" if self.aom_wxyz == (1.0, 0.0, 0.0, 0.0) else f" about axes [{', '.join(f'{v:g}' for v in self.aom_wxyz)}]"))


NO_LOAD = ToolLoad(0.0, (0.0, 0.0, 0.0))


def combined(a: ToolLoad | None, b: ToolLoad | None) -> ToolLoad | None:
    """The one load equal to ``a`` and ``b`` on the flange together (ABB: a GripLoad payload on
    top of the tool's tload; KUKA $LOAD is the whole): masses add, the centre of gravity is the
    mass-weighted mean, the tensors add after moving each to it (parallel axes: + m (|d|^2 E - d d^T),
    d in m), and the sum is stated about its principal axes (eigenvectors, a right-handed turn)."""
    if a is None or b is None or b.mass_kg == 0:
        return a if b is None or b.mass_kg == 0 else b
    if a.mass_kg == 0:
        return b
    mass = a.mass_kg + b.mass_kg
    cog = (a.mass_kg * np.array(a.cog_mm) + b.mass_kg * np.array(b.cog_mm)) / mass
    total = np.zeros((3, 3))
    for part in (a, b):
        d = (np.array(part.cog_mm) - cog) / 1000.0
        total += part.tensor() + part.mass_kg * (d @ d * np.eye(3) - np.outer(d, d))
    if np.allclose(total, np.diag(np.diag(total)), atol=1e-12):  # already about the flange axes
        moments, axes = np.diag(total), np.eye(3)
    else:
        moments, axes = np.linalg.eigh(total)
        axes[:, 2] *= np.sign(np.linalg.det(axes))
    aom = tuple(float(v) for v in np.round(matrix_to_quat_wxyz(axes[None])[0], 9))
    return ToolLoad(float(mass), tuple(float(v) for v in np.round(cog, 9)), tuple(float(v) for v in np.round(moments, 12)), aom)


def parse_tool_load(text: str, option: str = "--tool-load") -> ToolLoad:
    """'MASS,CX,CY,CZ[,IX,IY,IZ]' -> ToolLoad; anything else is an InputError naming ``option``."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (4, 7):
        raise InputError(f"{option}: expected MASS,CX,CY,CZ[,IX,IY,IZ] (kg, mm, kg m^2), got {len(parts)} values in '{text}'")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"{option}: expected numbers MASS,CX,CY,CZ[,IX,IY,IZ], got '{text}'") from None
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"{option}: every value must be a finite number, got '{text}'")
    if values[0] <= 0:
        raise InputError(f"{option}: the mass must be > 0 kg (ABB tooldata and KUKA $LOAD need one), got {values[0]:g}")
    if any(v < 0 for v in values[4:]):
        raise InputError(f"{option}: moments of inertia cannot be negative, got '{text}'")
    return ToolLoad(values[0], tuple(values[1:4]), tuple(values[4:7]) if len(values) == 7 else (0.0, 0.0, 0.0))
