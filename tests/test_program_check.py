"""The model is checked against the program (issue 13): robot, tool and payload; a mismatch
is an error naming both (exit 2, nothing written), or notes with --allow-model-mismatch."""

from __future__ import annotations

import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.jobs.program_check import ModelMismatchError, check_model_fits
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import parse_program

runner = CliRunner()
TOOL = [0.0, 0.0, 200.0]


def _model(tmp_path, effects="geometric,joint_compliance"):
    model = ErrorModel.create(kr160(), TOOL, parse_effects(effects))
    path = tmp_path / "model.json"
    save_model(path, model)
    return path


def _krl(tmp_path, tool="X 0, Y 0, Z 200, A 0, B 0, C 0", extra=(), ptp="PTP {X 1000, Y -50, Z 500, A 0, B 180, C 0}"):
    lines = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", f"$TOOL = {{{tool}}}", *extra, ptp,
             "LIN {X 1000, Y 0, Z 500, A 0, B 180, C 0}", "LIN {X 1000, Y 50, Z 500, A 0, B 180, C 0}", "END"]
    (tmp_path / "part.src").write_text("\n".join(lines) + "\n")
    return tmp_path / "part.src"


def _run(tmp_path, program, model, *extra):
    out = tmp_path / "out.src"
    res = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), *extra])
    return res, out


def test_matching_program_and_model_pass(tmp_path):
    res, out = _run(tmp_path, _krl(tmp_path), _model(tmp_path), "--robot", "kr160_r1570")
    assert res.exit_code == 0, res.output
    assert out.exists() and "note:" not in res.output.replace("note: the program sets", "")


def test_another_robot_named_is_an_error_naming_both(tmp_path):
    res, out = _run(tmp_path, _krl(tmp_path), _model(tmp_path), "--robot", "kr6_r900")
    assert res.exit_code == 2 and "--robot kr6_r900" in res.output and "is for robot kr160_r1570" in res.output
    assert not out.exists()


def test_a_joint_target_outside_the_models_robot_is_an_error_with_its_line(tmp_path):
    lower = kr160().lower_deg[2]
    program = _krl(tmp_path, ptp=f"PTP {{A1 0, A2 -60, A3 {lower - 20:g}, A4 0, A5 60, A6 0}}")
    res, out = _run(tmp_path, program, _model(tmp_path))
    assert res.exit_code == 2, res.output
    assert "part.src, line 4: axis 3" in res.output and "kr160_r1570" in res.output and "another robot" in res.output
    assert not out.exists()


def test_another_tool_is_an_error_naming_both_unless_allowed(tmp_path):
    program, model = _krl(tmp_path, tool="X 0, Y 0, Z 250, A 0, B 0, C 0"), _model(tmp_path)
    res, out = _run(tmp_path, program, model)
    assert res.exit_code == 2
    text = " ".join(res.output.split())
    assert "part.src, line 4: the program's tool" in text and "(0, 0, 250) mm" in text and "fitted for the tool at (0, 0, 200) mm" in text
    assert not out.exists()
    res, out = _run(tmp_path, program, model, "--allow-model-mismatch")
    assert res.exit_code == 0 and "note:" in res.output and "(0, 0, 250)" in " ".join(res.output.split())
    assert out.exists()


def test_krl_payload_against_the_models_payload(tmp_path):
    model = _model(tmp_path, "geometric,joint_compliance[payload=20]")
    res, out = _run(tmp_path, _krl(tmp_path, extra=["$LOAD = {M 50, CM {X 0, Y 0, Z 100, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}"]), model)
    assert res.exit_code == 2 and "line 4: the program's payload is 50 kg" in " ".join(res.output.split()) and "fitted with 20 kg" in res.output
    assert not out.exists()
    res, _ = _run(tmp_path, _krl(tmp_path, extra=["$LOAD.M = 20.2"]), model)
    assert res.exit_code == 0, res.output


def test_krl_load_data_selected_by_bas_comes_from_config_dat(tmp_path):
    (tmp_path / "$config.dat").write_text("DEFDAT $CONFIG\nLOAD_DATA[3]={M 35,CM {X 0,Y 0,Z 0,A 0,B 0,C 0},J {X 0,Y 0,Z 0}}\nENDDAT\n")
    program = _krl(tmp_path, extra=["BAS(#TOOL, 3)"])
    tp = parse_program(program)
    from postproc.model.model_io import load_model

    model, _ = load_model(_model(tmp_path, "geometric,joint_compliance[payload=20]"))
    with pytest.raises(ModelMismatchError, match=r"line 4 \(LOAD_DATA\[3\]\): the program's payload is 35 kg"):
        check_model_fits(tp, model, "m.json")
    assert check_model_fits(tp, model, "m.json", allow=True)


RAPID = """MODULE part
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[MASS,[0,0,100],[1,0,0,0],0,0,0]];
  PROC main()
    MoveAbsJ [[0,-10,10,0,60,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tSpindle;
    MoveL [[1000,0,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tSpindle;
  ENDPROC
ENDMODULE
"""


def test_rapid_tooldata_load_against_the_models_payload(tmp_path):
    from postproc.model.model_io import load_model

    model, _ = load_model(_model(tmp_path, "geometric,joint_compliance[payload=20]"))
    for mass, ok in (("20", True), ("8.5", False)):
        (tmp_path / "part.mod").write_text(RAPID.replace("MASS", mass))
        tp = parse_program(tmp_path / "part.mod")
        if ok:  # a RAPID program is for an ABB robot: the KUKA model's maker is the one mismatch, not the payload
            mismatches = check_model_fits(tp, model, "m.json", allow=True)
            assert len(mismatches) == 1 and "the language of ABB controllers" in mismatches[0], mismatches
        else:
            with pytest.raises(ModelMismatchError, match=r"part.mod, line 2 \(tooldata tSpindle\): the program's payload is 8.5 kg; the model m.json was fitted with 20 kg"):
                check_model_fits(tp, model, "m.json")


def test_many_programs_each_checked(tmp_path):
    good = tmp_path / "a"
    bad = tmp_path / "b"
    good.mkdir(), bad.mkdir()
    model = _model(tmp_path)
    other = _krl(bad, tool="X 0, Y 0, Z 300, A 0, B 0, C 0")
    programs = [_krl(good), other.rename(bad / "other.src")]
    (tmp_path / "o").mkdir()
    res = runner.invoke(app, ["compensate", *map(str, programs), "--model", str(model), "--out-dir", str(tmp_path / "o"), "--jobs", "1"])
    assert res.exit_code == 1, res.output
    assert "fitted for the tool at (0, 0, 200) mm" in " ".join(res.output.split())
    assert (tmp_path / "o" / "part.src").exists() and not (tmp_path / "o" / "other.src").exists()


# ---------------------------------------------------------------- the payload a model was fitted at


def test_a_gravity_model_that_states_no_payload_is_refused_for_a_program_with_a_load(tmp_path):
    """joint_compliance without payload=: the load on the flange while measuring hides in the
    compliances, so the model cannot say it fits a program carrying 50 kg: refused, naming both."""
    program = _krl(tmp_path, extra=["$LOAD.M = 50"])
    res, out = _run(tmp_path, program, _model(tmp_path, "geometric,joint_compliance"))
    text = " ".join(res.output.split())
    assert res.exit_code == 2, res.output
    assert "part.src, line 4: the program's payload is 50 kg" in text and "model.json has joint_compliance" in text
    assert "does not state the payload it was fitted at" in text and "joint_compliance[payload=KG]" in text
    assert not out.exists()
    res, out = _run(tmp_path, program, _model(tmp_path, "geometric,joint_compliance"), "--allow-model-mismatch")
    assert res.exit_code == 0 and "note:" in res.output and out.exists()


@pytest.mark.parametrize("effects", ["geometric,nonlinear_stiffness[joints=2,3]", "geometric,link_bending", "geometric,base_tilt"])
def test_every_effect_gravity_drives_needs_the_payload(tmp_path, effects):
    res, out = _run(tmp_path, _krl(tmp_path, extra=["$LOAD.M = 50"]), _model(tmp_path, effects))
    assert res.exit_code == 2 and effects.split(",")[1].split("[")[0] in res.output, res.output
    assert not out.exists()


def test_a_payload_stated_as_zero_is_compared(tmp_path):
    model = _model(tmp_path, "geometric,joint_compliance[payload=0]")
    from postproc.model.model_io import load_model

    assert load_model(model)[0].effects.spec() == "geometric,joint_compliance[payload=0.0;payload_com=0.0,0.0,0.0]"
    res, out = _run(tmp_path, _krl(tmp_path, extra=["$LOAD.M = 50"]), model)
    assert res.exit_code == 2 and "payload is 50 kg" in res.output and "fitted with 0 kg" in res.output
    assert not out.exists()
    res, out = _run(tmp_path, _krl(tmp_path, extra=["$LOAD.M = 0.3"]), model)
    assert res.exit_code == 0, res.output


def test_no_payload_to_compare_passes(tmp_path):
    # A model that gravity does not drive predicts the same under any load; a program that
    # states no load has nothing to compare.
    res, out = _run(tmp_path, _krl(tmp_path, extra=["$LOAD.M = 50"]), _model(tmp_path, "geometric,base_frame"))
    assert res.exit_code == 0, res.output
    res, out = _run(tmp_path, _krl(tmp_path), _model(tmp_path, "geometric,joint_compliance"))
    assert res.exit_code == 0, res.output


GRIP = """MODULE part
  PERS tooldata tGrip := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,100],[1,0,0,0],0,0,0]];
  PERS loaddata box := [25,[0,0,150],[1,0,0,0],0,0,0];
  PROC main()
    MoveAbsJ [[0,-10,10,0,60,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tGrip;
    GripLoad box;
    MoveL [[1000,0,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tGrip;
    MoveL [[1000,50,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tGrip\\TLoad:=box;
  ENDPROC
ENDMODULE
"""


def test_rapid_gripload_and_tload_are_the_payload(tmp_path):
    from postproc.model.model_io import load_model

    (tmp_path / "part.mod").write_text(GRIP)
    tp = parse_program(tmp_path / "part.mod")
    model, _ = load_model(_model(tmp_path, "geometric,joint_compliance[payload=10]"))
    problems = check_model_fits(tp, model, "m.json", allow=True)
    text = "\n".join(problems)
    assert "part.mod, line 6 (GripLoad box): the program's payload is 35 kg" in text  # the tool's 10 kg and the box's 25
    assert "part.mod, line 8 (\\TLoad:=box): the program's payload is 25 kg" in text
    assert "tooldata" not in text  # the tool alone carries the 10 kg the model was fitted with
    with pytest.raises(ModelMismatchError, match="fitted with 10 kg"):
        check_model_fits(tp, model, "m.json")
