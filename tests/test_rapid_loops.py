"""RAPID FOR loops run as the controller runs them (issue 12 B): one IR row per executed move.

Rule: ABB "Technical reference manual - RAPID Instructions, Functions and Data types"
(3HAC050917-001), instruction FOR: ``FOR counter FROM start TO end [STEP step] DO ... ENDFOR``
runs the body with the counter at start, start + step, ... while it has not passed the end;
without STEP the step is 1, or -1 when the start is larger than the end. Function Offs(p,
dx, dy, dz) is p displaced by (dx, dy, dz) in its object frame; path{k} is the k-th array
element (RAPID overview, "Arrays", indices from 1). Each expected position is worked out by
hand from these rules.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import SharedNumberError
from postproc.programs import emit_texts, parse_program

RT = "[[{},{},{}],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
DATA = (f"  CONST robtarget p1 := {RT.format(500, 0, 400)};\n"
        f"  CONST robtarget path{{3}} := [{RT.format(600, 0, 400)},\n    {RT.format(610, 10, 400)},\n    {RT.format(620, 20, 400)}];\n")


def module(body: str) -> bytes:
    return ("MODULE M\n" + DATA + "  PROC main()\n" + body + "  ENDPROC\nENDMODULE\n").encode("latin-1")


def read(body: str):
    data = module(body)
    tp = parse_program("m.mod", "rapid", data)
    assert emit_texts(tp, tp)[0].encode("latin-1") == data  # unrolled rows still round-trip the text
    return tp


LOOP = ("    FOR i FROM 1 TO 3 DO\n"
        "      MoveL Offs(p1, i*10, 0, 0), v100, z10, tool0;\n"
        "      MoveL path{i}, v100, z10, tool0;\n"
        "    ENDFOR\n")  # lines 7-10 of the module


def test_for_over_an_array_and_offs_gives_one_row_per_pass_in_execution_order():
    # i = 1, 2, 3: Offs(p1, 10 i, 0, 0) = (500 + 10 i, 0, 400), then path{i}.
    tp = read(LOOP)
    assert tp.line.tolist() == [8, 9] * 3 and tp.resolved.all()
    np.testing.assert_array_equal(tp.position, [[510, 0, 400], [600, 0, 400], [520, 0, 400], [610, 10, 400], [530, 0, 400], [620, 20, 400]])


def test_step_default_down_step_nested_loops_and_zero_passes():
    # FOR j FROM 3 TO 1: no STEP, start > end -> step -1: j = 3, 2, 1. STEP 2 from 1 to 4: 1, 3.
    # Nested: i = 1, 2 outside, k = 0, 1 inside: Offs(p1, 100 i, k, 0). FROM 1 TO 0 STEP 1: no pass.
    tp = read("    FOR j FROM 3 TO 1 DO\n      MoveL path{j}, v100, fine, tool0;\n    ENDFOR\n"
              "    FOR s FROM 1 TO 4 STEP 2 DO\n      MoveL Offs(p1, 0, 0, s), v100, fine, tool0;\n    ENDFOR\n"
              "    FOR i FROM 1 TO 2 DO\n      FOR k FROM 0 TO 1 DO\n        MoveL Offs(p1, i*100, k, 0), v100, fine, tool0;\n"
              "      ENDFOR\n    ENDFOR\n"
              "    FOR z FROM 1 TO 0 STEP 1 DO\n      MoveL p1, v100, fine, tool0;\n    ENDFOR\n")
    np.testing.assert_array_equal(tp.position, [[620, 20, 400], [610, 10, 400], [600, 0, 400], [500, 0, 401], [500, 0, 403],
                                                [600, 0, 400], [600, 1, 400], [700, 0, 400], [700, 1, 400]])
    assert tp.resolved.all()


def test_a_one_line_move_in_a_loop_body_is_run_every_pass():
    # MoveL p1, v100, z10, tool0; is the shape read in bulk elsewhere; in a FOR it runs twice.
    tp = read("    FOR i FROM 1 TO 2 DO\n      MoveL p1, v100, z10, tool0;\n    ENDFOR\n    MoveL p1, v100, z10, tool0;\n")
    assert tp.line.tolist() == [8, 8, 10]


def test_a_count_not_known_at_post_time_lists_the_body_once():
    tp = read("    FOR i FROM 1 TO n DO\n      MoveL Offs(p1, i*10, 0, 0), v100, z10, tool0;\n      MoveL p1, v100, z10, tool0;\n    ENDFOR\n")
    assert tp.line.tolist() == [8, 9] and tp.resolved.tolist() == [False, True]
    assert any("m.mod:7: the FOR count is not known" in n for n in tp.notes)


def test_inspect_json_lists_every_executed_target(tmp_path):
    prog = tmp_path / "m.mod"
    prog.write_bytes(module(LOOP))
    result = CliRunner().invoke(app, ["inspect", str(prog), "--json"])
    assert result.exit_code == 0, result.output
    moves = json.loads(result.stdout)["moves"]
    assert [m["line"] for m in moves] == [8, 9] * 3
    assert [m["xyz"][0] for m in moves] == [510, 600, 520, 610, 530, 620]


def test_write_back_one_number_for_every_pass_or_refuse_with_its_place():
    tp = read(LOOP)
    new = tp.position.copy()
    new[:, 0] += 1.5  # the same correction on every pass: p1's X (one number) becomes 501.5
    text = emit_texts(tp, tp.with_positions(new))[0]
    assert "[[501.5,0,400]" in text and "[[601.5,0,400]" in text and "[[621.5,20,400]" in text
    assert "Offs(p1, i*10, 0, 0)" in text
    new = tp.position.copy()
    new[tp.line == 8, 1] += [0.1, 0.2, 0.3]  # Offs's dy (the literal 0 on line 8) would need three values
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(new))
    assert (exc.value.path, exc.value.line, exc.value.column) == ("m.mod", 8, 28)
    new = tp.position.copy()
    new[tp.line == 8, 0] += [0.1, 0.2, 0.3]  # Offs(p1, i*10, ..): p1's X (line 2) would need three values
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(new))
    assert (exc.value.path, exc.value.line, exc.value.column) == ("m.mod", 2, 27)  # the 500 of p1


def test_loops_that_run_too_many_statements_are_refused_with_their_line():
    from postproc.errors import ParseError

    body = "    FOR i FROM 1 TO 2000 DO\n      FOR j FROM 1 TO 1000 DO\n        MoveL p1, v100, z10, tool0;\n      ENDFOR\n    ENDFOR\n"
    with pytest.raises(ParseError, match=r"m.mod:7:5: the FOR loops here run more than 200,000 statements"):
        parse_program("m.mod", "rapid", module(body))


# WHILE (instruction WHILE: the condition is evaluated before each pass; Incr adds 1): a
# routine's own VAR num (RAPID overview, "Scope of data": a routine's data is local to it) set
# in straight-line code is followed exactly.
def test_while_over_a_local_counter_runs_each_pass():
    # i = 1, 2, 3 pass; Offs(p1, 10 i, 0, 0); after the loop i = 4; the one-line MoveL runs 3 times.
    tp = read("    VAR num i;\n    i := 1;\n    WHILE i <= 3 DO\n      MoveL Offs(p1, i*10, 0, 0), v100, z10, tool0;\n"
              "      MoveL p1, v100, z10, tool0;\n      Incr i;\n    ENDWHILE\n    MoveL Offs(p1, i, 0, 0), v100, z10, tool0;\n")
    assert tp.line.tolist() == [10, 11] * 3 + [14] and tp.resolved.all()
    np.testing.assert_array_equal(tp.position[::2, 0], [510, 520, 530, 504])


@pytest.mark.parametrize("body, why", [
    ("    VAR num n := 2;\n    WHILE n > 0 DO\n      MoveL Offs(p1, 0, n, 0), v100, z10, tool0;\n      IF n > 1 n := n - 1;\n      n := n - 1;\n    ENDWHILE\n",
     "the counter also changes in a one-line IF"),
    ("    VAR num n := 2;\n    TPReadNum n, \"how many?\";\n    WHILE n > 0 DO\n      MoveL Offs(p1, 0, n, 0), v100, z10, tool0;\n      n := n - 1;\n    ENDWHILE\n",
     "the start value is read at run time"),
    ("    VAR num n;\n    WHILE n > 0 DO\n      MoveL Offs(p1, 0, n, 0), v100, z10, tool0;\n      n := n - 1;\n    ENDWHILE\n",
     "no start value in the text"),
])
def test_a_while_whose_count_the_text_does_not_give_is_listed_once(body, why):
    tp = read(body)
    assert len(tp) == 1 and not tp.resolved.any(), why
    assert any("passes of this WHILE is not known" in n for n in tp.notes)


def test_a_jump_in_the_module_stops_counter_tracking():
    tp = read("    VAR num i := 1;\n  again:\n    WHILE i <= 2 DO\n      MoveL Offs(p1, i, 0, 0), v100, z10, tool0;\n      Incr i;\n    ENDWHILE\n"
              "    IF i < 9 GOTO again;\n")
    assert len(tp) == 1 and not tp.resolved.any()
    tp = read("    VAR num i := 1;\n  again:\n    MoveL Offs(p1, i, 0, 0), v100, z10, tool0;\n    i := i + 1;\n    IF i < 3 GOTO again;\n")
    assert not tp.resolved.any()  # the move runs with i = 1, then 2: no one value
