"""One typed request (issue 27): ``CompensationRequest`` checks which options go together in
one place; the robot and the five-axis machine are ``Machine`` targets told apart by the
model file's content, not its suffix; the older keyword entries build a request and give
the same programs as the request entries."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from helpers import kr160
from typer.testing import CliRunner

import postproc
from postproc.cam.post import post_request
from postproc.cli import app
from postproc.jobs.compensate_files import can_stream as _can_stream
from postproc.compensation.machine import Machine
from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError, ModelFileError
from postproc.jobs.compensate import compensate, compensate_with, request_for
from postproc.jobs.stream import compensate_streamed, stream_request
from postproc.jobs.target_file import load_target
from postproc.jobs.targets import FiveAxisTarget, RobotTarget
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import parse_program

runner = CliRunner()
HERE = Path(__file__).parent
MACHINE = HERE / "data" / "fivex" / "xyzac-trt-true.toml"
KRL = ("DEF p( )\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n"
       + "".join(f"LIN {{X {1000 + 5 * i}, Y {20 * i}, Z 500, A 0, B 180, C 0}}\n" for i in range(12)) + "END\n")


@pytest.fixture(scope="module")
def model() -> ErrorModel:
    m = ErrorModel.create(kr160(), [0.0, 0.0, 200.0], parse_effects("geometric"))
    rng = np.random.default_rng(3)
    return m.with_values({p.name: float(rng.normal(0.0, 0.2)) for p in m.params if p.unit == "mm"})


@pytest.fixture()
def program(tmp_path) -> Path:
    path = tmp_path / "p.src"
    path.write_text(KRL)
    return path


def test_forces_are_checked_in_the_request_once(model):
    robot = RobotTarget(model)
    with pytest.raises(InputError, match="--force-file gives .*not with --force or --cut"):
        CompensationRequest(robot, force_n=(1.0, 2.0, 3.0), force_file=Path("f.csv"))
    with pytest.raises(InputError, match="--cut gives .*not with --force"):
        CompensationRequest(robot, force_n=(1.0, 2.0, 3.0), cut=Path("c.toml"))
    with pytest.raises(InputError, match="force_per_target"):
        request_for(model, force_n=[1.0, 2.0, 3.0], force_per_target=np.zeros((3, 3)))
    CompensationRequest(robot, cut=Path("c.toml"))  # one source alone is fine


def test_the_job_shape_is_checked_in_the_request(model):
    robot = RobotTarget(model, "m.json")
    with pytest.raises(InputError, match="needs -o OUT"):
        CompensationRequest(robot, programs=("p.src",))
    with pytest.raises(InputError, match="--subdivide: work on one program at a time"):
        CompensationRequest(robot, programs=("a.src", "b.src"), out_dir=Path("out"), subdivide=True)
    with pytest.raises(InputError, match="--jobs N or --scheduler"):
        CompensationRequest(robot, programs=("a.src", "b.src"), out_dir=Path("out"), jobs=2, scheduler="tcp://x:1")
    with pytest.raises(InputError, match="--tol must be > 0"):
        CompensationRequest(robot, tol_mm=0.0)
    assert CompensationRequest(robot, programs=("a.src", "b.src"), out_dir=Path("out")).is_batch


def test_each_target_refuses_what_it_does_not_take(model):
    five = load_target(MACHINE)
    with pytest.raises(InputError, match="--tol, --subdivide: not used by the compensation of a five-axis machine"):
        CompensationRequest(five, programs=("p.ngc",), output="o.ngc", tol_mm=0.001, subdivide=True)
    with pytest.raises(InputError, match="--grid: not used by the compensation of a robot"):
        CompensationRequest(RobotTarget(model), grid=Path("g.csv"))
    with pytest.raises(InputError, match="takes one program"):
        CompensationRequest(five, programs=("a.ngc", "b.ngc"), output="o.ngc")


def test_the_target_is_told_by_content_not_suffix(tmp_path, model):
    save_model(tmp_path / "model.toml", model)  # a model JSON under a misleading name
    shutil.copy(MACHINE, tmp_path / "machine.json")  # a machine file under another
    robot, five = load_target(tmp_path / "model.toml"), load_target(tmp_path / "machine.json")
    assert isinstance(robot, RobotTarget) and isinstance(five, FiveAxisTarget)
    assert isinstance(robot, Machine) and isinstance(five, Machine)
    assert five.machine.name == "xyzac-trt" and robot.model.robot.name == model.robot.name
    (tmp_path / "notes.txt").write_text("title = 'not a machine'\n")
    with pytest.raises(ModelFileError, match="notes.txt: neither a model file"):
        load_target(tmp_path / "notes.txt")


def test_the_targets_kinematics_go_both_ways(model):
    robot = RobotTarget(model)
    q = np.array([[10.0, -70.0, 100.0, 5.0, 30.0, -20.0]])
    branches = robot.inverse(robot.forward(q))
    assert np.nanmin(np.abs(branches - q).max(axis=2)) < 1e-6
    assert np.linalg.norm(robot.predict(q) - robot.forward(q)[:, :3, 3]) > 0.01  # the model moves the point
    five = load_target(MACHINE)
    axes = np.array([[10.0, 20.0, -30.0, 15.0, 40.0]])
    np.testing.assert_allclose(five.inverse(five.forward(axes))[:, :3], axes[:, :3], atol=1e-6)
    assert np.linalg.norm(five.predict(axes) - five.forward(axes)[:, :3, 3]) > 1e-4  # the true machine is not the nominal one


def test_keyword_compensate_is_the_request(program, model):
    tp = parse_program(program)
    old, old_rep = compensate(tp, model, tol_mm=0.001, max_iter=30)
    new, new_rep = compensate_with(CompensationRequest(RobotTarget(model), tol_mm=0.001, max_iter=30), tp)
    np.testing.assert_array_equal(old.position, new.position)
    assert old_rep.summary() == new_rep.summary()
    assert not np.allclose(new.position, tp.position)  # it did compensate


def test_keyword_post_is_the_request(program, model):
    text = program.read_text()
    request = CompensationRequest(RobotTarget(model), output="cell.src", tol_mm=0.001)
    files = post_request(request, text, "krl")
    assert postproc.post(text, model, "krl", output="cell.src", tol_mm=0.001) == files and set(files) == {"cell.src", "cell.dat"}


def test_keyword_stream_is_the_request(tmp_path, program, model):
    a = compensate_streamed(program, model, tmp_path / "a.src", chunk_lines=5, workers=0)
    request = CompensationRequest(RobotTarget(model), programs=(str(program),), output=str(tmp_path / "b.src"))
    b = stream_request(request, chunk_lines=5, workers=0)
    assert a.summary == b.summary and a.summary["chunks"] > 1
    assert (tmp_path / "a.src").read_text() == (tmp_path / "b.src").read_text()


def test_cli_takes_a_machine_file_by_content(tmp_path):
    shutil.copy(MACHINE, tmp_path / "machine.cfg")
    (tmp_path / "p.ngc").write_text("G21 G90 G54\nG0 X0 Y0 Z5 A0 C0\nG1 X1 A0 C0 F100\nG1 X2 A5 C10\nM2\n")
    res = runner.invoke(app, ["compensate", str(tmp_path / "p.ngc"), "--model", str(tmp_path / "machine.cfg"),
                              "-o", str(tmp_path / "o.ngc"), "--input-axes", "tip", "--frame", "G54=0,0,0,0,0,0"])
    assert res.exit_code == 0, res.output
    assert "targets compensated for" in res.output and (tmp_path / "o.ngc").exists()


def test_what_the_chunks_cannot_carry_is_compensated_whole(model):
    """--subdivide and --force-file need the whole program: never the streamed way (which
    would leave them out), whatever --stream says."""
    robot = RobotTarget(model, "m.json")
    base = {"programs": ("p.src",), "output": "o.src", "stream": "always"}
    assert _can_stream(CompensationRequest(robot, **base))
    assert not _can_stream(CompensationRequest(robot, subdivide=True, **base))
    assert not _can_stream(CompensationRequest(robot, force_file=Path("f.csv"), **base))


def test_the_targets_read_and_write_programs(program, model, tmp_path):
    robot, five = RobotTarget(model), load_target(MACHINE)
    tp = robot.read_program(program)
    assert robot.write_texts(tp, tp) == [KRL] and len(tp) == 12
    ngc = tmp_path / "p.ngc"
    ngc.write_text("G21 G90 G54\nG0 X0 Y0 Z5 A0 C0\nG1 X1 A0 C0 F100\nM2\n")
    tp = five.read_program(ngc)
    moved = tp.with_positions(tp.position + 1.0)
    assert five.write_texts(tp, moved) == ["G21 G90 G54\nG0 X1 Y1 Z6 A0 C0\nG1 X2 A0 C0 F100\nM2\n"]
