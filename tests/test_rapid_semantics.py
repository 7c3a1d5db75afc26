"""RAPID as the controller reads it: syntax seen in real modules, and what the moves mean.

Expected positions are written by hand from ABB's "Technical reference manual - RAPID
Instructions, Functions and Data types" (3HAC050917-001) and "RAPID overview"
(3HAC050947-001); each test names the section it follows.
"""

from __future__ import annotations

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

P1 = "[[100,200,300],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def module(*body: str, data: tuple[str, ...] = ()) -> bytes:
    lines = ["MODULE M", f"  CONST robtarget p1 := {P1};", *data, "  PROC main()", *body, "  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines).encode("latin-1")


def read(data: bytes, name: str = "m.mod"):
    tp = parse_program(name, "rapid", data)
    assert emit_texts(tp, tp)[0].encode("latin-1") == data
    return tp


# ------------------------------------------------------------------ syntax from real modules

def test_connect_trap_and_error_handler_with_a_number_list():
    """CONNECT intno WITH trap (instruction CONNECT); an ERROR handler may list the error
    numbers it handles (RAPID overview, 'Error recovery': ERROR (ERR_A, ERR_B))."""
    data = "\n".join([
        "MODULE M", "  VAR intnum intno1;",
        "  PROC main()", "    CONNECT intno1 WITH on_trap;", "    ISignalDI di1, 1, intno1;",
        "  ERROR (ERR_SOCK_TIMEOUT, ERR_SOCK_CLOSED)", "    RETRY;", "  ENDPROC",
        "  LOCAL TRAP on_trap", "    TPWrite \"trap\";", "  ENDTRAP", "ENDMODULE", ""]).encode()
    assert len(read(data)) == 0


def test_one_statement_if_over_two_lines_keeps_its_move():
    """IF cond statement; without THEN is the compact IF (instruction 'Compact IF'): the
    statement may be on the next line; its move is one target at that line."""
    tp = read(module("    IF ( NOT (IsStopMoveAct(\\FromMoveTask) OR IsStopMoveAct(\\FromNonMoveTask)) )",
                     "      MoveL p1, v100, z1, tool0;",
                     "    IF a > 2 MoveL Offs(p1, 10, 0, 0), v100, z1, tool0;",
                     "    IF a > 3",
                     "      MoveL Offs(p1, 20, 0, 0), v100, z1, tool0;",
                     "    IF a > 4 AND",
                     "       b < 3 THEN",
                     "      MoveJ p1, v100, z1, tool0;",
                     "    ENDIF"))
    assert tp.line.tolist() == [5, 6, 8, 11]
    np.testing.assert_array_equal(tp.position, [[100, 200, 300], [110, 200, 300], [120, 200, 300], [100, 200, 300]])


def test_local_record_strings_with_quotes_and_mod():
    """LOCAL RECORD ... ENDRECORD (RAPID overview, 'Data types': record); a quote inside a
    string is written "" (data type string); MOD and DIV after a parenthesis."""
    data = "\n".join([
        "MODULE M", "  LOCAL RECORD cam_rec", "    num exposure;", "    bool present;", "  ENDRECORD",
        "  PROC main()", "    Write f, \"{\"\"seqno\"\": \" + NumToStr(n,0)\\NoNewLine;",
        "    k:=((kmax-1) MOD 128)+1;", "    k:=(k+1) DIV 2;", "  ENDPROC", "ENDMODULE", ""]).encode()
    assert len(read(data)) == 0


def test_a_statement_that_never_ends_names_its_line():
    with pytest.raises(ParseError) as err:
        parse_program("m.mod", "rapid", module("    IF a > 3 AND", "      b < 2"))
    assert err.value.line == 4  # where the statement starts


# ------------------------------------------------------------------ semantics: where the robot goes
# p1 = (100, 200, 300) mm, orientation [1,0,0,0] (identity) unless a test says otherwise.

WOBJ1 = "  PERS wobjdata wobj1 := [FALSE,TRUE,\"\",[[500,0,0],[1,0,0,0]],[[0,0,100],[1,0,0,0]]];"


def test_trap_routine_moves_are_read():
    """A TRAP routine runs when its interrupt comes (RAPID overview, 'Interrupts'); its moves
    are the program's moves like any routine's: Offs(p1, 0, 0, 50) = (100, 200, 350)
    (function Offs: 'a displacement in the object coordinate system')."""
    data = "\n".join(["MODULE M", f"  CONST robtarget p1 := {P1};", "  VAR intnum int1;", "  PROC main()",
                      "    CONNECT int1 WITH lift;", "    ISignalDI di1, 1, int1;", "    MoveL p1, v100, fine, tool0;", "  ENDPROC",
                      "  TRAP lift", "    MoveL Offs(p1, 0, 0, 50), v100, fine, tool0;", "  ENDTRAP", "ENDMODULE", ""]).encode()
    tp = read(data)
    assert tp.line.tolist() == [7, 10] and tp.resolved.all()
    np.testing.assert_array_equal(tp.position, [[100, 200, 300], [100, 200, 350]])


def test_test_case_and_while_bodies_are_listed_once_and_a_for_once_per_pass():
    """TEST/CASE, WHILE (instructions TEST, WHILE): a constant target in a body is at the same
    place on every pass; with a count not known at post time (n is not set) it is read once,
    where it is written, and resolved. FOR i FROM 1 TO 3 (instruction FOR) runs its body 3
    times: one row per executed move, all at line 15."""
    tp = read(module("    TEST n", "    CASE 1, 2:", "      MoveL Offs(p1, 10, 0, 0), v100, z1, tool0;", "    DEFAULT:",
                     "      MoveL Offs(p1, 20, 0, 0), v100, z1, tool0;", "    ENDTEST",
                     "    WHILE n < 3 DO", "      MoveL p1, v100, z1, tool0;", "      n := n + 1;", "    ENDWHILE",
                     "    FOR i FROM 1 TO 3 DO", "      MoveJ Offs(p1, 0, 30, 0), v100, z1, tool0;", "    ENDFOR"))
    assert tp.line.tolist() == [6, 8, 11, 15, 15, 15] and tp.resolved.all()
    np.testing.assert_array_equal(tp.position, [[110, 200, 300], [120, 200, 300], [100, 200, 300]] + [[100, 230, 300]] * 3)
    assert tp.kind.tolist() == [Kind.LINEAR, Kind.LINEAR, Kind.LINEAR] + [Kind.JOINT] * 3


def test_robtarget_arrays_by_literal_index_and_loops_over_them():
    """An array element path{2} is the second element (RAPID overview, 'Arrays': indices start
    at 1). FOR k FROM 1 TO 2 runs MoveL path{k} with k = 1, then 2 (instruction FOR); with an
    index the program text cannot give (FOR k FROM 1 TO n) it is listed once, unresolved."""
    path = f"  CONST robtarget path{{2}} := [{P1},\n    [[400,500,600],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];"
    tp = read(module("    MoveL path{2}, v100, z1, tool0;", "    MoveL Offs(path{1}, 0, 0, 5), v100, z1, tool0;",
                     "    FOR k FROM 1 TO 2 DO", "      MoveL path{k}, v100, z1, tool0;", "    ENDFOR",
                     "    FOR k FROM 1 TO n DO", "      MoveL path{k}, v100, z1, tool0;", "    ENDFOR", data=(path,)))
    np.testing.assert_array_equal(tp.position[:4], [[400, 500, 600], [100, 200, 305], [100, 200, 300], [400, 500, 600]])
    assert tp.line.tolist() == [6, 7, 9, 9, 12] and tp.resolved.tolist() == [True, True, True, True, False]
    assert any("path{k}" in n for n in tp.notes) and any("FOR count is not known" in n for n in tp.notes)


def test_offs_and_reltool_nested_in_arguments():
    """RelTool(p, dx, dy, dz): a displacement in the tool frame of p (function RelTool); Offs:
    in the object frame (function Offs). With q = [0,0,1,0] (180 deg about y: x -> -x, z -> -z):
    RelTool(Offs(p, 10, 0, 0), 0, 0, 50) = (110, 200, 300) + R (0, 0, 50) = (110, 200, 250);
    Offs(RelTool(p, 0, 0, 50), 10, 0, 0) = (100, 200, 250) + (10, 0, 0) = (110, 200, 250)."""
    flipped = "  CONST robtarget pf := [[100,200,300],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];"
    tp = read(module("    MoveL RelTool(Offs(pf, 10, 0, 0), 0, 0, 50), v100, z1, tool0;",
                     "    MoveL Offs(RelTool(pf, 0, 0, 50), 10, 0, 0), v100, z1, tool0;",
                     "    MoveL RelTool(pf, 0, 0, 0 \\Rz:=90), v100, z1, tool0;", data=(flipped,)))
    np.testing.assert_allclose(tp.position, [[110, 200, 250], [110, 200, 250], [100, 200, 300]], atol=1e-9)
    assert tp.resolved.all()


def test_work_object_user_and_object_frames():
    """A target in a work object is in the object frame, which is in the user frame
    (data type wobjdata: uframe, oframe): base = uframe * oframe * p = p + (500, 0, 100)."""
    tp = read(module("    MoveL p1, v100, z1, tool0\\WObj:=wobj1;", "    MoveL Offs(p1, 0, 0, 10), v100, z1, tool0\\WObj:=wobj1;", data=(WOBJ1,)))
    np.testing.assert_allclose(tp.base_positions(), [[600, 200, 400], [600, 200, 410]])


def test_moveldo_searchl_triggl_read_their_target_speed_and_zone():
    """MoveLDO ToPoint Speed Zone Tool Signal Value; SearchL [\\Stop] Signal SearchPoint ToPoint
    Speed Tool (no zone); TriggL ToPoint Speed Trigg_1 Zone Tool (instructions MoveLDO, SearchL,
    TriggL, 'Syntax'). SearchL writes where the signal came into its search point, so a later
    move to that point is not resolved."""
    sp = f"  VAR robtarget sp := {P1};"
    tp = read(module("    MoveLDO Offs(p1, 1, 0, 0), v100, z5, tool0, do1, 1;",
                     "    SearchL \\Stop, di1, sp, Offs(p1, 0, 0, -40), v20, tool0;",
                     "    TriggL Offs(p1, 2, 0, 0), v500, trigg1, z50, tool0;",
                     "    TriggC Offs(p1, 3, 0, 0), Offs(p1, 4, 0, 0), v300, trigg1, z20, tool0;",
                     "    MoveL sp, v100, fine, tool0;", data=(sp,)))
    np.testing.assert_array_equal(tp.position, [[101, 200, 300], [100, 200, 260], [102, 200, 300], [103, 200, 300], [104, 200, 300], [100, 200, 300]])
    assert tp.kind.tolist() == [Kind.LINEAR, Kind.LINEAR, Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END, Kind.LINEAR]
    np.testing.assert_array_equal(tp.speed, [100, 20, 500, 300, 300, 100])
    np.testing.assert_array_equal(tp.zone[[0, 2, 3]], [5, 50, 20])
    assert tp.resolved.tolist() == [True, True, True, True, True, False]
    assert any(":6: sp is written by Searchl" in n for n in tp.notes)


def test_a_work_object_changed_at_run_time_is_followed_in_straight_line_code_only():
    """`wobj1.oframe.trans := [...]` moves every later target in wobj1 (data type wobjdata).
    A constant in straight-line code is followed as the controller runs it (issue 28): uframe
    (500, 0, 0), oframe (0, 0, 100) -> (0, 0, 250), so p1 (100, 200, 300) goes to (600, 200, 400)
    before and (600, 200, 550) after; a target in another frame is untouched. Inside an IF the
    frame is not known: the targets in wobj1 are not resolved (never the declared value)."""
    tp = read(module("    MoveL p1, v100, z1, tool0\\WObj:=wobj1;", "    wobj1.oframe.trans := [0, 0, 250];",
                     "    MoveL p1, v100, z1, tool0\\WObj:=wobj1;", "    MoveL p1, v100, z1, tool0;", data=(WOBJ1,)))
    assert tp.resolved.all()
    np.testing.assert_allclose(tp.base_positions(), [[600, 200, 400], [600, 200, 550], [100, 200, 300]], atol=1e-9)
    tp = read(module("    MoveL p1, v100, z1, tool0\\WObj:=wobj1;", "    IF DInput(di1) = 1 wobj1.oframe.trans := [0, 0, 250];",
                     "    MoveL p1, v100, z1, tool0\\WObj:=wobj1;", "    MoveL p1, v100, z1, tool0;", data=(WOBJ1,)))
    assert tp.resolved.tolist() == [False, False, True]
    assert not tp.placed()[:2].any()
    assert any(n.startswith("m.mod:6: wobj1 is assigned") for n in tp.notes)


def test_a_robtarget_changed_at_run_time_or_by_a_procedure():
    """`p1.trans.x := ...` and a PROC with an INOUT robtarget parameter change p1 (RAPID
    overview, 'Routines': INOUT arguments are written back): moves to p1 are not resolved;
    p2 is not touched and stays resolved."""
    p2 = "  CONST robtarget p2 := [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];"
    tp = read(module("    MoveL p1, v100, z1, tool0;", "    p1.trans.x := p1.trans.x + 300;", "    MoveL p2, v100, z1, tool0;", data=(p2,)))
    assert tp.resolved.tolist() == [False, True]
    data = "\n".join(["MODULE M", f"  VAR robtarget p1 := {P1};", "  PROC main()", "    shift p1;", "    MoveL p1, v100, z1, tool0;",
                      "  ENDPROC", "  PROC shift(INOUT robtarget p)", "    p := Offs(p, 0, 0, 10);", "  ENDPROC", "ENDMODULE", ""]).encode()
    tp = read(data)
    assert tp.resolved.tolist() == [False]
    assert any("m.mod:4: p1 is passed to shift" in n for n in tp.notes)


def test_program_displacement_leaves_every_target_unresolved():
    """PDispOn/PDispSet displace every later target (instruction PDispOn)."""
    tp = read(module("    MoveL p1, v100, z1, tool0;", "    PDispSet [[0,0,100],[1,0,0,0]];", "    MoveL p1, v100, z1, tool0;"))
    assert not tp.resolved.any() and any("PDispSet" in n for n in tp.notes)


def test_an_unknown_motion_instruction_is_refused_with_its_line():
    with pytest.raises(ParseError) as err:
        parse_program("m.mod", "rapid", module("    MoveL p1, v100, z1, tool0;", "    MoveQ p1, v100, z1, tool0;"))
    assert (err.value.line, err.value.column) == (5, 5) and "MoveQ" in str(err.value)


def test_an_unknown_instruction_that_does_not_move_is_a_note_with_its_line():
    tp = read(module("    MoveL p1, v100, z1, tool0;", "    Hand_GripInward;", "    Hand_GripInward;", "    TPWrite \"ok\";"))
    assert len(tp) == 1 and [n for n in tp.notes if "Hand_GripInward" in n] == [
        "m.mod:5: Hand_GripInward is neither a PROC of this program nor a RAPID instruction postproc knows; read as not moving the robot (and 1 more calls)"]


def test_moveextj_moves_external_axes_with_no_tool():
    """MoveExtJ ToJointPos Speed Zone (instruction MoveExtJ): no tool argument; the external
    axes of the jointtarget are its target."""
    tp = read(module("    MoveExtJ [[9E9,9E9,9E9,9E9,9E9,9E9],[250,9E9,9E9,9E9,9E9,9E9]], v100, fine;"))
    assert tp.kind.tolist() == [Kind.ABSJ] and tp.ext[0, 0] == 250 and np.isnan(tp.ext[0, 1:]).all()
