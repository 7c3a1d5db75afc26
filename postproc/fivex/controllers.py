"""Calibrated rotary axes written as controller machine data, each labelled with its controller.

- LinuxCNC trt kinematics (xyzac-trt-kins / xyzbc-trt-kins): HAL pins x/y/z-rot-point (a
  point on C) and the tilt axis offsets from it (trtfuncs.c). These kinematics assume the
  axes exactly along X/Y and Z: the tilts found are reported as not representable.
- Siemens 840D orientable toolholder ($TC_CARR1..23), kinematics type P (both rotary axes
  in the part/table): axis vectors v1, v2 and offset vectors l2, l3, l4.
- A Heidenhain-style kinematics table as CSV (a transformation sequence: translations and
  rotary axes from the machine base to the table), for review, not a TNC import file.
"""

from __future__ import annotations

import numpy as np

from .machine import Machine


def _closest_points(p1, d1, p2, d2):
    """Feet of the common perpendicular of two skew lines."""
    w = p1 - p2
    a, b, c, d, e = d1 @ d1, d1 @ d2, d2 @ d2, d1 @ w, d2 @ w
    den = a * c - b * b
    s = (b * e - c * d) / den
    t = (a * e - b * d) / den
    return p1 + s * d1, p2 + t * d2


def linuxcnc_trt(machine: Machine, nominal: Machine) -> dict | None:
    """HAL settings for LinuxCNC's trt kinematics, or None when the machine is not of that form."""
    names = machine.rotary_names
    kins = machine.linuxcnc.get("kinematics", "")
    if machine.kind != "table-table" or names[1] != "C" or names[0] not in ("A", "B") or not kins.endswith("trt-kins"):
        return None
    tilt, rot = machine.rotary
    # C rot point: the calibrated C line where it crosses the nominal rot point's height.
    z0 = nominal.rotary[1].point[2]
    r = rot.point + (z0 - rot.point[2]) / rot.direction[2] * rot.direction
    along = 0 if names[0] == "A" else 1  # the tilt axis runs along X (A) or Y (B)
    q = tilt.point + (r[along] - tilt.point[along]) / tilt.direction[along] * tilt.direction
    off = q - r
    ideal = np.eye(3)[along]
    not_representable = {
        f"{names[0]}_tilt_rad": float(np.arccos(min(1.0, abs(tilt.direction @ ideal)))),
        "C_tilt_rad": float(np.arccos(min(1.0, abs(rot.direction[2])))),
    }
    pins = {"x-rot-point": r[0], "y-rot-point": r[1], "z-rot-point": r[2]}
    if names[0] == "A":
        pins.update({"y-offset": off[1], "z-offset": off[2]})
    else:
        pins.update({"x-offset": off[0], "z-offset": off[2]})
    lines = [f"# LinuxCNC {kins} (trtfuncs.c): calibrated rotary axes of machine {machine.name}",
             f"# not representable in {kins} (it assumes {names[0]} along {'XY'[along]} and C along Z): " +
             ", ".join(f"{k} {v:.3g}" for k, v in not_representable.items())]
    lines += [f"setp {kins}.{pin} {value:.6f}" for pin, value in pins.items()]
    return {"controller": f"LinuxCNC {kins} HAL pins", "pins": {k: float(v) for k, v in pins.items()},
            "not_representable": not_representable, "text": "\n".join(lines) + "\n"}


def siemens_tc_carr(machine: Machine, number: int = 1) -> dict | None:
    """Siemens $TC_CARR data of an orientable toolholder, kinematics type P (table-table)."""
    if machine.kind != "table-table":
        return None
    a1, a2 = machine.rotary
    p1, p2 = _closest_points(a1.point, a1.direction, a2.point, a2.direction)
    l2, l3 = p1, p2 - p1
    l4 = -(l2 + l3)
    values = {}
    for start, vec in ((4, l2), (7, a1.direction), (10, a2.direction), (15, l3), (18, l4)):
        for k in range(3):
            values[f"$TC_CARR{start + k}[{number}]"] = float(vec[k])
    lines = [f"; Siemens 840D orientable toolholder {number}, kinematics type P (both rotary axes in the table), machine {machine.name}",
             "; l2: machine zero -> axis 1 (common perpendicular foot), l3: axis 1 -> axis 2, l4: closing vector;",
             "; check the signs of l2..l4 against the controller's documentation (W1, orientable toolholders) before use"]
    lines += [f"{k}={v:.6f}" for k, v in values.items()]
    lines.append(f'$TC_CARR23[{number}]="P"')
    return {"controller": "Siemens 840D $TC_CARR (type P)", "values": values, "text": "\n".join(lines) + "\n"}


def heidenhain_csv(machine: Machine) -> str:
    """Transformation sequence from the machine base to the table as CSV."""
    rows = ["key,type,x,y,z,axis"]
    here = np.zeros(3)
    for ax in machine.rotary:
        if ax.carrier != "table":
            continue
        t = ax.point - here
        rows.append(f"Trans,translation,{t[0]:.6f},{t[1]:.6f},{t[2]:.6f},")
        d = ax.direction
        rows.append(f"{ax.name},rotary axis direction,{d[0]:.9f},{d[1]:.9f},{d[2]:.9f},{ax.name}")
        here = ax.point
    rows.append(f"Trans,closing translation,{-here[0]:.6f},{-here[1]:.6f},{-here[2]:.6f},")
    return "# Heidenhain-style kinematics description (transformation sequence base -> table), mm; not a TNC import file\n" + "\n".join(rows) + "\n"
