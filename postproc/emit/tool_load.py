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

from ..errors import InputError


@dataclass(frozen=True)
class ToolLoad:
    mass_kg: float
    cog_mm: tuple[float, float, float]
    inertia_kgm2: tuple[float, float, float] = (0.0, 0.0, 0.0)


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
