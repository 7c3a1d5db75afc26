"""The two things a program is compensated for, behind ``compensation.machine.Machine``:
a robot under the error model ``postproc fit`` wrote (``RobotTarget``), and a calibrated
five-axis machine file (``FiveAxisTarget``). ``postproc.jobs.target_file.load_target`` reads
either from a file, by its content.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from postproc.compensation.request import OPTION
from postproc.fivex import kinematics as five_kinematics
from postproc.fivex.machine import Machine as FiveAxisMachine
from postproc.model.errormodel import ErrorModel
from postproc.programs.ir import Toolpath
from postproc.programs.program_io import emit_texts, parse_program
from postproc.robot import kinematics

from .five_axis.commands import compensate_five_request

# What a five-axis machine's compensation uses; the rest of the request is the robot's.
FIVE_AXIS_TAKES = frozenset({"programs", "output", "dialect", "frames", "tools", "grid", "input_axes", "tool_radii"})
ROBOT_TAKES = frozenset(OPTION) - {"grid", "input_axes", "tool_radii"}


class _ProgramsByDialect:
    """Programs read and written through the language registry (both targets)."""

    def read_program(self, path, dialect: str | None = None, data: bytes | None = None, modules=()) -> Toolpath:
        return parse_program(path, dialect, data=data, modules=modules)

    def write_texts(self, tp: Toolpath, new: Toolpath) -> list[str]:
        return emit_texts(tp, new)


@dataclass(frozen=True, eq=False)
class RobotTarget(_ProgramsByDialect):
    """A robot and its fitted error model (a model JSON from ``postproc fit``)."""

    model: ErrorModel
    source: str = "the model"
    kind: str = "robot"
    takes: frozenset[str] = field(default=ROBOT_TAKES)
    why_unused: Mapping[str, str] = field(default_factory=dict)

    def forward(self, commands: np.ndarray) -> np.ndarray:
        return kinematics.fk(self.model.robot, commands)

    def inverse(self, poses: np.ndarray) -> np.ndarray:
        """All eight analytic branches (N, 8, 6) degrees, NaN where a branch has none."""
        return kinematics.ik(self.model.robot, poses)

    def predict(self, commands: np.ndarray) -> np.ndarray:
        return self.model.predict_prepared(self.model.prepare(q_deg=np.asarray(commands, dtype=float)))

    def own_job(self, request) -> None:
        """None: a robot takes the shared job (``postproc.jobs.compensate_files``: its postures,
        forces, path checks, chunks, batches and subdivision)."""


@dataclass(frozen=True, eq=False)
class FiveAxisTarget(_ProgramsByDialect):
    """A five-axis machine as calibrated (``rtcp-calibrate``'s TOML); ``nominal`` is the
    bundled machine of the same name, whose kinematics the controller runs."""

    machine: FiveAxisMachine
    nominal: FiveAxisMachine
    source: str
    kind: str = "five-axis machine"
    takes: frozenset[str] = field(default=FIVE_AXIS_TAKES)
    why_unused: Mapping[str, str] = field(default_factory=lambda: {"allow_extrapolation": "a machine's error grid is never extrapolated"})

    def forward(self, commands: np.ndarray) -> np.ndarray:
        """Tool-tip poses (N, 4, 4): the tip as translation, the tool axis as the z column."""
        tip, axis = five_kinematics.fk(self.nominal, commands)
        return _poses(tip, axis)

    def inverse(self, poses: np.ndarray) -> np.ndarray:
        poses = np.asarray(poses, dtype=float)
        return five_kinematics.ik(self.nominal, poses[:, :3, 3], poses[:, :3, 2]).axes

    def predict(self, commands: np.ndarray) -> np.ndarray:
        return five_kinematics.fk(self.machine, np.asarray(commands, dtype=float))[0]  # the calibrated axes (no grid)

    def own_job(self, request) -> list[str]:
        """The five-axis job (``jobs.five_axis.commands``): the program's tips and tool axes on the
        calibrated machine and its error grid, the rotary solution its controller takes, the
        written numbers read back and checked; the lines of its account."""
        return compensate_five_request(request)


def _poses(tip: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(N, 4, 4) with ``tip`` as the origin and ``axis`` as the z column (x, y left as zero)."""
    out = np.zeros((len(tip), 4, 4))
    out[:, :3, 3], out[:, :3, 2], out[:, 3, 3] = tip, axis, 1.0
    return out
