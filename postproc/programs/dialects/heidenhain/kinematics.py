"""A calibrated table-table machine written as a TNC kinematics description.

The TNC describes a machine as a transformation chain from the machine base to the table
(TNC 640 machine documentation, kinematics description / KinematicsDesign): translations
(``Trans X Y Z``), fixed rotations (``Rot X|Y|Z angle``) and the rotary axes, each turning
about its own local axis. A calibrated axis is a line (a point and a direction, postproc's
machine file): written as the translation to its point, the two fixed rotations that turn
the nominal axis direction onto the calibrated one, the axis, the same rotations undone,
and, after the last axis, the closing translation back to the base. ``chain_transform``
evaluates the chain, so that the text is checked against the machine's own kinematics.

The text lists the values as the calibration found them, for entry into the control's
kinematics table; it is not a file the control imports (the table's layout is the machine
builder's), and it is labelled so.
"""

from __future__ import annotations

import math

import numpy as np

_AXIS_OF = {"A": 0, "B": 1, "C": 2}  # the local axis each rotary axis turns about


def _rot(axis: int, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(4)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _trans(v) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = v
    return t


def _fixed_rotations(name: str, d: np.ndarray) -> list[tuple[int, float]]:
    """(local axis, deg) rotations R1, R2 with R1 R2 e = d for the nominal direction e of axis ``name``."""
    d = d / np.linalg.norm(d)
    if name == "A":  # Rz(g) Ry(b) x = (cos g cos b, sin g cos b, -sin b)
        return [(2, math.degrees(math.atan2(d[1], d[0]))), (1, -math.degrees(math.asin(d[2])))]
    if name == "B":  # Rz(g) Rx(a) y = (-sin g cos a, cos g cos a, sin a)
        return [(2, math.degrees(math.atan2(-d[0], d[1]))), (0, math.degrees(math.asin(d[2])))]
    # C: Rx(a) Ry(b) z = (sin b, -sin a cos b, cos a cos b)
    return [(0, math.degrees(math.atan2(-d[1], d[2]))), (1, math.degrees(math.asin(d[0])))]


def chain(machine) -> list[tuple]:
    """The chain: ("Trans", xyz) / ("Rot", local axis, deg) / ("Axis", name) entries, base -> table."""
    out: list[tuple] = []
    here = np.zeros(3)
    for ax in machine.rotary:
        rotations = _fixed_rotations(ax.name, np.asarray(ax.direction, float))
        out.append(("Trans", np.asarray(ax.point, float) - here))
        out += [("Rot", a, deg) for a, deg in rotations]
        out.append(("Axis", ax.name))
        out += [("Rot", a, -deg) for a, deg in reversed(rotations)]
        here = np.asarray(ax.point, float)
    out.append(("Trans", -here))
    return out


def chain_transform(entries: list[tuple], angles_deg: dict[str, float]) -> np.ndarray:
    """machine_T_table (4, 4) of the chain with the rotary axes at ``angles_deg``."""
    t = np.eye(4)
    for e in entries:
        if e[0] == "Trans":
            t = t @ _trans(e[1])
        elif e[0] == "Rot":
            t = t @ _rot(e[1], e[2])
        else:
            t = t @ _rot(_AXIS_OF[e[1]], angles_deg[e[1]])
    return t


def tnc_kinematics(machine) -> str | None:
    """The text of the chain for a machine whose rotary axes are both in the table (else None)."""
    if any(ax.carrier != "table" for ax in machine.rotary) or any(ax.name not in _AXIS_OF for ax in machine.rotary):
        return None
    lines = [f"; Heidenhain TNC kinematics description of machine {machine.name}: transformation chain machine base -> table",
             "; (KEY, local axis, value: mm / deg) as the rotary axis calibration found it; enter into the control's kinematics",
             "; table under the machine builder's procedure: this is not a file the control imports"]
    for e in chain(machine):
        if e[0] == "Trans":
            lines += [f"Trans  {k}  {v:+.6f}" for k, v in zip("XYZ", e[1])]
        elif e[0] == "Rot":
            lines.append(f"Rot    {'XYZ'[e[1]]}  {e[2]:+.6f}")
        else:
            lines.append(f"{e[1]}      {'XYZ'[_AXIS_OF[e[1]]]}  (rotary axis)")
    return "\n".join(lines) + "\n"
