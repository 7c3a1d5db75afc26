"""Fanuc TP jumps the text fixes (R-30iB Operator's Manual, "Branching instructions",
"Register instructions"): a counted loop (R[] set, stepped, IF R[] < k,JMP LBL[]) and a
forward JMP are followed in the order the controller runs the statements; anything else is
read in text order with a note, as before. The expected targets are written by hand."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from postproc.programs import emit_files, parse_program
from postproc.programs.dialects import get

POS = "".join(
    f"P[{n}]{{\n   GP1:\n\tUF : 0, UT : 0,\t\tCONFIG : 'N U T, 0, 0, 0',\n\tX = {x:9.3f}  mm,\tY =     0.000  mm,\tZ =   300.000  mm,\n"
    f"\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg\n}};\n" for n, x in ((1, 900.0), (2, 950.0), (3, 1000.0), (4, 1050.0)))


def listing(*body: str) -> bytes:
    mn = "".join(f"{k + 1:4d}:{text} ;\n" for k, text in enumerate(body))
    return f"/PROG  LOOP\n/ATTR\n/MN\n{mn}/POS\n{POS}/END\n".encode()


def read(*body: str):
    return get("fanuc").parse("loop.ls", listing(*body))


def xs(tp) -> list[float]:
    return np.round(tp.position[:, 0], 3).tolist()


def test_a_counted_loop_runs_its_motions_once_per_pass():
    tp = read("J P[1] 100% FINE", "  R[1]=0", "  LBL[10]", "L P[2] 100mm/sec FINE", "L P[3] 100mm/sec FINE",
              "  R[1]=R[1]+1", "  IF R[1]<3,JMP LBL[10]", "L P[4] 100mm/sec FINE")
    assert xs(tp) == [900.0, 950.0, 1000.0, 950.0, 1000.0, 950.0, 1000.0, 1050.0]
    assert tp.line.tolist() == [4, 7, 8, 7, 8, 7, 8, 11]  # (/PROG, /ATTR, /MN are lines 1-3)
    assert any("16 statement(s) are read in the order they run (8 repeated by loops, 0 of the program never run)" in n for n in tp.notes)
    assert not any("in text order" in n for n in tp.notes)


def test_a_forward_jump_skips_what_never_runs():
    tp = read("J P[1] 100% FINE", "  JMP LBL[2]", "L P[2] 100mm/sec FINE", "  LBL[2]", "L P[3] 100mm/sec FINE")
    assert xs(tp) == [900.0, 1000.0]


def test_a_flow_the_text_does_not_fix_is_read_in_text_order():
    for unfixed in ("  IF DI[1]=ON,JMP LBL[2]", "  CALL OTHER", "  IF R[5]<3,JMP LBL[2]"):  # an input; a call; a register set outside
        tp = read("J P[1] 100% FINE", unfixed, "L P[2] 100mm/sec FINE", "  LBL[2]", "L P[3] 100mm/sec FINE")
        assert xs(tp) == [900.0, 950.0, 1000.0]
        assert any("in text order" in n for n in tp.notes), unfixed


def test_a_loop_that_never_ends_is_read_in_text_order():
    tp = read("  LBL[1]", "J P[1] 100% FINE", "  JMP LBL[1]")
    assert xs(tp) == [900.0] and any("in text order" in n for n in tp.notes)


def test_a_call_of_a_program_beside_it_runs_that_program_there(tmp_path):
    """CALL SUB with SUB.ls in the folder: SUB's motions (its own /POS) run at the CALL, twice
    in a counted loop; compensated numbers of SUB go to SUB's own file, beside the output."""
    (tmp_path / "SUB.ls").write_bytes(listing("L P[4] 100mm/sec FINE").replace(b"/PROG  LOOP", b"/PROG  SUB"))
    main = tmp_path / "MAIN.ls"
    main.write_bytes(listing("J P[1] 100% FINE", "  R[2]=0", "  LBL[1]", "  CALL SUB", "  R[2]=R[2]+1", "  IF R[2]<2,JMP LBL[1]", "L P[2] 100mm/sec FINE"))
    tp = parse_program(main)
    assert xs(tp) == [900.0, 1050.0, 1050.0, 950.0]
    assert [tp.sources[f].path for f in tp.file] == [str(main), str(tmp_path / "SUB.ls"), str(tmp_path / "SUB.ls"), str(main)]
    assert tp.line.tolist() == [4, 4, 4, 10] and tp.resolved.all()
    assert any("calls are fixed by its text" in n and "called: SUB.ls" in n for n in tp.notes)
    moved, values = tp.position.copy(), tp.values.copy()
    moved[1:3, 0] += 0.5  # both passes of SUB's P[4] moved alike: one number in SUB.ls
    values[1:3, 0] += 0.5
    files = emit_files(tp, replace(tp, position=moved, values=values), tmp_path / "out" / "MAIN.ls")
    assert set(files) == {tmp_path / "out" / "MAIN.ls", tmp_path / "out" / "SUB.ls"}
    assert "X =  1050.500  mm" in files[tmp_path / "out" / "SUB.ls"]


def test_a_call_of_a_program_not_in_the_folder_is_read_in_text_order(tmp_path):
    main = tmp_path / "MAIN.ls"
    main.write_bytes(listing("J P[1] 100% FINE", "  CALL ELSEWHERE", "L P[2] 100mm/sec FINE"))
    tp = parse_program(main)
    assert xs(tp) == [900.0, 950.0] and len(tp.sources) == 1 and any("in text order" in n for n in tp.notes)
