"""postproc predict: where a program puts the TCP under a model (here: the simulated truth),
against the program it was compensated from."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app

runner = CliRunner()

POCKET = """DEF pocket( )
$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}
$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}
PTP {X 900, Y -200, Z 500, A 0, B 180, C 0}
LIN {X 900, Y -200, Z 448, A 0, B 180, C 0}
LIN {X 1150, Y -200, Z 448, A 0, B 180, C 0}
LIN {X 1150, Y 200, Z 448, A 0, B 180, C 0}
END
"""


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    d = tmp_path_factory.mktemp("predict")
    (d / "pocket.src").write_text(POCKET)
    assert runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--n", "120", "--seed", "3", "-o", str(d / "sim.csv"),
                               "--truth", str(d / "truth.json")]).exit_code == 0
    assert runner.invoke(app, ["fit", str(d / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "--cv", "0",
                               "--effects", "geometric,base_frame,tool_offset,joint_compliance", "-o", str(d / "model.json")]).exit_code == 0
    r = runner.invoke(app, ["compensate", str(d / "pocket.src"), "--model", str(d / "model.json"), "-o", str(d / "pocket_c.src")])
    assert r.exit_code == 0, r.output
    return d


def _predict(*args):
    return runner.invoke(app, ["predict", *map(str, args)])


def test_the_compensated_program_lands_on_the_intended_targets_on_the_true_robot(cell):
    before = json.loads(_predict(cell / "pocket.src", "--model", cell / "truth.json", "--json").stdout)
    after = json.loads(_predict(cell / "pocket_c.src", "--model", cell / "truth.json", "--intended", cell / "pocket.src", "--json").stdout)
    assert [t["target"].rsplit(":", 1)[1] for t in after] == ["4", "5", "6", "7"]
    err_before = np.array([t["error_mm"] for t in before])
    err_after = np.array([t["error_mm"] for t in after])
    assert err_before.min() > 1.0 and err_after.max() < 0.05, (err_before, err_after)
    # against its own (compensated) targets the compensated program is as far off as the correction
    own = json.loads(_predict(cell / "pocket_c.src", "--model", cell / "truth.json", "--json").stdout)
    assert np.array([t["error_mm"] for t in own]).min() > 1.0
    text = _predict(cell / "pocket_c.src", "--model", cell / "truth.json", "--intended", cell / "pocket.src")
    assert text.exit_code == 0 and "4 of 4 targets" in text.stdout and "RMS" in text.stdout


def test_an_intended_program_of_other_motions_is_refused(cell, tmp_path):
    other = tmp_path / "other.src"
    other.write_text(POCKET.replace("LIN {X 1150, Y 200, Z 448, A 0, B 180, C 0}\n", ""))
    r = _predict(cell / "pocket_c.src", "--model", cell / "truth.json", "--intended", other)
    assert r.exit_code == 2 and "motion for motion" in r.output


def test_an_unreachable_target_exits_1_naming_its_line(cell, tmp_path):
    far = tmp_path / "far.src"
    far.write_text(POCKET.replace("X 1150, Y 200", "X 4150, Y 200"))
    r = _predict(far, "--model", cell / "truth.json")
    assert r.exit_code == 1 and "far.src:7: out of reach" in r.output
