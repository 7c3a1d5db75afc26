"""Pulse positions (the normal form of taught INFORM jobs) placed wherever a robot is known:
``inspect --robot``, ``convert --robot``, and the model's robot of ``compensate`` and
``predict`` (``Dialect.with_robot``). The expected joints are written by hand from the
controller's rule angle = (pulse - zero) / pulses per degree with the GP25 file's figures,
taken here as a controller's own (``measured_gp25``): the bundled file's are estimates, with
which pulse positions stay unplaced (never guessed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.jobs.compensate import compensate, predicted_positions
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import language_of, parse_program
from postproc.robot import kinematics as kin

Q0 = np.array([0.0, 10.0, -10.0, 0.0, -60.0, 0.0])  # the MOVJ's joints, deg
PULSES = [0, 13440, -13440, 0, -54600, 0]  # Q0 times the GP25 file's pulses per degree (1344 x3, 910 x2, 546)
TOOL = np.eye(4)
TOOL[:3, 3] = [0.0, 0.0, 150.0]


def _job(robot) -> bytes:
    """A pulse MOVJ, then two MOVLs to RECTAN positions 20 and 40 mm along x from it."""
    flange = kin.fk(robot, Q0[None])[0]
    tcp = flange @ TOOL
    rx, ry, rz = Rotation.from_matrix(tcp[:3, :3]).as_euler("xyz", degrees=True)
    rect = [f"C{k:05d}={tcp[0, 3] + 20.0 * k:.3f},{tcp[1, 3]:.3f},{tcp[2, 3]:.3f},{rx:.4f},{ry:.4f},{rz:.4f}" for k in (1, 2)]
    lines = ["/JOB", "//NAME PULSED", "//POS", "///NPOS 3,0,0,0,0,0", "///TOOL 0", "///POSTYPE PULSE", "///PULSE",
             "C00000=" + ",".join(map(str, PULSES)), "///POSTYPE ROBOT", "///RECTAN", *rect, "//INST", "///ATTR SC,RW",
             "///GROUP1 RB1", "NOP", "MOVJ C00000 VJ=25.00", "MOVL C00001 V=100.0", "MOVL C00002 V=100.0 PL=0", "END", ""]
    return "\r\n".join(lines).encode()


def measured_gp25(folder) -> str:
    """A GP25 robot file whose [pulses] are a controller's own (the bundled one's are estimates)."""
    text = (Path(postproc.__file__).parent.parent / "robots" / "gp25.toml").read_text()
    head, pulses = text.split("[pulses]", 1)
    path = Path(folder) / "measured" / "gp25.toml"  # (a robot file is named after its robot)
    path.parent.mkdir(exist_ok=True)
    path.write_text(head + "[pulses]" + pulses.replace("estimate = true", "estimate = false", 1))
    return str(path)


def _model(folder):
    return ErrorModel.create(postproc.load_robot(measured_gp25(folder)), TOOL[:3, 3], parse_effects("thermal"), {"thermal.alpha": 1.2e-5})


def test_compensate_and_predict_place_the_pulse_positions_with_the_models_robot(tmp_path):
    model = _model(tmp_path)
    tp = parse_program("PULSED.JBI", data=_job(model.robot))
    assert not tp.resolved[0]  # read alone, the pulses are not angles
    tools = {"TOOL#(0)": TOOL}
    new, report = compensate(tp, model, tools=tools, temp_c=40.0)
    assert not report.failed.any(), report.failures()
    assert report.compensated[1:].all()
    # the MOVLs after the pulse MOVJ keep its posture: nothing is assumed (without the pulse
    # data the core would take the posture nearest to all-zero joints and say so)
    assert not any("posture nearest to all-zero joints is assumed" in n for n in new.notes), new.notes
    assert any("pulse position(s) turned into joint angles" in n for n in new.notes)
    rows, predicted, _ = predicted_positions(tp, model, tools=tools, temp_c=20.0)
    np.testing.assert_allclose(predicted, tp.with_frames(tools=tools).base_positions()[rows], atol=1e-6)


def test_inspect_and_convert_take_a_robot(tmp_path):
    path = tmp_path / "PULSED.JBI"
    path.write_bytes(_job(postproc.load_robot("gp25")))
    runner = CliRunner()
    plain = json.loads(runner.invoke(app, ["inspect", str(path), "--json"]).stdout)
    assert "joints" not in plain["moves"][0]
    estimated = json.loads(runner.invoke(app, ["inspect", str(path), "--json", "--robot", "gp25"]).stdout)
    assert "joints" not in estimated["moves"][0] and any("are estimates" in n for n in estimated["notes"])
    res = runner.invoke(app, ["inspect", str(path), "--json", "--robot", measured_gp25(tmp_path)])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    np.testing.assert_allclose(doc["moves"][0]["joints"], Q0, atol=1e-9)
    assert any("pulse position(s) turned into joint angles" in n for n in doc["notes"])
    out = tmp_path / "pulsed.script"
    res = runner.invoke(app, ["convert", str(path), "--to", "urscript", "-o", str(out), "--robot", measured_gp25(tmp_path), "--tool", "TOOL#(0)=0,0,150"])
    assert res.exit_code == 0, res.output
    assert "movej([0, 0.1745329, -0.1745329, 0, -1.0471976, 0])" in out.read_text()  # Q0 in radians


def test_a_robot_without_pulse_data_leaves_them_unplaced_and_says_why():
    tp = parse_program("PULSED.JBI", data=_job(postproc.load_robot("gp25")))
    kr = postproc.load_robot("kr160_r1570")
    same = language_of(tp).with_robot(tp, kr)
    assert not same.resolved[0] and any("no [pulses] section" in n for n in same.notes)


def test_compensate_cli_uses_the_models_pulse_data(tmp_path):
    model_path = tmp_path / "m.json"
    save_model(model_path, _model(tmp_path))
    path = tmp_path / "PULSED.JBI"
    path.write_bytes(_job(postproc.load_robot("gp25")))
    res = CliRunner().invoke(app, ["compensate", str(path), "--model", str(model_path), "-o", str(tmp_path / "OUT.JBI"),
                                   "--tool", "TOOL#(0)=0,0,150", "--temp", "40"])
    assert res.exit_code == 0, res.output
    assert "C00000=" + ",".join(map(str, PULSES)) in (tmp_path / "OUT.JBI").read_text()


def test_joint_targets_of_another_language_are_written_as_pulse_positions(tmp_path):
    """A RAPID MoveAbsJ becomes a MOVJ to a ///PULSE position: pulse = angle x pulses per degree
    + zero (the robot file's [pulses], the controller's); read back with the same robot file it
    gives the same joints. With the bundled (estimated) pulses, or no --robot, refused."""
    mod = tmp_path / "j.mod"
    mod.write_text("MODULE J\n  PROC main()\n    MoveAbsJ [[0,10,-10,0,-60,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\n  ENDPROC\nENDMODULE\n")
    runner, out, robot = CliRunner(), tmp_path / "J.JBI", measured_gp25(tmp_path)
    for extra in ([], ["--robot", "gp25"]):
        res = runner.invoke(app, ["convert", str(mod), "--to", "inform", "-o", str(out), *extra])
        assert res.exit_code == 2 and "encoder pulses" in res.output and not out.exists(), res.output
    res = runner.invoke(app, ["convert", str(mod), "--to", "inform", "-o", str(out), "--robot", robot])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "///POSTYPE PULSE" in text and "C00000=" + ",".join(map(str, PULSES)) in text
    doc = json.loads(runner.invoke(app, ["inspect", str(out), "--json", "--robot", robot]).stdout)
    np.testing.assert_allclose(doc["moves"][0]["joints"], Q0, atol=1e-9)
