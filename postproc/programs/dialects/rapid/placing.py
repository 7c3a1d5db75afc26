"""RAPID: a program's work object moved to a new place (``postproc place -o``)."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import matrix_to_quat_wxyz, quat_wxyz_to_matrix

from ..base import NUMBER, short_number


def set_work_object(text: str, name: str, new_frame: np.ndarray, path: str) -> str:
    """The work object ``name`` placed at ``new_frame`` (its user frame changed, its object
    frame kept). Only a literal wobjdata declared once can be changed."""
    if name.upper() == "WOBJ0":
        raise EmitError(f"{path}: the targets are in wobj0 (the base frame); declare a work object to place the workpiece")
    return _rapid_wobj(text, name, new_frame, path)


def _rapid_wobj(text: str, name: str, new_frame: np.ndarray, path: str) -> str:
    decl = re.compile(rf"wobjdata\s+{re.escape(name)}\s*:=\s*\[", re.IGNORECASE)
    found = list(decl.finditer(text))
    if len(found) != 1:
        raise EmitError(f"{path}: work object '{name}' is declared {len(found)} times; cannot place it")
    start = found[0].end()
    end = text.find(";", start)
    body = text[start:end]
    after_string = body.find('"', body.find('"') + 1) + 1  # past the ufmec string
    nums = [m for m in re.finditer(NUMBER, body[after_string:])]
    if after_string <= 0 or len(nums) != 14:
        raise EmitError(f"{path}: work object '{name}' is not a literal wobjdata (14 numbers); cannot place it")
    values = np.array([float(m.group()) for m in nums])
    oframe = np.eye(4)
    oframe[:3, :3] = quat_wxyz_to_matrix(values[10:14][None])[0]
    oframe[:3, 3] = values[7:10]
    uframe = new_frame @ np.linalg.inv(oframe)
    new = list(uframe[:3, 3]) + list(matrix_to_quat_wxyz(uframe[None, :3, :3])[0])
    digits = [4, 4, 4, 8, 8, 8, 8]
    out = text
    for m, value, dec in sorted(zip(nums[:7], new, digits), key=lambda t: -t[0].start()):
        s, e = start + after_string + m.start(), start + after_string + m.end()
        out = out[:s] + short_number(value, dec) + out[e:]
    return out
