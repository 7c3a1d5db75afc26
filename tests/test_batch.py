"""Many programs on a real dask.distributed LocalCluster (2 worker processes): each program
succeeds or fails on its own, the broken one is reported, the others are written and are
byte-identical to what the single-program `compensate PROGRAM -o OUT` writes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.errors import OutputError
from postproc.jobs.batch import compensate_file
from postproc.model.effects import parse_effects
from postproc.model.model_io import load_model, save_model
from postproc.model.sim import random_truth
from postproc.programs import write_texts

runner = CliRunner()


def _rapid(path, shift):
    lines = ["MODULE Part", "  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];",
             "  TASK PERS wobjdata wTable := [FALSE,TRUE,\"\",[[900,-100,300],[0.9659258,0,0,0.2588190]],[[0,0,0],[1,0,0,0]]];", "  PROC main()", "    ConfL\\Off;"]
    for i in range(30):
        x, y = 10.0 * (i % 15) + shift, 120.0 * (i // 15)
        lines.append(f"    MoveL [[{x:.3f},{y:.3f},150.000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle\\WObj:=wTable;")
    path.write_text("\n".join(lines + ["  ENDPROC", "ENDMODULE", ""]))
    return path


def _krl(path):
    src = ["DEF cell( )", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$BASE = {X 900, Y -100, Z 350, A 0, B 0, C 0}"]
    dat = ["DEFDAT cell"]
    for i in range(20):
        src.append(f"LIN XP{i} C_DIS")
        dat.append(f"DECL E6POS XP{i}={{X {8.0 * i:.2f},Y {50.0 * np.sin(i / 4):.2f},Z 0.0,A 0.0,B 180.0,C 0.0,S 2,T 10}}")
    path.write_text("\r\n".join(src + ["END"]) + "\r\n")
    path.with_suffix(".dat").write_text("\r\n".join(dat + ["ENDDAT"]) + "\r\n")
    return path


@pytest.fixture(scope="module")
def batch_inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("batch")
    robot = postproc.load_robot("kr160_r1570")
    model = random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE + "[payload=10]"), np.random.default_rng(3))  # the RAPID tool carries 10 kg
    save_model(root / "model.json", model)
    src = root / "in"
    src.mkdir()
    programs = [_rapid(src / f"part{k}.mod", 20.0 * k) for k in range(3)] + [_krl(src / "cell.src")]
    broken = src / "broken.mod"
    broken.write_text("MODULE Broken\n  PROC main()\n    MoveL [[1,2,3],[1,0,0,0]], v100, z1, tool0\n  ENDPROC\nENDMODULE\n")  # robtarget cut short
    return root, programs, broken


def test_localcluster_batch_reports_the_broken_program_and_writes_the_others(batch_inputs):
    root, programs, broken = batch_inputs
    out_dir = root / "out"
    out_dir.mkdir()
    args = ["compensate", *map(str, programs[:2]), str(broken), *map(str, programs[2:]), "--model", str(root / "model.json"),
            "--out-dir", str(out_dir), "--jobs", "2", "--report", str(root / "batch.json"), "--allow-model-mismatch"]  # RAPID programs, a KUKA model
    result = runner.invoke(app, args)
    assert result.exit_code == 1, result.output
    assert "broken.mod" in result.stderr and "4 of 5 programs written; 1 failed" in result.stdout
    assert not (out_dir / "broken.mod").exists()
    doc = json.loads((root / "batch.json").read_text())
    assert [r["ok"] for r in doc["programs"]] == [True, True, False, True, True]
    assert "broken.mod:3:" in doc["programs"][2]["error"]  # the parser's file:line:column
    # Every written program equals the single-program path's output, .dat included.
    for program in programs:
        single = root / f"single_{program.name}"
        assert runner.invoke(app, ["compensate", str(program), "--model", str(root / "model.json"), "-o", str(single), "--allow-model-mismatch"]).exit_code == 0
        assert (out_dir / program.name).read_bytes() == single.read_bytes()
        if program.suffix == ".src":
            assert (out_dir / "cell.dat").read_bytes() == single.with_suffix(".dat").read_bytes()
            assert (out_dir / "cell.dat").read_bytes() != program.with_suffix(".dat").read_bytes()


def test_batch_usage_errors_exit_2(batch_inputs):
    root, programs, _ = batch_inputs
    model = str(root / "model.json")
    result = runner.invoke(app, ["compensate", *map(str, programs), "--model", model, "--out-dir", str(root / "missing")])
    assert result.exit_code == 2 and "not an existing folder" in result.stderr
    result = runner.invoke(app, ["compensate", *map(str, programs), "--model", model, "-o", str(root / "x.mod")])
    assert result.exit_code == 2 and "--out-dir" in result.stderr
    twin = root / "twin"
    twin.mkdir()
    same_name = twin / programs[0].name
    same_name.write_bytes(programs[0].read_bytes())
    result = runner.invoke(app, ["compensate", str(programs[0]), str(same_name), "--model", model, "--out-dir", str(root)])
    assert result.exit_code == 2 and "would both be written" in result.stderr


def test_compensate_file_refuses_to_overwrite_its_input(batch_inputs):
    root, programs, _ = batch_inputs
    model, _ = load_model(root / "model.json")
    before = programs[0].read_bytes()
    res = compensate_file(programs[0], model, programs[0].parent, {})
    assert not res.ok and res.exit_code == 2 and "would overwrite an input file" in res.error
    assert programs[0].read_bytes() == before


def test_a_program_set_is_written_whole_or_not_at_all(tmp_path):
    (tmp_path / "a.src").write_text("old a")
    with pytest.raises(OutputError):
        write_texts(["new a", "new b"], [tmp_path / "a.src", tmp_path / "missing" / "b.dat"])
    assert (tmp_path / "a.src").read_text() == "old a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.src"]  # no temp file left behind
