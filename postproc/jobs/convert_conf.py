"""Configuration data of a converted program in the output language's terms, from the joints
the input's controller takes at each target (``convert --to fanuc|inform --robot R``).

One controller's configuration data mean nothing to another's (an ABB cfx is no Fanuc CONFIG),
so ``convert`` never carries them across languages. What carries over is the posture: the
joints the input's controller takes by its own rules (its configuration data where they
apply, the posture carried from target to target otherwise; ``compensate.reference_postures``)
are the joints the new program must drive to, and the output language states them its way
(``Dialect.conf_of_joints``: Fanuc's CONFIG, INFORM's ///RCONF form).
"""

from __future__ import annotations

import numpy as np

from postproc.compensation.core import POSTURE_CONF, POSTURE_START
from postproc.errors import InputError
from postproc.model.effects import EffectSum
from postproc.model.errormodel import ErrorModel
from postproc.programs import dialects
from postproc.programs.emit.writer import where
from postproc.programs.ir import Kind, Toolpath

from .compensate import reference_postures

_WHY = {POSTURE_CONF: "its configuration data name no solution of the robot's inverse kinematics there",
        POSTURE_START: "the input's controller takes the solution nearest the joints the program starts from, which the program does not state"}


def joints_taken(tp: Toolpath, robot) -> tuple[np.ndarray, list[str]]:
    """(N, 6) deg: the joints the input's controller takes at each target of ``tp`` on ``robot``
    (joint targets: their own), and the notes of its rules (a start posture assumed); an
    InputError naming the first target whose joints are not determined, and why."""
    reference = reference_postures(tp, ErrorModel.create(robot, np.zeros(3), EffectSum()))
    q = tp.joints.astype(float).copy()
    rows = np.nonzero(tp.kind != Kind.ABSJ)[0]
    q[rows] = reference.q
    bad = np.nonzero(np.isnan(q).any(axis=1))[0]
    if bad.size:
        row = int(bad[0])
        at = np.nonzero(rows == row)[0]
        code = int(reference.posture_problem[at[0]]) if at.size else 0
        why = _WHY.get(code, f"{robot.name} cannot reach it within its joint limits")
        raise InputError(f"{where(tp, row)}: the joints the controller takes here are not determined ({why}); "
                         f"its configuration data in the output language cannot be written ({bad.size} target(s) in all)")
    return q, list(reference.notes)


def converted_conf(tp: Toolpath, language, robot) -> tuple[np.ndarray | None, list[str]]:
    """(N, 4) configuration data of every target of ``tp`` in ``language``'s terms (a
    ``Dialect``) on ``robot``, and the notes of the input controller's rules; None where
    ``language`` is the input's own (its configuration data are written as they are)."""
    if language is dialects.of(tp):
        return None, []
    q, notes = joints_taken(tp, robot)
    return np.asarray(language.conf_of_joints(robot, q), dtype=float), notes
