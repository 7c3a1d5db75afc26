"""Runtime assignments of constant values in straight-line code, followed as the controller
runs them (issue 28, "Read silently wrong"): RAPID whole robtargets, rotations, external axes,
work-object and tool frames; KRL points between motions. Every expected position is worked by
hand from the rule quoted at the test; compensation writes into the assignment's own numbers,
or is refused at the number two moves would need with two values."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.model_io import save_model
from postproc.model.sim import random_truth
from postproc.programs import parse_program

runner = CliRunner()
R2 = "0.7071068"


@pytest.fixture(scope="module")
def model_path(tmp_path_factory) -> Path:
    """A geometric error model with random (non-zero) parameters: compensation moves targets."""
    path = tmp_path_factory.mktemp("model") / "model.json"
    save_model(path, random_truth(kr160(), TOOL, parse_effects("geometric"), np.random.default_rng(3)))
    return path


def _compensate(program: Path, model: Path, out: Path):
    return runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--allow-model-mismatch"])


RAPID = f"""MODULE m
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wobj1 := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR robtarget p1 := [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\\Off;
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1 := [[100,50,120],[0,0,1,0],[-1,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1.rot := [0,{R2},{R2},0];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    wobj1.uframe.rot := [{R2},0,0,{R2}];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    tSpindle.tframe.trans := [0,0,250];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
  ENDPROC
ENDMODULE
"""


def test_rapid_whole_robtargets_rotations_and_frames_are_followed(tmp_path):
    """RAPID runs a routine's statements in order (RAPID kernel reference, "Statements"); a
    robtarget is [trans, rot, robconf, extax], a wobjdata's frame uframe * oframe, a tooldata's
    TCP its tframe. Worked by hand: p1 (10, 20, 150) in wobj1 (uframe at (900, -100, 300), no
    turn) -> (910, -80, 450); 'p1 := [[100,50,120],...,[-1,0,0,1],...]' -> (1000, -50, 420),
    configuration data (-1, 0, 0, 1); 'p1.rot := [0, r, r, 0]' keeps the position, the
    orientation is the new quaternion; 'wobj1.uframe.rot := [r, 0, 0, r]' turns the uframe 90
    degrees about z: (100, 50, 120) -> (-50, 100, 120) + (900, -100, 300) = (850, 0, 420);
    'tSpindle.tframe.trans := [0, 0, 250]': the last move's tool has its TCP 250 mm out."""
    path = tmp_path / "upd.mod"
    path.write_text(RAPID)
    tp = parse_program(path)
    np.testing.assert_allclose(tp.base_positions(), [[910, -80, 450], [1000, -50, 420], [1000, -50, 420], [850, 0, 420], [850, 0, 420]], atol=1e-4)
    assert tp.resolved.all() and not tp.notes
    r = float(R2)
    np.testing.assert_allclose(tp.values[:, 3:7], [[0, 0, 1, 0]] * 2 + [[0, r, r, 0]] * 3, atol=1e-12)
    np.testing.assert_allclose(tp.conf, [[0, 0, 0, 0]] + [[-1, 0, 0, 1]] * 4)
    np.testing.assert_allclose(tp.tools[tp.tool][:, :3, 3], [[0, 0, 200]] * 4 + [[0, 0, 250]])


@pytest.mark.parametrize("statement", [
    "IF DInput(di1) = 1 THEN p1.rot := [0,1,0,0]; ENDIF",
    "p1 := [[100,50,120],[0,0,1,0],[-1,0,0,nCfx],[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "tSpindle.tframe.rot := ReadRot();",
    "tSpindle.oframe.trans := [0,0,1];",  # no such component: not read as a change of the TCP
    "wobj1.tframe.trans := [0,0,1];",
])
def test_rapid_assignments_that_depend_on_inputs_or_calls_stay_unresolved(tmp_path, statement):
    """Only constants in straight-line code are followed: under an input, or of a value a
    variable or a function gives (or of a component the data type does not have), every target
    that uses the name is flagged with the line."""
    text = RAPID.replace("    p1 := [[100,50,120],[0,0,1,0],[-1,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];\n", f"    {statement}\n")
    if "tSpindle" in statement:
        text = text.replace("    tSpindle.tframe.trans := [0,0,250];\n", "")
    path = tmp_path / "upd.mod"
    path.write_text(text)
    tp = parse_program(path)
    assert not tp.resolved.all()
    assert any("upd.mod:8: " in n and "is assigned" in n for n in tp.notes), tp.notes


WHOLE = """MODULE m
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wobj1 := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR robtarget p1 := [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\\Off;
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1 := [[100,50,120],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1 := [[150,-30,130],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
  ENDPROC
ENDMODULE
"""


def test_rapid_whole_robtarget_assignments_are_compensated_into_their_own_numbers(tmp_path, model_path):
    """Each move's numbers are the declaration's or an assignment's: compensation writes each
    there, and the written program reads back to the compensated targets."""
    path = tmp_path / "upd.mod"
    path.write_text(WHOLE)
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "upd.mod")
    assert result.exit_code == 0, result.output
    text = (tmp_path / "out" / "upd.mod").read_text()
    for old in ("[[10,20,150]", "p1 := [[100,50,120]", "p1 := [[150,-30,130]"):
        assert old not in text
    assert text.count("\n    p1 := [[") == 2
    before, after = parse_program(path), parse_program(tmp_path / "out" / "upd.mod")
    assert after.resolved.all()
    moved = np.linalg.norm(after.base_positions() - before.base_positions(), axis=1)
    assert (moved > 0.05).all() and (moved < 20).all()


def test_rapid_rotation_update_sharing_position_numbers_is_refused_where_they_are(tmp_path, model_path):
    """After 'p1.rot := ...' two moves use the position numbers of line 8 but need different
    compensated values: refused at those numbers, nothing written."""
    path = tmp_path / "upd.mod"
    path.write_text(RAPID)
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "upd.mod")
    assert result.exit_code == 2 and "upd.mod:8:13:" in result.output and "give each use its own point" in result.output
    assert list((tmp_path / "out").iterdir()) == []


KRL_SRC = """DEF a( )
$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}
$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}
LIN XP1
XP1 = {X 1000, Y 0, Z 410, A 10, B 180, C 0, S 2, T 2, E1 0, E2 0, E3 0, E4 0, E5 0, E6 0}
LIN XP1
XP1.X = 950
LIN XP1
END
"""
KRL_DAT = "DEFDAT a\nDECL E6POS XP1={X 900, Y -200, Z 400, A 0, B 180, C 0, S 2, T 2, E1 0, E2 0, E3 0, E4 0, E5 0, E6 0}\nENDDAT\n"


def test_krl_point_assignments_between_motions_are_followed(tmp_path):
    """KSS 8 SI, "Structures": an assignment runs between the motions around it (advance run
    aside). Worked by hand: XP1 as declared (900, -200, 400); the whole aggregate (1000, 0,
    410); 'XP1.X = 950' changes X only: (950, 0, 410)."""
    (tmp_path / "a.src").write_text(KRL_SRC)
    (tmp_path / "a.dat").write_text(KRL_DAT)
    tp = parse_program(tmp_path / "a.src")
    np.testing.assert_allclose(tp.position, [[900, -200, 400], [1000, 0, 410], [950, 0, 410]], atol=1e-9)
    assert tp.resolved.all()


def test_krl_aggregate_assignment_is_compensated_into_its_own_numbers(tmp_path, model_path):
    """Without 'XP1.X = 950' each move has its own numbers (the .dat's, the aggregate's): both
    are compensated where they are written."""
    (tmp_path / "a.src").write_text(KRL_SRC.replace("XP1.X = 950\nLIN XP1\n", ""))
    (tmp_path / "a.dat").write_text(KRL_DAT)
    (tmp_path / "out").mkdir()
    result = _compensate(tmp_path / "a.src", model_path, tmp_path / "out" / "a.src")
    assert result.exit_code == 0, result.output
    assert "XP1 = {X 1000," not in (tmp_path / "out" / "a.src").read_text()
    assert "XP1={X 900," not in (tmp_path / "out" / "a.dat").read_text()


def test_krl_component_assignment_sharing_numbers_is_refused_where_they_are(tmp_path, model_path):
    """'XP1.X = 950' keeps the aggregate's Y and Z for the third move: line 5's Y serves two
    moves that need different values; refused there (a.src:5:...), nothing written."""
    (tmp_path / "a.src").write_text(KRL_SRC)
    (tmp_path / "a.dat").write_text(KRL_DAT)
    (tmp_path / "out").mkdir()
    result = _compensate(tmp_path / "a.src", model_path, tmp_path / "out" / "a.src")
    assert result.exit_code == 2 and "a.src:5:" in result.output and "give each use its own point" in result.output, result.output
    assert list((tmp_path / "out").iterdir()) == []


LOOP = """MODULE m
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wobj1 := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR robtarget p1 := [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\\Off;
    FOR i FROM 1 TO 3 DO
      MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
      p1.trans.z := 120;
      MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
      wobj1.oframe.trans := [100, 0, 0];
    ENDFOR
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
  ENDPROC
ENDMODULE
"""


def test_rapid_assignments_in_a_for_loop_with_known_count_are_followed_pass_by_pass(tmp_path):
    """ABB RAPID instruction FOR: the body runs once per counter value, its statements in
    order. Worked by hand: pass 1 moves to p1 as declared (910, -80, 450), then z := 120:
    (910, -80, 420); 'wobj1.oframe.trans := [100, 0, 0]' moves wobj1 100 mm in x for passes 2
    and 3 (both moves (1010, -80, 420)) and the move after ENDFOR: 7 moves."""
    path = tmp_path / "loop.mod"
    path.write_text(LOOP)
    tp = parse_program(path)
    np.testing.assert_allclose(tp.base_positions(), [[910, -80, 450], [910, -80, 420]] + [[1010, -80, 420]] * 5, atol=1e-9)
    assert tp.resolved.all() and not tp.notes


@pytest.mark.parametrize("head", ["FOR i FROM 1 TO nCount DO", "WHILE DInput(di1) = 1 DO"])
def test_rapid_assignments_in_loops_of_unknown_count_stay_unresolved(tmp_path, head):
    text = LOOP.replace("FOR i FROM 1 TO 3 DO", head)
    path = tmp_path / "loop.mod"
    path.write_text(text.replace("ENDFOR", "ENDWHILE") if head.startswith("WHILE") else text)
    tp = parse_program(path)
    assert not tp.resolved.all() and any("loop.mod:9: " in n and "is assigned" in n for n in tp.notes), tp.notes


def test_rapid_assignment_in_a_loop_is_compensated_into_its_own_numbers(tmp_path, model_path):
    """Every pass moves to the assignment's point: one compensated value, written there."""
    text = LOOP.replace("      MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;\n      p1.trans.z := 120;\n", "      p1 := [[100,50,120],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n")
    text = text.replace("      wobj1.oframe.trans := [100, 0, 0];\n", "")
    path = tmp_path / "loop.mod"
    path.write_text(text)
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "loop.mod")
    assert result.exit_code == 0, result.output
    written = (tmp_path / "out" / "loop.mod").read_text()
    assert "p1 := [[100,50,120]" not in written and "[[10,20,150]" in written  # the declaration serves no move
    after = parse_program(tmp_path / "out" / "loop.mod")
    assert after.resolved.all() and len(after) == 4
