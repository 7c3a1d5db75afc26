"""A machine defined outside the package, implementing ``postproc.compensation.machine.Machine``,
compensates a G-code program through the library (issue 27): compensation asks the object it
is given (``inverse``, ``predict``, ``read_program``, ``write_texts``) and knows nothing of
gantries. The machine here is a 3-axis Cartesian gantry with a linear error model: squareness
and scale errors of its axes, an offset, and a small sag that grows with X."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.compensation.machine import Machine
from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.jobs.compensate import compensate_with
from postproc.programs import emit_texts, parse_program

PROGRAM = "G21 G90\nG0 X0 Y0 Z50\nG1 X100 Y20 Z5 F600\nG1 X250.5 Y-40 Z5\nG1 X300 Y300 Z10\nM30\n"


class Gantry:
    """Axis commands are X Y Z in mm; the tool really goes to A @ q + b + sag(q)."""

    kind = "gantry"
    source = "a test gantry"
    takes = frozenset({"programs", "output", "dialect", "tol_mm", "max_iter", "frames", "tools"})
    why_unused: dict = {}

    A = np.array([[1.0002, 0.0003, 0.0], [0.0, 0.9998, -0.0004], [0.0001, 0.0, 1.0001]])
    b = np.array([0.05, -0.03, 0.02])

    def forward(self, commands):
        poses = np.repeat(np.eye(4)[None], len(commands), axis=0)
        poses[:, :3, 3] = commands
        return poses

    def inverse(self, poses):
        return np.asarray(poses)[:, :3, 3].copy()

    def predict(self, commands):
        commands = np.asarray(commands, dtype=float)
        sag = np.zeros_like(commands)
        sag[:, 2] = -2e-7 * commands[:, 0] ** 2  # Z droops along the X beam: not linear, so the solve iterates
        return commands @ self.A.T + self.b + sag

    def read_program(self, path, dialect=None, data=None):
        return parse_program(path, dialect, data=data)

    def write_texts(self, tp, new):
        return emit_texts(tp, new)


def _request(tmp_path, **more):
    (tmp_path / "part.nc").write_text(PROGRAM)
    return CompensationRequest(Gantry(), programs=(str(tmp_path / "part.nc"),), output=str(tmp_path / "out.nc"),
                               frames={"G54": np.eye(4)}, **more)


def test_the_gantry_is_a_machine():
    assert isinstance(Gantry(), Machine)


def test_a_gcode_program_is_compensated_for_a_machine_defined_outside_the_package(tmp_path):
    request = _request(tmp_path, tol_mm=1e-6)
    gantry = request.machine
    tp = gantry.read_program(request.programs[0])
    new, report = compensate_with(request, tp)
    (tmp_path / "out.nc").write_text(gantry.write_texts(tp, new)[0])
    written = gantry.read_program(tmp_path / "out.nc")
    goal = tp.position
    assert report.summary()["failed"] == 0 and report.summary()["compensated"] == len(tp)
    assert np.all(report.before_mm > 0.02)  # the gantry misses every point as written
    assert np.abs(gantry.predict(written.position) - goal).max() < 0.002  # as written back (G-code keeps 3 decimals)
    assert report.iterations.max() >= 2 and report.after_mm.max() < 1e-6  # a tight tolerance: more than one step
    assert [line.split(" ")[0] for line in (tmp_path / "out.nc").read_text().splitlines()] == [line.split(" ")[0] for line in PROGRAM.splitlines()]


def test_what_the_machine_does_not_take_is_refused_naming_the_option(tmp_path):
    with pytest.raises(InputError, match=r"--force: not used by the compensation of a gantry \(--model a test gantry\)"):
        _request(tmp_path, force_n=(0.0, 0.0, 10.0))


def test_a_circular_move_is_refused_with_its_line(tmp_path):
    (tmp_path / "arc.nc").write_text("G21 G90 G17\nG0 X0 Y0 Z5\nG1 X10 Y0 F600\nG2 X20 Y0 I5 J0\nM30\n")
    request = CompensationRequest(Gantry(), programs=(str(tmp_path / "arc.nc"),), output=str(tmp_path / "o.nc"), frames={"G54": np.eye(4)})
    tp = request.machine.read_program(tmp_path / "arc.nc")
    with pytest.raises(InputError, match=r"arc.nc:4: a circular move"):
        compensate_with(request, tp)


def test_a_point_the_machine_cannot_reach_fails_with_its_line(tmp_path):
    class Limited(Gantry):
        def inverse(self, poses):
            q = super().inverse(poses)
            q[q[:, 0] > 280] = np.nan  # the X travel ends at 280 mm
            return q

    request = CompensationRequest(Limited(), programs=(), frames={"G54": np.eye(4)})
    (tmp_path / "part.nc").write_text(PROGRAM)
    tp = request.machine.read_program(tmp_path / "part.nc")
    _, report = compensate_with(request, tp)
    assert report.failures() == [(5, "out of reach or outside the joint limits")]
