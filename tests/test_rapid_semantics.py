"""RAPID as the controller reads it: syntax seen in real modules, and what the moves mean.

Expected positions are written by hand from ABB's "Technical reference manual - RAPID
Instructions, Functions and Data types" (3HAC050917-001) and "RAPID overview"
(3HAC050947-001); each test names the section it follows.
"""

from __future__ import annotations

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.ir import Kind
from postproc.programs import emit_texts, parse_program

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
