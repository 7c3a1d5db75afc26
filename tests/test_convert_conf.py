"""convert --to fanuc / --to inform from another language: a joint motion's configuration data
(Fanuc CONFIG, INFORM ///RCONF form) computed with --robot from the joints the input's
controller takes, refused without it. Checked by reading the new program back: its
controller, by its own rules, takes the very joints the input's controller takes."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.jobs.convert_conf import joints_taken
from postproc.programs import parse_program

runner = CliRunner()

# an IRB 2400 program: two MoveJ to one point with two postures (cf4 = -2, cf6 = -2: the
# wrist turned half a turn: J4 -169 J5 -71 J6 -146), a MoveL between
RAPID = """MODULE Part
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  PROC main()
    MoveJ [[1200,100,900],[0,0.2996257,0.9488147,0.0998752],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle;
    MoveL [[1200,300,900],[0,0.2996257,0.9488147,0.0998752],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v250, fine, tSpindle;
    MoveJ [[1200,100,900],[0,0.2996257,0.9488147,0.0998752],[0,-2,-2,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle;
  ENDPROC
ENDMODULE
"""


@pytest.fixture()
def source(tmp_path):
    path = tmp_path / "part.mod"
    path.write_text(RAPID)
    return path


@pytest.mark.parametrize("to, name, tool", [("fanuc", "part.ls", "UTOOL[1]"), ("inform", "PART.JBI", "TOOL#(0)")])
def test_the_new_program_takes_the_joints_the_input_takes(source, to, name, tool):
    robot = postproc.load_robot("irb2400_10")
    out = source.parent / name
    res = runner.invoke(app, ["convert", str(source), "--to", to, "-o", str(out), "--robot", "irb2400_10"])
    assert res.exit_code == 0, res.output
    tp = parse_program(source)
    back = parse_program(out).with_frames(tools={tool: tp.tools[tp.tool[0]]})
    q_in, _ = joints_taken(tp, robot)
    q_out, _ = joints_taken(back, robot)
    np.testing.assert_allclose(q_in[[0, 2]], [[2.23, 26.95, -12.02, 11.38, 71.49, 33.99], [2.23, 26.95, -12.02, -168.62, -71.49, -146.01]], atol=0.01)
    np.testing.assert_allclose(q_out, q_in, atol=1e-3)
    assert "is written where the input gives no" not in out.read_text()  # every CONFIG computed, none a placeholder


@pytest.mark.parametrize("to, name", [("fanuc", "part.ls"), ("inform", "PART.JBI")])
def test_a_joint_motion_without_a_robot_is_refused_where_it_is(source, to, name):
    out = source.parent / name
    res = runner.invoke(app, ["convert", str(source), "--to", to, "-o", str(out)])
    assert res.exit_code == 2
    assert f"{source}:4:13: a joint motion to a Cartesian target" in res.output and "--robot" in res.output
    assert not out.exists()


def test_linear_motions_alone_need_no_robot_and_the_placeholder_is_named(tmp_path):
    path = tmp_path / "lin.mod"
    path.write_text(RAPID.replace("MoveJ", "MoveL"))
    res = runner.invoke(app, ["convert", str(path), "--to", "fanuc", "-o", str(tmp_path / "lin.ls")])
    assert res.exit_code == 0, res.output
    assert "L and C motions keep the posture the robot is in" in (tmp_path / "lin.ls").read_text()


def test_val3_movej_points_carry_the_configuration_of_the_joints(source):
    """--to val3 --robot: each movej point's shoulder / elbow / wrist are those of the joints the
    input's controller takes; the VAL3 rules, read back, take the same joints."""
    robot = postproc.load_robot("irb2400_10")
    out = source.parent / "part.pgx"
    res = runner.invoke(app, ["convert", str(source), "--to", "val3", "-o", str(out), "--robot", "irb2400_10"])
    assert res.exit_code == 0, res.output
    tp = parse_program(source)
    back = parse_program(out)
    q_in, _ = joints_taken(tp, robot)
    q_out, _ = joints_taken(back, robot)
    np.testing.assert_allclose(q_out, q_in, atol=1e-3)
    data = (source.parent / "part.dtx").read_text()
    assert data.count('shoulder="lefty"') == 2 and 'wrist="wpositive"' in data and 'wrist="wnegative"' in data
