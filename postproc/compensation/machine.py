"""What a compensation target is, for the steps that compensate a program: a robot under
its fitted error model, or a calibrated five-axis machine.

``Machine`` is a protocol: the robot target and the five-axis target
(``postproc.jobs.targets``) implement it, and ``postproc.jobs.targets.load_target`` returns the one
a file holds, judged by its content (never by its suffix). A script may bring its own
class: ``postproc.jobs.compensate_files.compensate_files(request)`` (what ``postproc compensate``
calls) asks the machine how its programs are compensated (``own_job``): its own job, or the
shared one, where ``postproc.jobs.compensate.compensate_with`` compensates any machine that is
not a robot under a fitted error model through ``inverse`` and ``predict`` alone
(``through_machine.py``). Nothing chooses by the machine's class.
This module imports nothing of the languages or of either target, so the request
(``request.py``) can carry one.
"""

from __future__ import annotations

from typing import Mapping, Protocol, runtime_checkable

import numpy as np

from postproc.programs.ir import Toolpath


@runtime_checkable
class Machine(Protocol):
    """A robot or a machine that programs are compensated for.

    ``kind`` names it in messages ("robot", "five-axis machine"); ``source`` is the file it
    was read from; ``takes`` holds the ``CompensationRequest`` fields its compensation
    uses (any other field given is refused by the request, naming the option);
    ``why_unused``: for some of the others, why (said with the refusal).
    A machine may also have ``own_job(request)`` (optional, so not part of the protocol's
    check): how a program is compensated on it. Absent or returning None: by the shared job
    (``postproc.jobs.compensate_files``: each program read with ``read_program``, compensated
    target by target by ``compensate_with``, its texts from ``write_texts`` read back and
    written, all files or none) — the robot's way, and a script's gantry's. Otherwise the
    machine runs a job of its own for ``request`` (a ``CompensationRequest``), writes the files
    itself (all or none) and returns the lines of its account (a calibrated five-axis machine:
    its error grid, rotary solutions and read-back check).
    """

    kind: str
    source: str
    takes: frozenset[str]
    why_unused: Mapping[str, str]

    def forward(self, commands: np.ndarray) -> np.ndarray:
        """(N, 4, 4) poses the commanded axis values (N, dof) reach under the nominal kinematics."""
        ...

    def inverse(self, poses: np.ndarray) -> np.ndarray:
        """(N, dof) commands that reach ``poses`` (N, 4, 4) under the nominal kinematics."""
        ...

    def predict(self, commands: np.ndarray) -> np.ndarray:
        """(N, 3) mm: where the tool point really goes for ``commands`` under the error model."""
        ...

    def read_program(self, path, dialect: str | None = None, data: bytes | None = None) -> Toolpath:
        """The program at ``path`` (``data``: its text already read) as a Toolpath. A machine
        whose ``takes`` holds ``data`` (``--data``) is also given ``modules=``: the other modules'
        files the program uses."""
        ...

    def write_texts(self, tp: Toolpath, new: Toolpath) -> list[str]:
        """The texts of ``tp``'s sources with the numbers of ``new`` spliced in."""
        ...
