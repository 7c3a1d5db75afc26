"""`convert --tool-load MASS,CX,CY,CZ[,IX,IY,IZ]` (issue 12): the real load written where the
controller reads it (RAPID tooldata's tload, RAPID GripLoad for tool0, KRL $LOAD), so that a
model fitted at that payload compensates the converted program without
--allow-model-mismatch; a bad value is exit 2 naming the option, nothing written.

ABB: RAPID reference, "tooldata" (tload: mass kg, cog mm in the wrist frame, aom, ix iy iz
kg m^2) and "loaddata", "GripLoad". KUKA: KSS 8 system variables, "$LOAD" (M kg, CM frame
relative to the flange, J kg m^2).
"""

from __future__ import annotations

import re

import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import dialects, parse_program

runner = CliRunner()
GCODE = "G21 G90 F600\nG43 H1\nG0 X0 Y-50 Z0\nG1 X0 Y0 Z0\nG1 X0 Y50 Z0\nM2\n"
PLACE = ["--tool", "H1=0,0,200", "--frame", "G54=1000,0,500,0,0,0"]
RAPID_TOOL0 = """MODULE part
  PROC main()
    MoveJ [[1000,0,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;
    MoveL [[1000,50,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;
  ENDPROC
ENDMODULE
"""


def _convert(tmp_path, to, *extra, text=GCODE, name="part.ngc"):
    src = tmp_path / name
    src.write_text(text)
    out = tmp_path / ("new.src" if to == "krl" else "new.mod")
    res = runner.invoke(app, ["convert", str(src), "--to", to, "-o", str(out), *extra])
    return res, out


def _payloads(path):
    tp = parse_program(path)
    return [mass for mass, _ in dialects.of(tp).controller.payloads(tp)]


def test_rapid_tooldata_carries_the_given_load_and_no_placeholder(tmp_path):
    res, out = _convert(tmp_path, "rapid", *PLACE, "--tool-load", "12.5,1,-2,80,0.05,0.04,0.01")
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "PERS tooldata H1 := [TRUE,[[0,0,200],[1,0,0,0]],[12.5,[1,-2,80],[1,0,0,0],0.05,0.04,0.01]];" in text
    assert "placeholder" not in text
    assert _payloads(out) == [12.5]


def test_without_the_option_the_rapid_placeholder_stays_and_names_the_option(tmp_path):
    res, out = _convert(tmp_path, "rapid", *PLACE)
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "[1,[0,0,1],[1,0,0,0],0,0,0]]" in text and re.search(r"! H1: load 1 kg .* placeholder .*--tool-load", text)


def test_rapid_tool0_grips_the_load(tmp_path):
    """tool0 is the controller's own (no load of its own): the load is a GripLoad of a loaddata."""
    res, out = _convert(tmp_path, "rapid", "--tool-load", "20,0,0,100", text=RAPID_TOOL0, name="part.mod")
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "PERS loaddata tool_load := [20,[0,0,100],[1,0,0,0],0,0,0];" in text
    assert text.index("GripLoad tool_load;") < text.index("MoveJ")
    assert _payloads(out) == [20.0]


def test_krl_writes_load_with_the_tool(tmp_path):
    res, out = _convert(tmp_path, "krl", *PLACE, "--tool-load", "7,0,0,95")
    assert res.exit_code == 0, res.output
    lines = out.read_text().splitlines()
    at = lines.index("$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}")
    assert lines[at + 1] == "$LOAD = {M 7, CM {X 0, Y 0, Z 95, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}"
    assert _payloads(out) == [7.0]
    res, out = _convert(tmp_path, "krl", *PLACE)  # without it: $LOAD stays as the controller has it (nothing written)
    assert "$LOAD" not in out.read_text()


@pytest.mark.parametrize("to", ["krl", "rapid"])
def test_a_model_fitted_at_the_given_payload_compensates_without_allowing_a_mismatch(to, tmp_path):
    model = tmp_path / "m20.json"
    save_model(model, ErrorModel.create(kr160(), [0.0, 0.0, 200.0], parse_effects("geometric,joint_compliance[payload=20]")))
    # A RAPID program is for an ABB robot: with this KUKA model it takes --allow-model-mismatch,
    # and the payload's mismatch is then a note beside the robot's, not an error.
    allow = ["--allow-model-mismatch"] if to == "rapid" else []
    for load, code in (("20,0,0,100", 0), ("8,0,0,100", 0 if allow else 2)):
        res, out = _convert(tmp_path, to, *PLACE, "--tool-load", load)
        assert res.exit_code == 0, res.output
        comp = tmp_path / f"comp{out.suffix}"
        res = runner.invoke(app, ["compensate", str(out), "--model", str(model), "-o", str(comp), *allow])
        assert res.exit_code == code, res.output
        assert ("payload is 8 kg" in res.output and "fitted with 20 kg" in res.output) == load.startswith("8")


@pytest.mark.parametrize("value, why", [
    ("0,0,0,100", "the mass must be > 0"), ("-2,0,0,100", "the mass must be > 0"), ("nan,0,0,100", "finite"),
    ("2,inf,0,100", "finite"), ("2,0,0", "got 3 values"), ("2,0,0,100,1", "got 5 values"), ("2,x,0,100", "expected numbers"),
    ("2,0,0,100,-0.1,0,0", "inertia cannot be negative"),
])
@pytest.mark.parametrize("to", ["krl", "rapid"])
def test_a_bad_load_is_exit_2_naming_the_option_and_nothing_is_written(value, why, to, tmp_path):
    res, out = _convert(tmp_path, to, *PLACE, "--tool-load", value)
    assert res.exit_code == 2
    assert "--tool-load" in res.output and why in " ".join(res.output.split())
    assert not out.exists() and not out.with_suffix(".dat").exists()


def test_the_option_is_refused_for_a_five_axis_gcode_output(tmp_path):
    res, _ = _convert(tmp_path, "gcode", "--machine", "xyzac-trt", "--rtcp", "linuxcnc", "--tool-load", "2,0,0,100")
    assert res.exit_code == 2 and "--tool-load" in res.output
