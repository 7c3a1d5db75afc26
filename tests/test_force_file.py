"""A process force per motion block (issue 13, `compensate --force-file FORCES.csv`): each
row's force changes the prediction of exactly the targets of its line, as --force would;
every malformed file is an error naming the CSV file, row and column, and nothing is written."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model
from postproc.programs import parse_program

runner = CliRunner()
LINES = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}",
         "PTP {X 1000, Y -50, Z 500, A 0, B 180, C 0}",
         "LIN {X 1000, Y 0, Z 500, A 0, B 180, C 0}",
         "LIN {X 1000, Y 50, Z 500, A 0, B 180, C 0}",
         "LIN {X 1050, Y 50, Z 500, A 0, B 180, C 0}", "END"]


def _model(tmp_path, effects="joint_compliance,external_load"):
    model = ErrorModel.create(kr160(), [0.0, 0.0, 200.0], parse_effects(effects))
    model = model.with_values({p.name: 2 * float(p.typical) for p in model.params})
    path = tmp_path / "model.json"
    save_model(path, model)
    return path


def _program(tmp_path):
    path = tmp_path / "part.src"
    path.write_text("\n".join(LINES) + "\n")
    return path


def _compensate(tmp_path, name, *extra, model=None):
    out = tmp_path / f"{name}.src"
    res = runner.invoke(app, ["compensate", str(_program(tmp_path)), "--model", str(model or _model(tmp_path)), "-o", str(out), *extra])
    return res, out


def test_a_row_forces_exactly_its_motion_as_a_constant_force_would(tmp_path):
    (tmp_path / "f.csv").write_text("line,fx,fy,fz\n6,0,-300,200\n")
    res, per_block = _compensate(tmp_path, "block", "--force-file", str(tmp_path / "f.csv"))
    assert res.exit_code == 0, res.output
    assert "3 Cartesian target(s) have no row" in " ".join(res.output.split())
    _, none = _compensate(tmp_path, "none", "--force", "0,0,0")
    _, constant = _compensate(tmp_path, "const", "--force", "0,-300,200")
    block, plain, const = (parse_program(p).position for p in (per_block, none, constant))
    np.testing.assert_allclose(block[2], const[2], atol=1e-3)  # line 6: the force
    assert np.abs(const[2] - plain[2]).max() > 0.05  # ... and it matters
    np.testing.assert_allclose(block[[0, 1, 3]], plain[[0, 1, 3]], atol=1e-3)  # the others: none


def test_a_file_column_picks_the_programs_file(tmp_path):
    (tmp_path / "f.csv").write_text("file,line,fx,fy,fz\npart.src,6,0,-300,200\n")
    res, _ = _compensate(tmp_path, "o", "--force-file", str(tmp_path / "f.csv"))
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("text, where", [
    ("line,fx,fy\n6,0,0\n", "row 1, column 'fz': required column missing"),
    ("line,fx,fy,fz,fw\n6,0,0,0,0\n", "row 1, column 'fw': unknown column"),
    ("line,fx,fy,fz\n6,0,abc,0\n", "row 2, column 'fy': 'abc' is not a number"),
    ("line,fx,fy,fz\n6,0,nan,0\n", "row 2, column 'fy': 'nan' is not a finite number"),
    ("line,fx,fy,fz\n6,0,0,1e9\n", "row 2, column 'fz': 1e+09 N is over"),
    ("line,fx,fy,fz\n6,0,0,0\n7,0,0,0\n6,1,0,0\n", "row 4, column 'line': line 6 of part.src has a force already"),
    ("line,fx,fy,fz\n2,0,0,0\n", "row 2, column 'line': line 2 of part.src holds no Cartesian motion"),
    ("line,fx,fy,fz\nsix,0,0,0\n", "row 2, column 'line': 'six' is not a line number"),
    ("line,fx,fy,fz\n6,0,0\n", "row 2: 3 cells, the header has 4"),
    ("file,line,fx,fy,fz\nother.src,6,0,0,0\n", "row 2, column 'file': 'other.src' is none of the program's files"),
    ("line,fx,fy,fz\n", "row 2: no data rows"),
])
def test_bad_force_files_name_row_and_column(tmp_path, text, where):
    (tmp_path / "f.csv").write_text(text)
    res, out = _compensate(tmp_path, "o", "--force-file", str(tmp_path / "f.csv"))
    assert res.exit_code == 2, res.output
    assert f"f.csv, {where}" in " ".join(res.output.split())
    assert not out.exists() and not out.with_suffix(".dat").exists()


def test_force_file_needs_a_model_that_uses_forces_and_no_second_force(tmp_path):
    (tmp_path / "f.csv").write_text("line,fx,fy,fz\n6,0,-300,200\n")
    res, out = _compensate(tmp_path, "o", "--force-file", str(tmp_path / "f.csv"), model=_model(tmp_path, "joint_compliance"))
    assert res.exit_code == 2 and "no effect that uses the process force" in " ".join(res.output.split()) and not out.exists()
    res, out = _compensate(tmp_path, "o", "--force-file", str(tmp_path / "f.csv"), "--force", "1,2,3")
    assert res.exit_code == 2 and "not with --force or --cut" in res.output and not out.exists()
