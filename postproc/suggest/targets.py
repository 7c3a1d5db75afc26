"""The joints at a program's targets, as the controller takes them (the postures
``compensate`` starts from), for the region-targeted design."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from postproc.errors import InputError
from postproc.jobs.compensate import reference_postures
from postproc.model.errormodel import ErrorModel
from postproc.programs.ir import Kind
from postproc.programs.program_io import parse_program


def program_targets(path: str | Path, model: ErrorModel, dialect: str | None = None) -> np.ndarray:
    """(T, 6) joints of every target of the program (joint targets as written, Cartesian
    ones by the dialect's posture rules); a target the robot cannot take is an error naming its line."""
    tp = parse_program(path, dialect)
    if len(tp) == 0:
        raise InputError(f"{path}: the program has no motion targets")
    ref = reference_postures(tp, model)
    q = np.array(tp.joints, dtype=float)
    cart = np.nonzero(tp.kind != Kind.ABSJ)[0]
    q[cart] = ref.q
    bad = np.isnan(q).any(axis=1)
    if bad.any():
        row = int(np.argmax(bad))
        doc = tp.sources[int(tp.file[row])]
        raise InputError(f"{doc.path}:{tp.line[row]}: target out of {model.robot.name}'s reach or joint limits "
                         f"({int(bad.sum())} target(s) in all); the design needs the joints of every target")
    return q
