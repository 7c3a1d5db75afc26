"""KRL statements the real corpus needed (issue 12), in our own words: each read and written back
byte-identically, or refused with its line (the corpus files themselves: test_real_corpus.py)."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

DAT = """&ACCESS RVP
DEFDAT cell PUBLIC
  GLOBAL CONST INT STATE_COUNT = 3
  GLOBAL ENUM CellState IDLE, BUSY, DONE
  GLOBAL STRUC AxisTuple INT number, CHAR name[8]
  DECL CellState state = #IDLE
  DECL CONST AxisTuple AXES[2]
  AXES[1] = {number 1, name[] "A1"}
  DECL FRISTATE retVal
  decl eki_status eki_ret
  DECL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0}
ENDDAT
"""
SRC = """DEF cell( )
  DECL AXIS jpos
  DECL RSIERR err
  jpos = {AXIS: A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}
  PTP jpos
  $BASE = {FRAME: X 10, Y 20, Z 30, A 0, B 0, C 0}
  LIN XP1
  CIRC {X 110, Y 10, Z 500}, {X 120, Y 0, Z 500, A 0, B 90, C 0}, CA 90 C_DIS
  CONFIRM 0
END

GLOBAL DEFFCT CHAR [32] AxisName(number: IN)
  DECL INT number
Again:
  IF number < 1 THEN
    number = number + 1
    GOTO Again
  ENDIF
  RETURN "A1"
ENDFCT
"""


def test_declarations_typed_aggregates_and_statements_round_trip(tmp_path):
    (tmp_path / "cell.src").write_bytes(SRC.replace("\n", "\r\n").encode("latin-1"))
    (tmp_path / "cell.dat").write_bytes(DAT.replace("\n", "\r\n").encode("latin-1"))
    tp = parse_program(tmp_path / "cell.src")
    assert [t.encode("latin-1") for t in emit_texts(tp, tp)] == [(tmp_path / n).read_bytes() for n in ("cell.src", "cell.dat")]
    np.testing.assert_allclose(tp.joints[0], [0, -90, 90, 0, 0, 0])  # the typed aggregate jpos = {AXIS: ...}
    np.testing.assert_allclose(tp.base_positions()[1], [110, 20, 530])  # $BASE = {FRAME: X 10, Y 20, Z 30}
    assert tp.frame_names[tp.frame[1]] == "{FRAME: X 10, Y 20, Z 30, A 0, B 0, C 0}"


def test_a_data_list_on_its_own_is_sniffed_as_krl(tmp_path):
    (tmp_path / "cell.dat").write_bytes(DAT.encode("latin-1"))
    tp = parse_program(tmp_path / "cell.dat")  # no dialect given: DEFDAT ... PUBLIC
    assert tp.dialect == "krl" and len(tp) == 0
    assert emit_texts(tp, tp)[0] == DAT


@pytest.mark.parametrize("line, column", [
    ("  CIRC {X 110, Y 10, Z 500}, {X 120, Y 0, Z 500} CA 90", 50),  # KSS 8: ", CA angle" after the end point
    ("  MYTYPE thing", 10),  # a user type needs DECL
    ("  DECL CONST", 8),
])
def test_what_the_controller_refuses_is_refused_with_its_line(tmp_path, line, column):
    (tmp_path / "bad.src").write_text(f"DEF bad( )\n{line}\nEND\n")
    with pytest.raises(ParseError) as err:
        parse_program(tmp_path / "bad.src")
    assert (err.value.line, err.value.column) == (2, column), str(err.value)
