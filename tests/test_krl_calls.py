"""KRL $BASE / $TOOL followed through calls to subprograms (postproc/programs/dialects/krl/calls.py).

Expected positions worked out by hand from "KUKA System Software 8.x, Operating and
Programming Instructions for System Integrators" (KSS 8 SI):
- "Subprograms and functions": a local subprogram (a further DEF ... END of the .src) runs
  where it is called, then the caller continues after the call;
- "System variables": $BASE and $TOOL are global: a subprogram runs with the frames in force
  at its call, and the caller continues with the frames the subprogram leaves (BAS.SRC's
  BAS(#BASE, n) works this way: its BASE(n) sets $BASE for the caller);
- "Coordinate systems" / "BASE": a Cartesian target's position in the robot base is
  $BASE : target ($BASE {X 1000}: XP1 (100, 0, 500) is at (1100, 0, 500));
- "INTERRUPT" / "TRIGGER": ``DO NAME()`` runs NAME when the event occurs, at a time the
  program text does not give.
A routine reached from places with different frames, before it sets its own, cannot be
given one frame: its targets are not placed (refused for compensation), with a note.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.programs import parse_program

DAT = "DEFDAT p\nDECL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0,S 2,T 35}\nENDDAT\n"
CONFIG = "DEFDAT $CONFIG\nBASE_DATA[1]={X 1000,Y 0,Z 0,A 0,B 0,C 0}\nBASE_DATA[2]={X 0,Y 2000,Z 0,A 0,B 0,C 0}\nENDDAT\n"


def program(tmp_path, text: str):
    (tmp_path / "p.src").write_text(text.strip() + "\n")
    (tmp_path / "p.dat").write_text(DAT)
    (tmp_path / "$config.dat").write_text(CONFIG)
    return parse_program(tmp_path / "p.src")


def placed_positions(tp) -> np.ndarray:
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)


def test_a_subprogram_runs_with_the_frame_of_its_call_and_leaves_its_own(tmp_path):
    # sub written after the $BASE = BASE_DATA[2] of line 5, but called on line 3 under
    # BASE_DATA[1]: its LIN XP1 is at (1100, 0, 500), not (100, 2000, 500).
    # setb( ) sets BASE_DATA[2]: the caller's LIN on line 7 is at (100, 2000, 500).
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
sub( )
LIN XP1
$BASE = BASE_DATA[1]
setb( )
LIN XP1
END
DEF sub( )
LIN XP1
END
DEF setb( )
$BASE = BASE_DATA[2]
END
""")
    order = np.argsort(tp.line)
    assert tp.line[order].tolist() == [4, 7, 10]
    np.testing.assert_allclose(placed_positions(tp)[order], [[1100, 0, 500], [100, 2000, 500], [1100, 0, 500]], atol=1e-9)


def test_nested_calls_are_followed_in_execution_order(tmp_path):
    # p -> a( ) -> b( ) sets BASE_DATA[2]; a's LIN after the call of b is in BASE_DATA[2];
    # p's LIN after a( ) too: (100, 2000, 500) both; a's LIN before b( ) in BASE_DATA[1].
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
a( )
LIN XP1
END
DEF a( )
LIN XP1
b( )
LIN XP1
END
DEF b( )
$BASE = BASE_DATA[2]
END
""")
    by_line = dict(zip(tp.line.tolist(), placed_positions(tp).tolist()))
    np.testing.assert_allclose([by_line[7], by_line[9], by_line[4]], [[1100, 0, 500], [100, 2000, 500], [100, 2000, 500]], atol=1e-9)


def test_a_subprogram_called_twice_gives_a_row_per_call_with_the_frame_of_that_call(tmp_path):
    # KSS 8 SI "Subprograms and functions": sub( ) runs each time it is called. Called under
    # BASE_DATA[1] ({X 1000}) and then under BASE_DATA[2] ({Y 2000}): its LIN XP1 (100, 0, 500)
    # is executed at (1100, 0, 500), then at (100, 2000, 500), then p's own LIN at (100, 2000, 500).
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
sub( )
$BASE = BASE_DATA[2]
sub( )
LIN XP1
END
DEF sub( )
LIN XP1
END
""")
    assert tp.line.tolist() == [9, 9, 6]
    np.testing.assert_allclose(placed_positions(tp), [[1100, 0, 500], [100, 2000, 500], [100, 2000, 500]], atol=1e-9)


def test_a_number_a_subprogram_runs_with_two_values_is_refused_on_write_back(tmp_path):
    # Both executed copies of sub's LIN XP1 read the one declaration of XP1 (p.dat line 2):
    # the same correction for both is written once; two different ones cannot be, and are
    # refused with the number's file, line and column.
    from postproc.errors import SharedNumberError
    from postproc.programs import emit_texts

    tp = program(tmp_path, "DEF p( )\nsub( )\nsub( )\nEND\nDEF sub( )\nLIN XP1\nEND\n")
    assert tp.line.tolist() == [6, 6]
    texts = emit_texts(tp, tp.with_positions(tp.position + [0.5, 0, 0]))
    assert "XP1={X 100.5," in texts[1]
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(tp.position + [[0.5, 0, 0], [0.25, 0, 0]]))
    assert (Path(exc.value.path).name, exc.value.line, exc.value.column) == ("p.dat", 2, 19)


def test_a_subprogram_called_in_a_loop_runs_once_per_pass(tmp_path):
    # FOR I = 1 TO 2 with sub( ) inside, then sub( ) once more: three executed LIN XP1, each in
    # BASE_DATA[1]: (1100, 0, 500) three times.
    tp = program(tmp_path, """
DEF p( )
DECL INT I
$BASE = BASE_DATA[1]
FOR I = 1 TO 2
sub( )
ENDFOR
sub( )
END
DEF sub( )
LIN XP1
END
""")
    assert tp.line.tolist() == [10, 10, 10]
    np.testing.assert_allclose(tp.base_positions(), [[1100, 0, 500]] * 3, atol=1e-9)


def test_a_routine_that_sets_its_frame_first_has_it_from_any_call(tmp_path):
    # Called under two bases, but $BASE = BASE_DATA[2] runs before its LIN: (100, 2000, 500) twice.
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
sub( )
$BASE = $WORLD
sub( )
END
DEF sub( )
$BASE = BASE_DATA[2]
LIN XP1
END
""")
    np.testing.assert_allclose(placed_positions(tp), [[100, 2000, 500]] * 2, atol=1e-9)


def test_what_is_not_straight_line_stays_unknown(tmp_path):
    # A call inside IF: the frame after ENDIF depends on the condition. A call of a routine of
    # another module (not in this .src): it may set $BASE. A TRIGGER's DO routine runs at a
    # time the text does not give. A routine no call reaches: the frame it runs with is unknown.
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
IF $IN[1] THEN
setb( )
ENDIF
LIN XP1
END
DEF setb( )
$BASE = BASE_DATA[2]
END
""")
    assert not tp.placed().any()
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nLIN XP1\nOTHERMODULE( )\nLIN XP1\nEND\n")
    assert tp.placed().tolist() == [True, False]
    assert any("p.src:4: OTHERMODULE() is not a subprogram of this file" in n for n in tp.notes)
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
TRIGGER WHEN DISTANCE=0 DELAY=0 DO setb( ) PRIO=-1
LIN XP1
setb( )
LIN XP1
END
DEF setb( )
$BASE = BASE_DATA[2]
END
""")
    assert not tp.placed().any()
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nLIN XP1\nEND\nDEF never( )\nLIN XP1\nEND\n")
    assert tp.placed().tolist() == [True, False]


def test_a_program_without_calls_is_unchanged(tmp_path):
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nLIN XP1\n$BASE = BASE_DATA[2]\nLIN XP1\nEND\n")
    np.testing.assert_allclose(placed_positions(tp), [[1100, 0, 500], [100, 2000, 500]], atol=1e-9)


# ---------------------------------------------------------------- GOTO (jumps.py)
# KSS 8 SI "GOTO": GOTO Marker continues at Marker: in the same routine. A forward jump
# that skips only statements that neither move nor change a variable leaves the same points
# and frames in force at every later target, whether it is taken or not.

def test_a_forward_jump_over_nothing_that_changes_keeps_the_frame(tmp_path):
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
IF $IN[1] THEN
GOTO SKIP
ENDIF
WAIT SEC 1
SKIP:
LIN XP1
END
""")
    np.testing.assert_allclose(placed_positions(tp), [[1100, 0, 500]], atol=1e-9)


def test_a_jump_that_may_change_what_is_in_force_is_not_straight_line(tmp_path):
    # Skips $BASE = BASE_DATA[2]: at LIN XP1 $BASE is BASE_DATA[1] or [2] by $IN[1].
    skip_frame = "DEF p( )\n$BASE = BASE_DATA[1]\nIF $IN[1] THEN\nGOTO SKIP\nENDIF\n$BASE = BASE_DATA[2]\nSKIP:\nLIN XP1\nEND\n"
    # Inside a loop (even to a label in the same pass): left to run time, conservatively.
    in_loop = "DEF p( )\n$BASE = BASE_DATA[1]\nFOR I = 1 TO 2\nIF $IN[1] THEN\nGOTO NEXT\nENDIF\nNEXT:\nLIN XP1\nENDFOR\nEND\n"
    # Backwards: the lines after the label run again after later changes.
    back = "DEF p( )\n$BASE = BASE_DATA[1]\nTOP:\nLIN XP1\n$BASE = BASE_DATA[2]\nGOTO TOP\nEND\n"
    for text, line in ((skip_frame, 4), (in_loop, 5), (back, 6)):
        tp = program(tmp_path, text)
        assert not tp.placed().any(), text
        assert any(f"p.src:{line}: GOTO" in n for n in tp.notes), tp.notes


def test_a_motion_a_forward_jump_may_skip_is_placed_like_one_in_an_if(tmp_path):
    # The skipped LIN runs or not (as a motion inside IF $IN[1]); where it runs, $BASE is
    # BASE_DATA[1] ({X 1000}), set before the jump: both placed at (1100, 0, 500).
    skip_motion = "DEF p( )\n$BASE = BASE_DATA[1]\nIF $IN[1] THEN\nGOTO SKIP\nENDIF\nLIN XP1\nSKIP:\nLIN XP1\nEND\n"
    np.testing.assert_allclose(placed_positions(program(tmp_path, skip_motion)), [[1100, 0, 500]] * 2, atol=1e-9)


JUMP_TABLE = "DEF p(n :IN)\nINT n\n{before}SWITCH n\nCASE 1\nGOTO A\nCASE 2\nGOTO B\nENDSWITCH\nA:\n{in_a}B:\n{after}LIN XP1\nEND\n"


@pytest.mark.parametrize("before, in_a, after, expected", [
    # Set before the jump table: runs once on every way to LIN (nothing the jumps skip changes it).
    ("$BASE = BASE_DATA[1]\nXP1.X = 70\n", "WAIT SEC 0\n", "", [1070, 0, 500]),
    # Set after the last label: runs on every way, last.
    ("$BASE = BASE_DATA[1]\n", "$BASE = BASE_DATA[1]\n", "$BASE = BASE_DATA[2]\n", [100, 2000, 500]),
    # Set between A: and B: (GOTO B skips it): BASE_DATA[1] or [2] at LIN: not placed.
    ("$BASE = BASE_DATA[1]\n", "$BASE = BASE_DATA[2]\n", "", None),
    # The point changed where GOTO B skips it: XP1.X 100 or 70: not resolved.
    ("$BASE = BASE_DATA[1]\n", "XP1.X = 70\n", "", None),
])
def test_a_forward_jump_table_skips_only_the_lines_between_its_gotos_and_labels(tmp_path, before, in_a, after, expected):
    # KSS 8 SI "SWITCH": one CASE runs; "GOTO": the program continues at the label (forward,
    # outside any block): a line between a GOTO and its label may or may not have run, every
    # other line of the routine runs once, in order, whichever CASE the selector n picks.
    tp = program(tmp_path, JUMP_TABLE.format(before=before, in_a=in_a, after=after))
    if expected is None:
        assert not tp.placed().any()
    else:
        np.testing.assert_allclose(placed_positions(tp), [expected], atol=1e-9)


def test_a_jump_in_a_subprogram_makes_its_frame_changes_unknown(tmp_path):
    tp = program(tmp_path, """
DEF p( )
$BASE = BASE_DATA[1]
LIN XP1
sub( )
LIN XP1
END
DEF sub( )
TOP:
$BASE = BASE_DATA[2]
LIN XP1
IF $IN[1] THEN
GOTO TOP
ENDIF
END
""")
    assert dict(zip(tp.line.tolist(), tp.placed().tolist())) == {3: True, 5: False, 10: False}


def test_a_call_tree_too_large_to_follow_falls_back_to_unknown(tmp_path):
    # s0 calls s1 twice, s1 calls s2 twice, ...: 2^15 executed copies of s14 (more than
    # calls.MAX_VISITS): not followed; frames changed in subprograms are unknown everywhere.
    subs = "".join(f"DEF s{k}( )\ns{k + 1}( )\ns{k + 1}( )\nEND\n" for k in range(15)) + "DEF s15( )\n$BASE = BASE_DATA[2]\nEND\n"
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nLIN XP1\ns0( )\nLIN XP1\nEND\n" + subs)
    assert not tp.placed().any()
    assert any("not followed" in n for n in tp.notes)


def test_a_handler_of_another_module_or_a_function_in_a_skipped_condition_is_not_followed(tmp_path):
    # TRIGGER ... DO IR_OTHER( ): a routine of another module runs during the motion after it;
    # it may set $BASE. A GOTO that skips IF f( ) THEN skips a function call that may change it.
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nLIN XP1\nTRIGGER WHEN DISTANCE=0 DELAY=0 DO IR_OTHER( ) PRIO=-1\nLIN XP1\nEND\n")
    assert tp.placed().tolist() == [True, False]
    tp = program(tmp_path, "DEF p( )\n$BASE = BASE_DATA[1]\nIF $IN[1] THEN\nGOTO SKIP\nENDIF\nIF f( ) THEN\nENDIF\nSKIP:\nLIN XP1\nEND\n")
    assert not tp.placed().any()


def test_a_loop_of_a_subprogram_called_twice_runs_in_each_call(tmp_path):
    # sub's FOR I = 1 TO 2 runs LIN XP[I] (p.dat: XP[1] = (1, 2, 3), XP[2] = (4, 5, 6)); sub is
    # called under BASE_DATA[1] ({X 1000}) then BASE_DATA[2] ({Y 2000}): four executed motions
    # (1001, 2, 3), (1004, 5, 6), (1, 2002, 3), (4, 2005, 6) (KSS 8 SI "FOR", "Subprograms").
    (tmp_path / "p.src").write_text("DEF p( )\n$BASE = BASE_DATA[1]\nsub( )\n$BASE = BASE_DATA[2]\nsub( )\nEND\n"
                                    "DEF sub( )\nDECL INT I\nFOR I = 1 TO 2\nLIN XP[I]\nENDFOR\nEND\n")
    (tmp_path / "p.dat").write_text("DEFDAT p\nDECL E6POS XP[2]\nXP[1]={X 1,Y 2,Z 3,A 0,B 90,C 0}\nXP[2]={X 4,Y 5,Z 6,A 0,B 90,C 0}\nENDDAT\n")
    (tmp_path / "$config.dat").write_text(CONFIG)
    tp = parse_program(tmp_path / "p.src")
    np.testing.assert_allclose(placed_positions(tp), [[1001, 2, 3], [1004, 5, 6], [1, 2002, 3], [4, 2005, 6]], atol=1e-9)
