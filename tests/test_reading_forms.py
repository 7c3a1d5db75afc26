"""Program forms controllers run that postproc refused or read wrong (issue 28): each test
writes a small program of its own in the form, and the expected positions are worked out
by hand from the controller manual's rule (quoted at the test)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.effects import parse_effects
from postproc.model_io import save_model
from postproc.programs import parse_program
from postproc.sim import random_truth

runner = CliRunner()
MARK = b"\xef\xbb\xbf"


@pytest.fixture(scope="module")
def model_path(tmp_path_factory) -> Path:
    """A geometric error model with random (non-zero) parameters: compensation moves targets."""
    path = tmp_path_factory.mktemp("model") / "model.json"
    save_model(path, random_truth(kr160(), TOOL, parse_effects("geometric"), np.random.default_rng(3)))
    return path


def _krl(folder: Path) -> list[Path]:
    src = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "LIN XP1"]
    for k, (x, y) in enumerate([(900, -200), (1000, 0), (1100, 200)]):
        src.append(f"LIN {{X {x}.000, Y {y}.000, Z {400 + 10 * k}.000, A {10 * k}, B 180, C 0}}")
    src.append("END")
    (folder / "part.src").write_text("\r\n".join(src) + "\r\n")
    (folder / "part.dat").write_text("DEFDAT part\r\nDECL E6POS XP1={X 950,Y 100,Z 420,A 0,B 180,C 0}\r\nENDDAT\r\n")
    return [folder / "part.src", folder / "part.dat"]


def _rapid(folder: Path) -> list[Path]:
    lines = ["MODULE Part", "  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];",
             "  TASK PERS wobjdata wTable := [FALSE,TRUE,\"\",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];",
             "  PROC main()", "    ConfL\\Off;"]
    for i in range(4):
        lines.append(f"    MoveL [[{50.0 * i:.3f},{20.0 * i:.3f},150.000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle\\WObj:=wTable;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    (folder / "part.mod").write_text("\n".join(lines))
    return [folder / "part.mod"]


def _gcode(folder: Path) -> list[Path]:
    lines = ["G21 G90 G54", "G43.5 H1"] + [f"G1 X{20 * i} Y{5 * i} Z0 I0 J0 K1 F500" for i in range(4)] + ["G49", "M2", ""]
    (folder / "part.ngc").write_text("\n".join(lines))
    return [folder / "part.ngc"]


GCODE_SETUP = ["--frame", "G54=900,-100,300,0,180,0", "--tool", "H1=0,0,200"]


def _compensate(program: Path, model: Path, out: Path, *options: str):
    return runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--allow-model-mismatch", *options])


@pytest.mark.parametrize("write, options", [(_krl, []), (_rapid, []), (_gcode, GCODE_SETUP)], ids=["krl", "rapid", "gcode"])
def test_byte_order_mark_is_read_past_and_written_back(tmp_path, model_path, write, options):
    """A file saved with a UTF-8 byte order mark compensates to the same numbers as without
    it, and every file written starts with the mark again, byte for byte."""
    plain, marked = tmp_path / "plain", tmp_path / "marked"
    plain.mkdir(), marked.mkdir()
    plain_files, marked_files = write(plain), write(marked)
    for path in marked_files:
        path.write_bytes(MARK + path.read_bytes())
    (plain / "out").mkdir(), (marked / "out").mkdir()
    first = _compensate(plain_files[0], model_path, plain / "out" / plain_files[0].name, *options)
    assert first.exit_code == 0, first.output
    second = _compensate(marked_files[0], model_path, marked / "out" / marked_files[0].name, *options)
    assert second.exit_code == 0, second.output
    for path in plain_files:
        expected = (plain / "out" / path.name).read_bytes()
        assert expected != path.read_bytes()  # the targets moved
        assert (marked / "out" / path.name).read_bytes() == MARK + expected
    back = runner.invoke(app, ["roundtrip", str(marked_files[0])])
    assert back.exit_code == 0 and "IDENTICAL" in back.output


def test_byte_order_mark_error_columns_count_as_an_editor_shows(tmp_path):
    """The mark takes no column: 'x' is the 10th character an editor shows on line 1."""
    path = tmp_path / "bad.mod"
    path.write_bytes(MARK + b"MODULE m x\nENDMODULE\n")
    result = runner.invoke(app, ["inspect", str(path)])
    assert result.exit_code == 2
    assert "bad.mod:1:10:" in result.output and "\xef" not in result.output and "ï»¿" not in result.output


@pytest.mark.parametrize("name, text, where, why", [
    ("empty.src", "", ":1:1:", "the file is empty"),
    ("blank.mod", "\n  \n", ":1:1:", "the file is empty"),
    ("comments.src", "; nothing\r\n&ACCESS RVP\r\n", ":1:1:", "the file is empty"),
    ("nodef.src", "&ACCESS RVP\n; c\nDEFDAT x\nENDDAT\n", ":3:1:", "no DEF"),
    ("nodef_motion.src", "LIN {X 1000,Y 0,Z 1000,A 0,B 90,C 0}\n", ":1:1:", "no DEF"),
    ("nomodule.mod", "! a routine without its module\nPROC main()\n  MoveL [[1000,0,1000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\nENDPROC\n", ":2:1:", "no MODULE"),
    ("nomotion.src", "DEF p( )\n  $OV_PRO = 50\nEND\n", ":1:1:", "no motion"),
    ("nomotion.mod", "MODULE m\nENDMODULE\n", ":1:1:", "no motion"),
    ("nomotion.ngc", "(setup only)\nG21 G90\nM2\n", ":2:1:", "no motion"),
])
def test_no_program_is_refused_and_nothing_written(tmp_path, model_path, name, text, where, why):
    """compensate and convert refuse a file that holds no program the controller would run
    (or no motion), exit 2, naming file:line:column, and write nothing."""
    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    result = _compensate(path, model_path, out / name)
    assert result.exit_code == 2, result.output
    assert f"{name}{where}" in result.output and why in result.output
    converted = runner.invoke(app, ["convert", str(path), "--to", "krl", "-o", str(out / "c.src")])
    assert converted.exit_code == 2 and why in converted.output
    assert list(out.iterdir()) == []
