"""`convert` carries the tool load the input program states into the new program, where it applies.

The conventions, and so the hand-written expectations below:
- ABB RAPID reference manual (instructions, functions and data types), data type "loaddata"
  (and tooldata's tload): [mass kg, cog [x,y,z] mm in the tool0 (wrist) frame, aom [q1,q2,q3,q4]
  the orientation of the axes of moment, ix, iy, iz kg m^2 about them]; "GripLoad": the payload
  gripped from there on, added to the tool's load; ``GripLoad load0`` drops it.
- KUKA System Software 8 system variables, "$LOAD": {M kg, CM the frame of the centre of
  gravity relative to the flange {X, Y, Z mm, A, B, C deg: the principal axes of inertia},
  J {X, Y, Z} kg m^2 about them}; the whole load on the flange.
Both frames are the flange's (postproc writes $TOOL and tooldata's tframe in it too), so mass,
centre of gravity and moments carry unchanged; the axes turn as aom = the quaternion of
Rz(A) Ry(B) Rx(C) (B 90 <-> [cos 45, 0, sin 45, 0]). A GripLoad payload on top of a tool
load is one KUKA $LOAD: masses add, the centre of gravity is their mass-weighted mean, the
moments add by the parallel axis theorem (m d^2 about each axis, d in m).
"""

from __future__ import annotations

import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import dialects, parse_program

runner = CliRunner()
TARGET = "[[{x},0,0],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _rapid(tload: str, body: str, extra: str = "") -> str:
    return (f"MODULE part\n  PERS tooldata t1 := [TRUE,[[0,0,200],[1,0,0,0]],{tload}];\n"
            "  TASK PERS wobjdata w1 := [FALSE,TRUE,\"\",[[1000,0,500],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\n"
            f"{extra}  PROC main()\n{body}  ENDPROC\nENDMODULE\n")


def _move(x: int) -> str:
    return f"    MoveL {TARGET.format(x=x)}, v100, fine, t1\\WObj:=w1;\n"


KRL = """DEF part( )
$BASE = {X 1000, Y 0, Z 500, A 0, B 0, C 0}
$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}
$LOAD = {M 12.5, CM {X 0, Y -5, Z 120, A 0, B 90, C 0}, J {X 0.2, Y 0.1, Z 0.05}}
LIN {X 0, Y 0, Z 0, A 0, B 180, C 0}
$LOAD = {M 4, CM {X 0, Y 0, Z 50, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}
LIN {X 0, Y 50, Z 0, A 0, B 180, C 0}
END
"""
GRIP = _rapid("[3,[0,0,100],[1,0,0,0],0,0,0]", _move(0) + "    GripLoad piece;\n" + _move(50) + "    GripLoad load0;\n" + _move(100),
              "  PERS loaddata piece := [2,[0,0,200],[1,0,0,0],0,0,0];\n")


def _convert(tmp_path, text, name, to, *extra, out_name="new"):
    src = tmp_path / name
    src.write_text(text)
    out = tmp_path / f"{out_name}.{'src' if to == 'krl' else 'mod'}"
    res = runner.invoke(app, ["convert", str(src), "--to", to, "-o", str(out), *extra])
    return res, out


def _lines(path, word):
    return [line.strip() for line in path.read_text().splitlines() if word in line]


def test_rapid_tooldata_load_to_krl(tmp_path):
    """aom [0.7071068,0,0,0.7071068] is 90 deg about z: CM A 90, B 0, C 0."""
    res, out = _convert(tmp_path, _rapid("[5,[10,0,80],[0.7071068,0,0,0.7071068],0.01,0.02,0.03]", _move(0) + _move(50)), "part.mod", "krl")
    assert res.exit_code == 0, res.output
    assert _lines(out, "$LOAD") == ["$LOAD = {M 5, CM {X 10, Y 0, Z 80, A 90, B 0, C 0}, J {X 0.01, Y 0.02, Z 0.03}}"]
    lines = out.read_text().splitlines()
    assert lines.index("$LOAD = {M 5, CM {X 10, Y 0, Z 80, A 90, B 0, C 0}, J {X 0.01, Y 0.02, Z 0.03}}") == lines.index("$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}") + 1


def test_krl_loads_to_rapid_one_tooldata_per_load(tmp_path):
    """Two $LOAD under one $TOOL: RAPID's load lives in the tooldata, so each load gets its own
    tooldata of the same tool (t, t_2), used by the motions it applies to; B 90 -> aom [c45,0,s45,0]."""
    res, out = _convert(tmp_path, KRL, "part.src", "rapid")
    assert res.exit_code == 0, res.output
    decl = _lines(out, "PERS tooldata")
    tool = "X_0__Y_0__Z_200__A_0__B_0__C_0"
    assert decl == [f"PERS tooldata {tool} := [TRUE,[[0,0,200],[1,0,0,0]],[12.5,[0,-5,120],[0.7071068,0,0.7071068,0],0.2,0.1,0.05]];",
                    f"PERS tooldata {tool}_2 := [TRUE,[[0,0,200],[1,0,0,0]],[4,[0,0,50],[1,0,0,0],0,0,0]];"]
    moves = _lines(out, "MoveL")
    assert moves[0].endswith(f", {tool}\\WObj:=X_1000__Y_0__Z_500__A_0__B_0__C_0;") and f"{tool}_2\\WObj" in moves[1]
    assert "placeholder" not in out.read_text()
    tp = parse_program(out)
    assert [m for m, _ in dialects.of(tp).controller.payloads(tp)] == [12.5, 4.0]


def test_krl_to_krl_keeps_each_load_where_it_applies(tmp_path):
    res, out = _convert(tmp_path, KRL, "part.src", "krl")
    assert res.exit_code == 0, res.output
    lines = out.read_text().splitlines()
    first = "$LOAD = {M 12.5, CM {X 0, Y -5, Z 120, A 0, B 90, C 0}, J {X 0.2, Y 0.1, Z 0.05}}"
    second = "$LOAD = {M 4, CM {X 0, Y 0, Z 50, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}"
    assert _lines(out, "$LOAD") == [first, second]
    lin = [k for k, line in enumerate(lines) if line.startswith("LIN {X 0, Y ")]
    assert lines.index(first) < lin[0] < lines.index(second) < lin[1] and len(lin) == 2


def test_gripload_mid_program_rapid_to_rapid(tmp_path):
    res, out = _convert(tmp_path, GRIP, "part.mod", "rapid")
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert _lines(out, "PERS tooldata") == ["PERS tooldata t1 := [TRUE,[[0,0,200],[1,0,0,0]],[3,[0,0,100],[1,0,0,0],0,0,0]];"]
    assert _lines(out, "PERS loaddata") == ["PERS loaddata tool_load := [2,[0,0,200],[1,0,0,0],0,0,0];"]
    body = [line.strip().split(" [[")[0] for line in text.splitlines() if line.startswith("    ") and not line.strip().startswith(("!", "Conf"))]
    assert body == ["MoveL", "GripLoad tool_load;", "MoveL", "GripLoad load0;", "MoveL"]


def test_gripload_mid_program_rapid_to_krl_is_the_whole_load(tmp_path):
    """3 kg at z 100 + 2 kg at z 200 = 5 kg at z (300 + 400) / 5 = 140 mm; Ixx = Iyy =
    3 (0.04 m)^2 + 2 (0.06 m)^2 = 0.012 kg m^2, Izz = 0; after GripLoad load0 the tool's 3 kg again."""
    res, out = _convert(tmp_path, GRIP, "part.mod", "krl")
    assert res.exit_code == 0, res.output
    assert _lines(out, "$LOAD") == ["$LOAD = {M 3, CM {X 0, Y 0, Z 100, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}",
                                    "$LOAD = {M 5, CM {X 0, Y 0, Z 140, A 0, B 0, C 0}, J {X 0.012, Y 0.012, Z 0}}",
                                    "$LOAD = {M 3, CM {X 0, Y 0, Z 100, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}"]
    kinds = [line.split(" ")[0] for line in out.read_text().splitlines() if line.startswith(("LIN", "$LOAD"))]
    assert kinds == ["$LOAD", "LIN", "$LOAD", "LIN", "$LOAD", "LIN"]


def test_round_trip_rapid_krl_rapid_keeps_the_load(tmp_path):
    tload = "[5,[10,-3,80],[0.7071068,0,0,0.7071068],0.01,0.02,0.03]"
    res, krl = _convert(tmp_path, _rapid(tload, _move(0) + _move(50)), "part.mod", "krl", out_name="mid")
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["convert", str(krl), "--to", "rapid", "-o", str(tmp_path / "back.mod")])
    assert res.exit_code == 0, res.output
    decl = _lines(tmp_path / "back.mod", "PERS tooldata")
    assert len(decl) == 1 and decl[0].endswith(f",{tload}];")


@pytest.mark.parametrize("to", ["krl", "rapid"])
def test_tool_load_option_differing_from_the_programs_is_refused_naming_both(to, tmp_path):
    text = _rapid("[5,[10,0,80],[1,0,0,0],0,0,0]", _move(0))
    res, out = _convert(tmp_path, text, "part.mod", to, "--tool-load", "6,10,0,80")
    assert res.exit_code == 2
    msg = " ".join(res.output.split())
    assert "part.mod:2:8" in msg and "5 kg at (10, 0, 80) mm" in msg and "--tool-load gives 6 kg at (10, 0, 80) mm" in msg
    assert not out.exists()
    res, out = _convert(tmp_path, text, "part.mod", to, "--tool-load", "5,10,0,80")  # the same load: fine
    assert res.exit_code == 0, res.output


def test_a_partial_krl_load_needs_the_option_and_must_agree_with_it(tmp_path):
    text = KRL.replace("$LOAD = {M 12.5, CM {X 0, Y -5, Z 120, A 0, B 90, C 0}, J {X 0.2, Y 0.1, Z 0.05}}", "$LOAD.M = 4").replace(
        "$LOAD = {M 4, CM {X 0, Y 0, Z 50, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}\n", "")
    res, out = _convert(tmp_path, text, "part.src", "rapid")
    assert res.exit_code == 2 and "part.src:4:1" in res.output and "--tool-load" in res.output and not out.exists()
    res, out = _convert(tmp_path, text, "part.src", "rapid", "--tool-load", "5,0,0,50")
    assert res.exit_code == 2 and "4 kg" in res.output and "5 kg" in res.output
    res, out = _convert(tmp_path, text, "part.src", "rapid", "--tool-load", "4,0,0,50")
    assert res.exit_code == 0, res.output
    assert "[4,[0,0,50],[1,0,0,0],0,0,0]]" in out.read_text()


def test_tload_argument_is_refused_with_its_place(tmp_path):
    body = f"    MoveL {TARGET.format(x=0)}, v100, fine, t1\\TLoad:=piece\\WObj:=w1;\n"
    text = _rapid("[3,[0,0,100],[1,0,0,0],0,0,0]", body, "  PERS loaddata piece := [2,[0,0,200],[1,0,0,0],0,0,0];\n")
    res, out = _convert(tmp_path, text, "part.mod", "krl")
    assert res.exit_code == 2 and "part.mod:6:" in res.output and "TLoad" in res.output and not out.exists()


@pytest.mark.parametrize("to", ["krl", "rapid"])
def test_a_model_fitted_at_the_programs_payload_compensates_the_conversion(to, tmp_path):
    """No --tool-load: the 20 kg the input states reaches the output, and the payload check
    (program_check._payload) finds it: a 20 kg model passes without --allow-model-mismatch, an 8 kg one is refused."""
    text = _rapid("[20,[0,0,100],[1,0,0,0],0,0,0]", _move(0) + _move(50))
    res, out = _convert(tmp_path, text, "part.mod", to)
    assert res.exit_code == 0, res.output
    # A RAPID program is for an ABB robot: with this KUKA model it takes --allow-model-mismatch,
    # and the payload's mismatch is then a note beside the robot's, not an error.
    allow = ["--allow-model-mismatch"] if to == "rapid" else []
    for kg, code in ((20, 0), (8, 0 if allow else 2)):
        model = tmp_path / f"m{kg}.json"
        save_model(model, ErrorModel.create(kr160(), [0.0, 0.0, 200.0], parse_effects(f"geometric,joint_compliance[payload={kg}]")))
        res = runner.invoke(app, ["compensate", str(out), "--model", str(model), "-o", str(tmp_path / f"comp{kg}{out.suffix}"), *allow])
        assert res.exit_code == code, res.output
        assert ("payload is 20 kg" in res.output and "fitted with 8 kg" in res.output) == (kg == 8)


def test_gcode_input_is_unchanged(tmp_path):
    res, out = _convert(tmp_path, "G21 G90 F600\nG1 X0 Y0 Z0\nG1 X0 Y50 Z0\nM2\n", "part.ngc", "krl", "--frame", "G54=1000,0,500,0,0,0")
    assert res.exit_code == 0, res.output
    assert "$LOAD" not in out.read_text()


def test_a_gripload_in_a_routine_without_motions_is_refused(tmp_path):
    """Where a routine's GripLoad applies depends on where it is called: not carried, refused at its place."""
    text = GRIP.replace("    GripLoad piece;\n", "    pick;\n").replace("  PROC main()", "  PROC pick()\n    GripLoad piece;\n  ENDPROC\n  PROC main()")
    res, out = _convert(tmp_path, text, "part.mod", "krl")
    assert res.exit_code == 2 and "part.mod:6:5" in res.output and "routine" in res.output and not out.exists()


def test_krl_load_data_reference_to_rapid(tmp_path):
    """$LOAD = LOAD_DATA[3], declared in the program's .dat: its whole value is carried."""
    text = KRL.replace("$LOAD = {M 12.5, CM {X 0, Y -5, Z 120, A 0, B 90, C 0}, J {X 0.2, Y 0.1, Z 0.05}}", "$LOAD = LOAD_DATA[3]").replace(
        "$LOAD = {M 4, CM {X 0, Y 0, Z 50, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}\n", "")
    (tmp_path / "part.dat").write_text("DEFDAT part\nDECL LOAD LOAD_DATA[3]={M 7.5,CM {X 1,Y 2,Z 60,A 0,B 0,C 0},J {X 0.1,Y 0.1,Z 0.02}}\nENDDAT\n")
    res, out = _convert(tmp_path, text, "part.src", "rapid")
    assert res.exit_code == 0, res.output
    assert _lines(out, "PERS tooldata")[0].endswith(",[7.5,[1,2,60],[1,0,0,0],0.1,0.1,0.02]];")
