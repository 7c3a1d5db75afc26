"""Writing compensated programs: every changed file is written, as one set, or nothing.

The emitter returns {path: text} for every file of the program that changed (KRL: the
.src, its .dat and a changed $config.dat); the CLI refuses standard output when targets
live in a second file, refuses to overwrite an input without --in-place (which keeps
NAME.bak), and re-parses the new text before writing it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.jobs.compensate import compensate
from postproc.model.effects import parse_effects
from postproc.model.model_io import save_model
from postproc.model.sim import random_truth
from postproc.programs import parse_program
from postproc.programs.dialects.krl import KrlDialect
from postproc.robot.robots import load_robot

runner = CliRunner()
TOOL = np.array([0.0, 0.0, 200.0])
WRITE_TOL_MM = 5.01e-4  # the emitter's rounding of a position (postproc.programs.emit.splice.TOLERANCE)


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    """A robot with millimetre-size errors (no fit needed: the true robot is the model)."""
    model = random_truth(load_robot("kr160_r1570"), TOOL, parse_effects("geometric,tool_offset,joint_compliance[payload=10]"), np.random.default_rng(3))  # the RAPID tools carry 10 kg
    path = tmp_path_factory.mktemp("model") / "model.json"
    save_model(path, model)
    return path


def krl_with_config(folder: Path) -> Path:
    """prog.src with one target inline, one in its .dat and one in the robot's $config.dat."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "prog.src").write_bytes(
        b"DEF prog( )\r\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\r\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\r\n"
        b"LIN {X 950, Y 50, Z 420, A 0, B 180, C 0}\r\nLIN XPDAT\r\nLIN XPCFG\r\nEND\r\n"
    )
    (folder / "prog.dat").write_bytes(b"DEFDAT prog\r\nDECL E6POS XPDAT={X 1000,Y -60,Z 430,A 0,B 180,C 0}\r\nENDDAT\r\n")
    (folder / "$config.dat").write_bytes(b"DEFDAT $CONFIG\r\nDECL GLOBAL E6POS XPCFG={X 1050,Y 80,Z 440,A 0,B 180,C 0}\r\nENDDAT\r\n")
    return folder / "prog.src"


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_a_target_in_config_dat_is_compensated_and_written(model_path, tmp_path):
    program = krl_with_config(tmp_path / "in")
    before = _snapshot(program.parent)
    out = tmp_path / "out" / "prog.src"
    out.parent.mkdir()
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["$config.dat", "prog.dat", "prog.src"]
    assert _snapshot(program.parent) == before  # the input is untouched
    from postproc.model.model_io import load_model

    want, _ = compensate(parse_program(program), load_model(model_path)[0])
    back = parse_program(out)
    assert back.target_name[2] == "XPCFG" and back.sources[int(back.spans[2, 0, 0])].path.endswith("$config.dat")
    np.testing.assert_allclose(back.position, want.position, atol=WRITE_TOL_MM)
    moved = np.linalg.norm(back.position - parse_program(program).position, axis=1)
    assert (moved > 0.01).all()  # every target, the $config.dat one included, was moved


def test_the_dialect_returns_every_changed_file(model_path, tmp_path):
    from postproc.model.model_io import load_model

    program = krl_with_config(tmp_path)
    tp = parse_program(program)
    new, _ = compensate(tp, load_model(model_path)[0])
    files = KrlDialect().emit(tp, new, tmp_path / "o" / "x.src")
    assert set(files) == {tmp_path / "o" / "x.src", tmp_path / "o" / "x.dat", tmp_path / "o" / "$config.dat"}
    unchanged = KrlDialect().emit(tp, tp, tmp_path / "o" / "x.src")
    assert set(unchanged) == {tmp_path / "o" / "x.src", tmp_path / "o" / "x.dat"}  # the module's two halves travel together


def test_standard_output_is_refused_when_targets_live_in_another_file(model_path, tmp_path):
    program = krl_with_config(tmp_path)
    before = _snapshot(tmp_path)
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", "-"])
    assert result.exit_code == 2
    assert "-o -" in result.stderr and "standard output cannot carry" in result.stderr and "prog.dat" in result.stderr
    assert result.stdout == "" and _snapshot(tmp_path) == before


def test_overwriting_an_input_is_refused_without_in_place(model_path, tmp_path):
    program = krl_with_config(tmp_path)
    before = _snapshot(tmp_path)
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(program)])
    assert result.exit_code == 2 and "would overwrite an input file" in result.stderr and "--in-place" in result.stderr
    assert _snapshot(tmp_path) == before
    # Another name in the same folder still replaces the folder's $config.dat: refused too.
    other = tmp_path / "other.src"
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(other)])
    assert result.exit_code == 2 and "$config.dat" in result.stderr and "would overwrite an input file" in result.stderr
    assert _snapshot(tmp_path) == before and not other.exists()


def test_in_place_rewrites_the_program_and_keeps_backups(model_path, tmp_path):
    program = krl_with_config(tmp_path)
    before = _snapshot(tmp_path)
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(program), "--in-place"])
    assert result.exit_code == 0, result.output
    for name in ("prog.src", "prog.dat", "$config.dat"):
        assert (tmp_path / f"{name}.bak").read_bytes() == before[name]
    assert (tmp_path / "prog.dat").read_bytes() != before["prog.dat"] and (tmp_path / "$config.dat").read_bytes() != before["$config.dat"]
    assert (tmp_path / "prog.src").read_bytes() != before["prog.src"]  # the inline target moved


def test_a_text_that_does_not_read_back_is_never_written(model_path, tmp_path, monkeypatch):
    program = krl_with_config(tmp_path / "in")
    out = tmp_path / "out.src"
    # An emitter that forgets the change (as one that skipped a file would).
    monkeypatch.setattr(KrlDialect, "emit_texts", lambda self, original, modified: [doc.text for doc in original.sources])
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(out)])
    assert result.exit_code == 1
    assert "reads back as" in result.stderr and "line 4" in result.stderr and "nothing was written" in result.stderr
    assert not out.exists() and not (tmp_path / "out.dat").exists() and not (tmp_path / "$config.dat").exists()


def test_rapid_to_standard_output_still_works(model_path, tmp_path):
    """One-file programs keep the filter mode (program on stdout, summary on stderr)."""
    program = tmp_path / "p.mod"
    program.write_text(
        "MODULE P\n  PERS tooldata t1 := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];\n  PROC main()\n    ConfL\\Off;\n"
        "    MoveL [[950,0,400],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, t1;\n  ENDPROC\nENDMODULE\n"
    )
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", "-", "--allow-model-mismatch"])  # RAPID, a KUKA model
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith("MODULE P") and "[[950,0,400]" not in result.stdout


def test_a_set_that_cannot_be_written_whole_is_not_written_at_all(tmp_path):
    from postproc.errors import OutputError
    from postproc.files import write_all

    keep = tmp_path / "kept.src"
    keep.write_bytes(b"old")
    with pytest.raises(OutputError, match="no_such_folder"):
        write_all({keep: b"new", tmp_path / "new.dat": b"data", tmp_path / "no_such_folder" / "x.dat": b"more"})
    assert keep.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["kept.src"]  # no temp file left


def rapid_program_file(folder: Path) -> Path:
    """cell.pgf listing Main.mod (the moves) and Data.mod (tool and robtargets), as RobotWare keeps a task."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "Main.mod").write_text(
        "MODULE Main\n  PROC main()\n    ConfJ\\Off;\n    ConfL\\Off;\n    MoveJ p10, v100, fine, tSpindle;\n    MoveL p20, v100, z1, tSpindle;\n"
        "    MoveL [[1050,-40,430],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tSpindle;\n  ENDPROC\nENDMODULE\n"
    )
    (folder / "Data.mod").write_text(
        "MODULE Data\n  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];\n"
        "  CONST robtarget p10 := [[950,0,400],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
        "  CONST robtarget p20 := [[1000,50,420],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n"
    )
    (folder / "cell.pgf").write_text('<?xml version="1.0" encoding="ISO-8859-1" ?>\n<Program>\n  <Module>Main.mod</Module>\n  <Module>Data.mod</Module>\n</Program>\n')
    return folder / "cell.pgf"


def test_a_rapid_program_of_several_modules_is_compensated_and_written_whole(model_path, tmp_path):
    from postproc.model.model_io import load_model

    program = rapid_program_file(tmp_path / "in")
    tp = parse_program(program)
    assert [Path(d.path).name for d in tp.sources] == ["cell.pgf", "Main.mod", "Data.mod"]
    assert tp.placed().all() and tp.tool_names[tp.tool[0]] == "tSpindle"  # tool and points from Data.mod
    assert {int(f) for f in tp.spans[:2, 0, 0]} == {2} and int(tp.spans[2, 0, 0]) == 1
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", "-"])
    assert result.exit_code == 2 and "standard output cannot carry" in result.stderr and result.stdout == ""
    out = tmp_path / "out" / "cell.pgf"
    out.parent.mkdir()
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(out), "--allow-model-mismatch"])  # RAPID, a KUKA model
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["Data.mod", "Main.mod", "cell.pgf"]
    assert (out.parent / "cell.pgf").read_bytes() == program.read_bytes()
    want, _ = compensate(tp, load_model(model_path)[0])
    np.testing.assert_allclose(parse_program(out).position, want.position, atol=WRITE_TOL_MM)
    assert (np.linalg.norm(want.position - tp.position, axis=1) > 0.01).all()
