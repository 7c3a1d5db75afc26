"""KRL loops as the controller runs them (issue 12 B): one IR row per executed motion.

Rule: KUKA System Software 8.x, Operating and Programming Instructions for System Integrators,
"FOR ... TO ... ENDFOR": ``FOR Counter = Start TO End [STEP Increment]``: the counter starts at
Start, the body runs while the counter has not passed End, the counter then changes by
Increment (+1 without STEP; a negative Increment counts down; Start already past End: no
pass). LOOP / WHILE / REPEAT run a number of passes the text does not give: their body is
listed once and noted. A target is $BASE : point in the robot base frame ("BASE").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from krl_programs import placed_positions, read_krl

from postproc.errors import SharedNumberError
from postproc.programs import emit_texts

DAT = """DEFDAT p
DECL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0,S 2,T 35}
DECL E6POS XP[3]
XP[1]={X 1,Y 2,Z 3,A 0,B 90,C 0}
XP[2]={X 4,Y 5,Z 6,A 0,B 90,C 0}
XP[3]={X 7,Y 8,Z 9,A 0,B 90,C 0}
ENDDAT
"""
CONFIG = "DEFDAT $CONFIG\nBASE_DATA[1]={X 1000,Y 0,Z 0,A 0,B 0,C 0}\nENDDAT\n"


def program(tmp_path: Path, body: str):
    return read_krl(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\n$TOOL = $NULLFRAME\n" + body + "END\n", DAT, CONFIG)


def test_for_over_an_array_runs_each_pass_in_order(tmp_path):
    # I = 1, 2, 3: XP[I] then XP1, each in BASE_DATA[1] = {X 1000}.
    tp = program(tmp_path, "FOR I = 1 TO 3\n  LIN XP[I]\n  PTP XP1\nENDFOR\n")
    assert tp.line.tolist() == [5, 6] * 3
    np.testing.assert_allclose(placed_positions(tp), [[1001, 2, 3], [1100, 0, 500], [1004, 5, 6], [1100, 0, 500], [1007, 8, 9], [1100, 0, 500]])
    assert not any("XP[I]" in n for n in tp.notes)


def test_step_down_nested_and_no_pass(tmp_path):
    # J = 3, 1 (STEP -2) x K = 1, 2: four passes of line 6; FOR N = 2 TO 1: none.
    tp = program(tmp_path, "FOR J = 3 TO 1 STEP -2\n  FOR K = 1 TO 2\n    LIN {X 10, Y 20, Z 30, A 0, B 90, C 0}\n  ENDFOR\nENDFOR\n"
                           "FOR N = 2 TO 1\n  LIN XP1\nENDFOR\n")
    assert tp.line.tolist() == [6] * 4
    np.testing.assert_allclose(placed_positions(tp), [[1010, 20, 30]] * 4)


def test_partial_aggregates_and_relative_moves_follow_execution_order(tmp_path):
    # LIN {X 10}: the other components are the previous target's; pass 2's previous target is
    # pass 1's LIN_REL end. LIN_REL {Y 5} adds 5 mm to Y from where the robot is.
    tp = program(tmp_path, "LIN XP1\nFOR I = 1 TO 2\n  LIN {X 10}\n  LIN_REL {Y 5}\nENDFOR\n")
    np.testing.assert_allclose(tp.position, [[100, 0, 500], [10, 0, 500], [10, 5, 500], [10, 5, 500], [10, 10, 500]])


@pytest.mark.parametrize("loop", ["FOR I = 1 TO N\n  LIN XP1\nENDFOR\n", "LOOP\n  LIN XP1\n  EXIT\nENDLOOP\n",
                                  "WHILE $IN[1]\n  LIN XP1\nENDWHILE\n", "REPEAT\n  LIN XP1\nUNTIL $IN[1]\n"])
def test_a_count_not_known_at_post_time_lists_the_body_once(tmp_path, loop):
    tp = program(tmp_path, loop)
    assert tp.line.tolist() == [5] and any("p.src:4: the number of passes" in n for n in tp.notes)


def _assert_written_once_for_both_passes_or_refused_at(tp, line: int) -> None:
    """The loop's two passes of LIN {X 10, Y 20, Z 30, ...}: one correction for both is written
    once in the text; a different one per pass is refused at the Z number (p.src, ``line``, column 22)."""
    new = tp.position.copy()
    new[:, 2] += 0.5
    assert "LIN {X 10, Y 20, Z 30.5," in emit_texts(tp, tp.with_positions(new))[0]
    new[1, 2] += 0.25  # the second pass would need Z 30.75
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(new))
    assert (Path(exc.value.path).name, exc.value.line, exc.value.column) == ("p.src", line, 22)


def test_write_back_once_for_every_pass_or_refuse_with_the_place(tmp_path):
    tp = program(tmp_path, "FOR I = 1 TO 2\n  LIN {X 10, Y 20, Z 30, A 0, B 90, C 0}\nENDFOR\n")
    _assert_written_once_for_both_passes_or_refused_at(tp, 5)


# ------------------------------------------------- WHILE / REPEAT over a counter (counters.py)
# KSS 8 SI "WHILE ... ENDWHILE": the condition is checked before each pass, the body runs while
# it is TRUE; "REPEAT ... UNTIL": the body runs, then the loop ends when the condition is TRUE;
# a variable declared in the DEF is local to it (nothing else changes it).

def counter_program(tmp_path: Path, decl: str, body: str):
    return read_krl(tmp_path, "DEF p( )\n" + decl + "$BASE = BASE_DATA[1]\n$TOOL = $NULLFRAME\n" + body + "END\n", DAT, CONFIG)


def test_while_over_a_counter_runs_each_pass_with_the_counter_of_its_place(tmp_path):
    # I = 1: passes with I = 1, 2 (I <= 2); LIN XP[I] before the update reads XP[1] then XP[2],
    # the PTP after it XP[2] then XP[3]; each in BASE_DATA[1] = {X 1000}.
    tp = counter_program(tmp_path, "DECL INT I\n", "I = 1\nWHILE I <= 2\n  LIN XP[I]\n  I = I + 1\n  PTP XP[I]\nENDWHILE\n")
    assert tp.line.tolist() == [7, 9] * 2
    np.testing.assert_allclose(placed_positions(tp), [[1001, 2, 3], [1004, 5, 6], [1004, 5, 6], [1007, 8, 9]])


def test_repeat_runs_at_least_once_and_stops_when_the_condition_holds(tmp_path):
    # J = 3: pass (J -> 1), 1 < 0 false: pass (J -> -1), -1 < 0: stop: two passes. K = 5 with
    # UNTIL K > 0: one pass although the condition holds before it.
    tp = counter_program(tmp_path, "DECL INT J, K\n", "J = 3\nREPEAT\n  LIN XP1\n  J = J - 2\nUNTIL J < 0\n"
                                                    "K = 5\nREPEAT\n  LIN XP[1]\n  K = K + 1\nUNTIL K > 0\n")
    assert tp.line.tolist() == [7, 7, 12]
    np.testing.assert_allclose(placed_positions(tp), [[1100, 0, 500], [1100, 0, 500], [1001, 2, 3]])


@pytest.mark.parametrize("decl, body, why", [
    ("", "I = 1\nWHILE I <= 2\n  LIN XP1\n  I = I + 1\nENDWHILE\n", "not an INT declared in this DEF"),
    ("DECL INT I\n", "I = 1\nWHILE I <= 2\n  LIN XP1\n  IF $IN[1] THEN\n    I = I + 1\n  ENDIF\nENDWHILE\n", "not changed exactly once"),
    ("DECL INT I\n", "I = 1\nWHILE I <= 2\n  LIN XP1\n  I = I * 2\nENDWHILE\n", "changed by something else"),
    ("DECL INT I\n", "IF $IN[1] THEN\n  I = 5\nENDIF\nI = 1\nWHILE I <= 2\n  LIN XP1\n  I = I + 1\nENDWHILE\n", "not set by literal integers"),
    ("DECL INT I\n", "I = 1\nWHILE I <= 2\n  LIN XP1\n  I = I + 1\n  IF $IN[1] THEN\n    EXIT\n  ENDIF\nENDWHILE\n", "EXIT"),
    ("DECL INT I\n", "I = 1\nWHILE I <= 2\n  LIN XP1\n  I = I + 1\n  bump(I)\nENDWHILE\n", "passed to a call"),
    ("DECL INT I\n", "I = 1\nWHILE I <= N\n  LIN XP1\n  I = I + 1\nENDWHILE\n", "not a comparison of a counter with a literal"),
])
def test_a_counter_loop_not_provable_from_the_text_is_listed_once(tmp_path, decl, body, why):
    tp = counter_program(tmp_path, decl, body)
    assert tp.line.tolist().count(tp.line[0]) == 1
    assert any("the number of passes of this WHILE is not known" in n and why in n for n in tp.notes), tp.notes


def test_counter_loop_write_back_once_for_every_pass_or_refuse_with_the_place(tmp_path):
    tp = counter_program(tmp_path, "DECL INT I\n", "I = 0\nWHILE I < 2\n  LIN {X 10, Y 20, Z 30, A 0, B 90, C 0}\n  I = I + 1\nENDWHILE\n")
    assert tp.line.tolist() == [7, 7]
    _assert_written_once_for_both_passes_or_refused_at(tp, 7)


def test_a_for_that_may_exit_early_is_listed_once(tmp_path):
    # KSS 8 SI "EXIT": EXIT leaves the loop: whether passes 2 and 3 run is decided at run time.
    tp = program(tmp_path, "FOR I = 1 TO 3\n  LIN XP1\n  IF $IN[1] THEN\n    EXIT\n  ENDIF\nENDFOR\n")
    assert tp.line.tolist() == [5] and any("p.src:4: the number of passes of this FOR" in n and "EXIT" in n for n in tp.notes)
