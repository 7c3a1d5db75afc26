"""Cutting force in compensation (issues 13 and 16): the mechanistic force of every cutting
move (--cut) deflects the robot through the model's external_load effect, and compensation
pre-compensates that deflection with the rest of the model."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from helpers import TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.jobs.compensate import compensate
from postproc.model.effects import parse_effects
from postproc.model.model_io import save_model
from postproc.model.sim import random_truth
from postproc.process.forces import load_cut_params, program_forces
from postproc.programs import emit_texts, parse_program

CUT = Path(__file__).resolve().parents[1] / "examples" / "cut_aluminium.toml"
runner = CliRunner()


@pytest.fixture(scope="module")
def model():
    return random_truth(kr160(), TOOL, parse_effects("geometric,external_load"), np.random.default_rng(11))


def _program(tmp_path):
    from postproc.robot import kinematics as kin
    from postproc.robot.frames import abc_to_matrix

    # An axis PTP to the first target's own joints: the straight moves start where the robot stands.
    first = np.eye(4)
    first[:3, :3] = abc_to_matrix(np.array([[0.0, 180.0, 0.0]]))[0]
    first[:3, 3] = [1000.0, -200.0, 450.0 + TOOL[2]]  # flange above the tool tip (tool along the flange z, pointing down)
    q, _ = kin.select_nearest(kr160(), kin.ik(kr160(), first[None]), np.array([0.0, -60, 40, 0, 60, 0]))
    lines = ["DEF face( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", f"$TOOL = {{X 0, Y 0, Z {TOOL[2]:g}, A 0, B 0, C 0}}",
             "PTP {" + ", ".join(f"A{i + 1} {v:.6f}" for i, v in enumerate(q[0])) + "}"]
    lines += [f"LIN {{X {1000 + 20 * i:.1f}, Y {-200 + 40 * i:.1f}, Z 450.0, A 0, B 180, C 0}}" for i in range(10)]
    path = tmp_path / "face.src"
    path.write_text("\n".join(lines + ["END"]) + "\n")
    return path


def test_cutting_force_is_pre_compensated(model, tmp_path):
    tp = parse_program(_program(tmp_path))
    force = program_forces(tp, params=load_cut_params(CUT))
    assert np.abs(force[1:]).max() > 50.0 and not force[0].any()  # N on the LIN moves, none on the PTP
    new, report = compensate(tp, model, force_per_target=force)
    assert not report.failed.any(), report.failures()
    # Run the compensated numbers on the robot (the model itself as truth) under that force.
    (tmp_path / "out.src").write_text(emit_texts(tp, new)[0], encoding="latin-1")
    written = parse_program(tmp_path / "out.src")
    from postproc.robot import kinematics as kin
    from postproc.robot.posture import branch_of

    # The controller keeps the posture of the axis PTP along the LINs (KSS: LIN ignores S and T).
    flange = written.base_poses()[1:] @ np.linalg.inv(written.tools[written.tool[1:]])
    q = kin.ik(model.robot, flange)[:, branch_of(model.robot, written.joints[:1])[0]]
    m = replace(model, tool_mm=TOOL)
    reached = m.predict_prepared(m.prepare(q_deg=q, force_n=force[1:]))
    assert np.abs(reached - tp.base_poses()[1:, :3, 3]).max() < 0.011
    # Without the force the same targets come out elsewhere: the force moved them.
    unloaded, _ = compensate(tp, model, force_per_target=np.zeros_like(force))
    moved = np.linalg.norm(new.position[1:] - unloaded.position[1:], axis=1)
    assert moved.min() > 0.01


def test_cut_and_force_together_are_refused(model, tmp_path):
    model_path = tmp_path / "m.json"
    save_model(model_path, model)
    out = tmp_path / "o.src"
    result = runner.invoke(app, ["compensate", str(_program(tmp_path)), "--model", str(model_path), "-o", str(out),
                                 "--cut", str(CUT), "--force", "0,0,100"])
    assert result.exit_code == 2 and "either" in result.output and not out.exists()
    result = runner.invoke(app, ["compensate", str(_program(tmp_path)), "--model", str(model_path), "-o", str(out), "--cut", str(CUT)])
    assert result.exit_code == 0, result.output
    assert out.exists()
