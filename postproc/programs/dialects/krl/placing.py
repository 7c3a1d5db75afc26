"""KRL: a program's $BASE moved to a new place (``postproc place -o``)."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError
from postproc.robot.frames import matrix_to_abc

from ..base import short_number


def set_base(text: str, new_frame: np.ndarray, path: str) -> str:
    pattern = re.compile(r"\$BASE\s*=\s*\{([^}]*)\}", re.IGNORECASE)
    found = list(pattern.finditer(text))
    if len(found) != 1:
        raise EmitError(f"{path}: the program sets $BASE {len(found)} times (need exactly one inline {{X .., C ..}} literal)")
    abc = matrix_to_abc(new_frame[None, :3, :3])[0]
    values = dict(zip("XYZABC", [*new_frame[:3, 3], *abc]))
    # 6 decimals of a degree: 2e-5 mm at 1 m from the frame's origin
    literal = "{" + ", ".join(f"{k} {short_number(v, 4 if k in 'XYZ' else 6)}" for k, v in values.items()) + "}"
    m = found[0]
    return text[: m.start(1) - 1] + literal + text[m.end(1) + 1 :]
