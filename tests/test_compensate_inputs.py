"""Process inputs at compensation time (issue 13): --force and --temp change the prediction
through the model's effects that consume them, and an option no effect of the model uses
is an error (exit 2), never a silent no-op."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import parse_program
from postproc.robot import kinematics as kin

runner = CliRunner()
FORCE_TOOL = np.array([100.0, -50.0, 400.0])  # N, tool frame


def _program(tmp_path):
    src = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}"]
    for k, (x, y) in enumerate([(900, -200), (1000, 0), (1100, 200), (950, 150), (1050, -150)]):
        src.append(f"LIN {{X {x}.000, Y {y}.000, Z {400 + 10 * k}.000, A {10 * k}, B 180, C 0}}")
    src.append("END")
    path = tmp_path / "part.src"
    path.write_text("\r\n".join(src) + "\r\n")
    return path


def _model(tmp_path, spec: str):
    path = tmp_path / f"{spec}.json"
    save_model(path, ErrorModel.create(kr160(), TOOL, parse_effects(spec)))
    return path


def _compensate(program, model, out, *options):
    return runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--tol", "0.001", *options])


def _joints(tp):
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, _ = kin.select_nearest(kr160(), kin.ik(kr160(), flange), np.array([0.0, -90.0, 90.0, 0.0, 45.0, 0.0]))
    return q


def test_force_moves_the_targets_by_the_predicted_deflection(tmp_path):
    program, model = _program(tmp_path), _model(tmp_path, "external_load")
    plain, loaded = tmp_path / "plain.src", tmp_path / "loaded.src"
    assert _compensate(program, model, plain, "--force", "0,0,0").exit_code == 0
    result = _compensate(program, model, loaded, "--force", ",".join(str(v) for v in FORCE_TOOL))
    assert result.exit_code == 0, result.output
    before, after = parse_program(plain), parse_program(loaded)
    moved = after.base_poses()[:, :3, 3] - before.base_poses()[:, :3, 3]
    # The deflection the force causes at those joints: delta p = J C J^T F, F in the base frame.
    q = _joints(before)
    force_base = before.base_poses()[:, :3, :3] @ FORCE_TOOL
    jac = kin.jacobian(kr160(), q, tool=TOOL)[:, :3]  # mm/rad
    torque = np.einsum("nij,ni->nj", jac, force_base) / 1000.0  # N*m
    deflection = np.einsum("nij,nj->ni", jac, torque / kr160().stiffness_nm_per_rad)
    assert np.linalg.norm(deflection, axis=1).min() > 0.1  # a force worth compensating
    np.testing.assert_allclose(moved, -deflection, atol=0.01)


def test_force_without_an_effect_that_uses_it_is_refused(tmp_path):
    program, model = _program(tmp_path), _model(tmp_path, "joint_compliance")
    out = tmp_path / "out.src"
    result = _compensate(program, model, out, "--force", "0,0,400")
    assert result.exit_code == 2 and "--force" in result.stderr and "external_load" in result.stderr, result.output
    assert not out.exists()
    result = _compensate(program, model, out, "--temp", "25")
    assert result.exit_code == 2 and "--temp" in result.stderr and "thermal" in result.stderr, result.output
    assert not out.exists()


@pytest.mark.parametrize(("spec", "option"), [("external_load", "--force"), ("thermal", "--temp")])
def test_an_effect_without_its_input_is_refused(tmp_path, spec, option):
    out = tmp_path / "out.src"
    result = _compensate(_program(tmp_path), _model(tmp_path, spec), out)
    assert result.exit_code == 2 and option in result.stderr and spec in result.stderr, result.output
    assert not out.exists()


def test_temperature_changes_the_targets_through_thermal(tmp_path):
    program = _program(tmp_path)
    model = tmp_path / "thermal.json"
    save_model(model, ErrorModel.create(kr160(), TOOL, parse_effects("thermal"), {"thermal.alpha": 1.2e-5}))
    cool, warm = tmp_path / "cool.src", tmp_path / "warm.src"
    assert _compensate(program, model, cool, "--temp", "20").exit_code == 0
    assert _compensate(program, model, warm, "--temp", "30").exit_code == 0
    at_20, at_30 = parse_program(cool).base_poses()[:, :3, 3], parse_program(warm).base_poses()[:, :3, 3]
    np.testing.assert_allclose(at_20, parse_program(program).base_poses()[:, :3, 3], atol=0.002)  # the reference temperature
    # 10 K warmer, the arm is 1.2e-4 longer: the targets are pulled in by about that fraction of the reach.
    shrink = np.linalg.norm(at_30, axis=1) / np.linalg.norm(at_20, axis=1) - 1
    assert np.all(shrink < -0.5e-4) and np.all(shrink > -2.5e-4)
