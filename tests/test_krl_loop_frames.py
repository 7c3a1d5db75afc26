"""KRL $BASE / $TOOL set inside a FOR body, followed pass by pass (postproc/programs/dialects/krl/passes.py).

Expected positions by hand from "KUKA System Software 8.x, Operating and Programming
Instructions for System Integrators" (KSS 8 SI):
- "FOR ... TO ... ENDFOR": the body runs once per counter value, in order;
- "System variables": $BASE keeps the value of the last executed assignment, so a motion in
  pass k runs under the $BASE of pass k, and the code after ENDFOR under the last pass's;
- "Coordinate systems" / "BASE": a target is at $BASE : target; XP1 = (100, 0, 500),
  BASE_DATA[1] = {X 1000}, BASE_DATA[2] = {Y 2000} (no rotation).
A loop that cannot be followed (its passes unknown, a block or a call in its body) keeps the
old rule: the frame is unknown from the loop on, and those targets are not placed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from postproc.programs import parse_program

DAT = "DEFDAT p\nDECL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0,S 2,T 35}\nENDDAT\n"
CONFIG = "DEFDAT $CONFIG\nBASE_DATA[1]={X 1000,Y 0,Z 0,A 0,B 0,C 0}\nBASE_DATA[2]={X 0,Y 2000,Z 0,A 0,B 0,C 0}\nENDDAT\n"


def program(tmp_path: Path, body: str, subs: str = ""):
    (tmp_path / "p.src").write_text("DEF p( )\nDECL INT I\n$BASE = BASE_DATA[1]\n$TOOL = $NULLFRAME\n" + body + "END\n" + subs)
    (tmp_path / "p.dat").write_text(DAT)
    (tmp_path / "$config.dat").write_text(CONFIG)
    return parse_program(tmp_path / "p.src")


def placed(tp) -> np.ndarray:
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)


def test_a_base_component_set_from_the_counter_in_each_pass(tmp_path):
    # $BASE.Y = I * 100 for I = 1..3 under BASE_DATA[1]: XP1 at (1100, 100 I, 500); after: Y 300.
    tp = program(tmp_path, "FOR I = 1 TO 3\n  $BASE.Y = I * 100\n  LIN XP1\nENDFOR\nLIN XP1\n")
    np.testing.assert_allclose(placed(tp), [[1100, 100, 500], [1100, 200, 500], [1100, 300, 500], [1100, 300, 500]])


def test_a_base_changed_from_its_own_value_accumulates_over_the_passes(tmp_path):
    # LIN XP1 before $BASE.X = $BASE.X + 50 in the body: passes see X 1000, 1050, 1100; after: 1150.
    tp = program(tmp_path, "FOR I = 1 TO 3\n  LIN XP1\n  $BASE.X = $BASE.X + 50\nENDFOR\nLIN XP1\n")
    np.testing.assert_allclose(placed(tp)[:, 0], [1100, 1150, 1200, 1250])


def test_base_data_indexed_by_the_counter(tmp_path):
    # $BASE = BASE_DATA[I], I = 1, 2: (1100, 0, 500) then (100, 2000, 500); a subprogram called
    # after the loop runs under BASE_DATA[2] (calls followed too: calls.py).
    tp = program(tmp_path, "FOR I = 1 TO 2\n  $BASE = BASE_DATA[I]\n  LIN XP1\nENDFOR\nsub( )\n", "DEF sub( )\nLIN XP1\nEND\n")
    np.testing.assert_allclose(placed(tp), [[1100, 0, 500], [100, 2000, 500], [100, 2000, 500]])
    assert "BASE_DATA[2]" in tp.frame_names


def test_loops_that_cannot_be_followed_leave_the_frame_unknown(tmp_path):
    # An IF in the body (the change may or may not run), a WHILE (passes unknown), a call in
    # the body: every target from the loop on is not placed.
    bodies = ["FOR I = 1 TO 2\n  IF $IN[1] THEN\n    $BASE.X = 0\n  ENDIF\n  LIN XP1\nENDFOR\nLIN XP1\n",
              "WHILE $IN[1]\n  $BASE.X = 0\n  LIN XP1\nENDWHILE\nLIN XP1\n",
              "FOR I = 1 TO 2\n  $BASE.X = 0\n  other( )\n  LIN XP1\nENDFOR\nLIN XP1\n"]
    for body in bodies:
        tp = program(tmp_path, "LIN XP1\n" + body)
        assert tp.placed()[0] and not tp.placed()[1:].any(), body


def test_while_and_repeat_over_a_counter_follow_the_frame_per_pass(tmp_path):
    # KSS 8 SI "WHILE ... ENDWHILE" / "REPEAT ... UNTIL": with I = 1 and I = I + 1 the bodies run
    # for I = 1, 2, 3 (counters.py). WHILE: $BASE.Y = I * 100 before LIN XP1: Y 100, 200, 300.
    # REPEAT: LIN XP1, then $BASE.X = $BASE.X + 50: X 1000, 1050, 1100 under the LINs, 1150 after.
    tp = program(tmp_path, "I = 1\nWHILE I <= 3\n  $BASE.Y = I * 100\n  LIN XP1\n  I = I + 1\nENDWHILE\nLIN XP1\n")
    np.testing.assert_allclose(placed(tp), [[1100, 100, 500], [1100, 200, 500], [1100, 300, 500], [1100, 300, 500]])
    tp = program(tmp_path, "I = 1\nREPEAT\n  LIN XP1\n  $BASE.X = $BASE.X + 50\n  I = I + 1\nUNTIL I > 3\nLIN XP1\n")
    np.testing.assert_allclose(placed(tp)[:, 0], [1100, 1150, 1200, 1250])
    # After the update the counter is the new one: $BASE.Y = I * 100 below I = I + 1 gives Y 200, 300, 400.
    tp = program(tmp_path, "I = 1\nWHILE I <= 3\n  I = I + 1\n  $BASE.Y = I * 100\n  LIN XP1\nENDWHILE\n")
    np.testing.assert_allclose(placed(tp)[:, 1], [200, 300, 400])
