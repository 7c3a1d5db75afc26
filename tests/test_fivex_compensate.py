"""compensate on five-axis programs: calibrated axes and a seed-004 grid error map."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.fivex.errormap import GridFileError, load_grid
from postproc.fivex.kinematics import fk
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.compensate import actual_tip, controller_axes
from postproc.jobs.five_axis.emit import emit
from postproc.jobs.five_axis.program import from_toolpath
from postproc.programs import parse_program

HERE = Path(__file__).parent
IMPELLER = HERE / "corpus" / "fivex" / "impeller-7bl-xyzac-head.ngc"
TILTED = HERE / "corpus" / "fivex" / "tilted_pass.mod"
TRUE = HERE / "data" / "fivex" / "xyzac-trt-true.toml"
runner = CliRunner()
# The impeller and our emitted programs never set G54: given as zero (the machine frame with the
# rotary axes at zero, as they were written for); without it they are refused (fivex/offsets.py).
AT_ZERO = ("--frame", "G54=0,0,0,0,0,0")


def field(p):
    """A smooth linear-axis error field (mm): scale errors, squareness, a sag."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    return np.stack([2e-4 * x + 1e-4 * y, -1.5e-4 * y + 5e-5 * x * y / 100, 1e-4 * z + 2e-7 * x * x], axis=1)


def write_grid(path: Path, xs, ys, zs, shuffle=True):
    g = np.array(np.meshgrid(xs, ys, zs, indexing="ij")).reshape(3, -1).T
    if shuffle:
        g = g[np.random.default_rng(0).permutation(len(g))]
    rows = ["x,y,z,dx,dy,dz"] + [",".join(f"{v:.6f}" for v in (*p, *e)) for p, e in zip(g, field(g))]
    path.write_text("# synthetic grid\n" + "\n".join(rows) + "\n")
    return path


def skeleton(text: str) -> str:
    return re.sub(r"[+-]?\d+\.?\d*", "#", text)


def test_trilinear_inside_refused_outside(tmp_path):
    grid = load_grid(write_grid(tmp_path / "g.csv", np.linspace(-200, 200, 9), np.linspace(-100, 100, 5), np.linspace(-120, 120, 7)))
    p = np.random.default_rng(1).uniform([-200, -100, -120], [200, 100, 120], (500, 3))
    e = grid.offset(p)
    assert np.abs(e[:, 0] - field(p)[:, 0]).max() < 1e-12  # linear in the cell: exact
    assert np.abs(e - field(p)).max() < 2e-7 * 50**2  # the x^2 term: trilinear's chord error
    assert np.isnan(grid.offset(np.array([[250.0, 0, 0]]))).all()


def test_planar_and_linewise_grids(tmp_path):
    planar = load_grid(write_grid(tmp_path / "p.csv", np.linspace(-200, 200, 9), np.linspace(-100, 100, 5), [0.0]))
    assert planar.varied == (True, True, False) and "z = 0" in planar.notes[0]
    p = np.array([[10.0, 20.0, 55.0]])
    np.testing.assert_allclose(planar.offset(p), planar.offset(np.array([[10.0, 20.0, 0.0]])))
    line = load_grid(write_grid(tmp_path / "l.csv", np.linspace(-200, 200, 9), [0.0], [0.0]))
    assert line.varied == (True, False, False)
    assert np.isnan(line.offset(np.array([[-201.0, 0, 0]]))).all()


@pytest.mark.parametrize("text,row,column", [
    ("x,y,z,dx,dy,dz\n0,0,0,0,0,0\n1,0,0,0,0,0\n0,1,0,0,0,0\n", None, None),  # 3 of a 2x2 grid
    ("x,y,z,dx,dy\n0,0,0,0,0\n", None, "dz"),
    ("x,y,z,dx,dy,dz\n0,0,0,0,0,zero\n", 1, "dz"),
])
def test_bad_grids(tmp_path, text, row, column):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(GridFileError) as exc:
        load_grid(path)
    assert exc.value.row == row and exc.value.column == column


def test_tip_program_compensated_for_calibrated_axes_and_grid(tmp_path):
    grid_path = write_grid(tmp_path / "g.csv", np.linspace(-200, 200, 9), np.linspace(-100, 100, 9), np.linspace(-120, 120, 9))
    out = tmp_path / "out.ngc"
    result = runner.invoke(app, ["compensate", str(IMPELLER), "--model", str(TRUE), "--grid", str(grid_path), "--input-axes", "tip", "-o", str(out), *AT_ZERO])
    assert result.exit_code == 0, result.output
    original = IMPELLER.read_text(encoding="latin-1")
    text = out.read_text(encoding="latin-1")
    assert skeleton(text) == skeleton(original) and text != original  # only numbers changed
    true, nominal, grid = load_machine(TRUE), load_machine("xyzac-trt"), load_grid(grid_path)
    tp, new = parse_program(IMPELLER), parse_program(out)
    intended = tp.position
    cmd_before = controller_axes(nominal, tp.position, tp.ext[:, [0, 2]], "tip")
    cmd_after = controller_axes(nominal, new.position, new.ext[:, [0, 2]], "tip")
    before = np.linalg.norm(actual_tip(true, grid, cmd_before) - intended, axis=1)
    after = np.linalg.norm(actual_tip(true, grid, cmd_after) - intended, axis=1)
    assert before.max() > 0.1 and after.max() < 0.002  # written with the program's 3 decimals


def test_machine_axes_program_compensated(tmp_path):
    nominal, true = load_machine("xyzac-trt"), load_machine(TRUE)
    path = from_toolpath(parse_program(TILTED), nominal)
    prog = tmp_path / "nominal_axes.ngc"
    prog.write_text(emit(nominal, path, "none").text)
    out = tmp_path / "out.ngc"
    result = runner.invoke(app, ["compensate", str(prog), "--model", str(TRUE), "--input-axes", "machine", "-o", str(out), *AT_ZERO])
    assert result.exit_code == 0, result.output
    tp, new = parse_program(prog), parse_program(out)
    intended = fk(nominal, np.c_[tp.position, tp.ext[:, [0, 2]]])[0]
    reached = fk(true, np.c_[new.position, new.ext[:, [0, 2]]])[0]
    # the splicer writes a changed number within 5e-4 (mm or deg) and with at least its old
    # decimals: "A0" becomes a 4-decimal angle, 2e-4 mm at 30 mm from the axis
    err = np.linalg.norm(reached - intended, axis=1)
    assert err.max() < 5e-4 and np.median(err) < 1e-5


def test_outside_the_grid_exits_1_and_writes_nothing(tmp_path):
    grid_path = write_grid(tmp_path / "g.csv", np.linspace(-20, 20, 3), np.linspace(-20, 20, 3), np.linspace(-20, 20, 3))
    out = tmp_path / "out.ngc"
    result = runner.invoke(app, ["compensate", str(IMPELLER), "--model", str(TRUE), "--grid", str(grid_path), "--input-axes", "tip", "-o", str(out), *AT_ZERO])
    assert result.exit_code == 1 and "outside the measured grid" in result.stderr
    assert not out.exists()
