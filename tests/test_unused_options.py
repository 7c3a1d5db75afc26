"""No option accepted and silently unused (issue 13): an option that this use of a command
would not use is an error naming it (exit 2), before any work and with nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model

runner = CliRunner()
FIVEX = Path(__file__).parent / "data" / "fivex"
KRL = "DEF p( )\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\nPTP {X 1000, Y 0, Z 500, A 0, B 180, C 0}\nLIN {X 1000, Y 50, Z 500, A 0, B 180, C 0}\nEND\n"


@pytest.fixture()
def files(tmp_path):
    save_model(tmp_path / "m.json", ErrorModel.create(kr160(), [0.0, 0.0, 200.0], parse_effects("geometric")))
    (tmp_path / "p.src").write_text(KRL)
    (tmp_path / "p.ngc").write_text("G21 G90\nG0 X0 Y0 Z5 A0 C0\nG1 X1 F100\nM2\n")
    (tmp_path / "meas.csv").write_text("q1,q2,q3,q4,q5,q6,x,y,z\n0,-60,40,0,60,0,1000,0,500\n")
    (tmp_path / "probes.csv").write_text("id,axis,x,y,z\n1,C,1,0,0\n2,C,0,1,0\n3,C,-1,0,0\n")
    return tmp_path


@pytest.mark.parametrize("args, option", [
    (["compensate", "{p}/p.src", "--model", "{p}/m.json", "-o", "{p}/o.src", "--grid", "{p}/g.csv"], "--grid"),
    (["compensate", "{p}/p.src", "--model", "{p}/m.json", "-o", "{p}/o.src", "--input-axes", "tip"], "--input-axes"),
    (["compensate", "{p}/p.ngc", "--model", f"{FIVEX}/xyzac-trt-true.toml", "-o", "{p}/o.ngc", "--tol", "0.001"], "--tol"),
    (["compensate", "{p}/p.ngc", "--model", f"{FIVEX}/xyzac-trt-true.toml", "-o", "{p}/o.ngc", "--subdivide"], "--subdivide"),
    (["compensate", "{p}/p.ngc", "--model", f"{FIVEX}/xyzac-trt-true.toml", "-o", "{p}/o.ngc", "--force", "1,2,3"], "--force"),
    (["compensate", "{p}/p.src", "{p}/p.src", "--model", "{p}/m.json", "--out-dir", "{p}", "--subdivide"], "--subdivide"),
    (["fit", "{p}/meas.csv", "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "geometric", "-o", "{p}/o.json", "--source", "{p}/meas.csv"], "--source"),
    (["fit", "{p}/meas.csv", "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "geometric", "-o", "{p}/o.json", "--gp-method", "local"], "--gp-method"),
    (["similarity", "{p}/meas.csv", "{p}/meas.csv", "--model", "{p}/m.json", "--robot", "kr160_r1570"], "--robot"),
    (["convert", "{p}/p.src", "--to", "rapid", "-o", "{p}/o.mod", "--input-axes", "tip"], "--input-axes"),
    (["convert", "{p}/p.src", "--to", "rapid", "-o", "{p}/o.mod", "--max-deviation", "0.1"], "--max-deviation"),
    (["rtcp-calibrate", "{p}/probes.csv", "--machine", "xyzac-trt", "--tip-radius", "1"], "--tip-radius"),
    (["rtcp-calibrate", "{p}/probes.csv", "--machine", "xyzac-trt", "--sphere-radius", "10"], "sphere radius"),
    (["rtcp-calibrate", "{p}/probes.csv", "--machine", "xyzac-trt", "--axis", "C"], "--axis"),
    (["compensate", "{p}/p.src", "--model", "{p}/m.json", "-o", "{p}/o.src", "--no-such-option"], "--no-such-option"),
])
def test_an_unused_option_is_an_error(files, args, option):
    before = sorted(p.name for p in files.iterdir())
    res = runner.invoke(app, [a.format(p=files) for a in args])
    assert res.exit_code == 2, res.output
    assert option in res.output
    assert sorted(p.name for p in files.iterdir()) == before  # nothing written
