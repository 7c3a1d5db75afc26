"""G-code control flow (postproc/dialects/gcode/flow.py): every executed motion is one IR row.

Expected positions are written by hand from LinuxCNC's G-code manual, "O Codes"
(https://linuxcnc.org/docs/html/gcode/o-code.html) and "Numbered/Named Parameters"
(https://linuxcnc.org/docs/html/gcode/overview.html#gcode:parameters); the rule each case
relies on is quoted next to it. The real programs (daisy, flowsnake, offsets, ...) are judged
against rs274 in test_real_corpus.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.dialects.gcode import flow
from postproc.errors import ParseError, SharedNumberError
from postproc.programs import emit_texts, parse_program


def _read(tmp_path: Path, text: str, name: str = "p.ngc"):
    path = tmp_path / name
    path.write_bytes(text.encode("latin-1"))
    tp = parse_program(path)
    assert emit_texts(tp, tp)[0].encode("latin-1") == path.read_bytes()  # round trip stays exact
    return tp


def test_sub_with_arguments_locals_globals_and_return_value(tmp_path):
    # "O Codes / Subroutines": call arguments are #1, #2, ... of the sub; named parameters
    # without a leading underscore are local to the sub; `#<_name>` is global; `return [e]`
    # sets #<_value>. After the call the caller's #1 is restored.
    tp = _read(tmp_path, "G21 G90\n#1 = 7\n#<x> = 100\no<move> sub\n  #<x> = [#1 * 2]\n  #<_last> = #<x>\n  G1 X#<x> Y#2 Z0 F100\n"
                         "  o<move> return [#2 + 1]\no<move> endsub\no<move> call [1] [2]\nG1 X#1 Y#<_value>\nG1 X#<x> Y#<_last>\n"
                         "o<move> call [3]\nM2\n")
    # call 1: X2 Y2; back: X#1 (caller's 7) Y#<_value> (3); X#<x> (caller's 100) Y#<_last> (2);
    # call 2: #2 not given -> 0: X6 Y0
    assert np.allclose(tp.position[:, :2], [[2, 2], [7, 3], [100, 2], [6, 0]])
    assert tp.line.tolist() == [7, 11, 12, 7]
    assert tp.resolved.all()
    assert tp.spans[0, 1, 1] == tp.spans[3, 1, 1]  # both calls executed the same text: shared spans


def test_recursion_with_a_known_depth(tmp_path):
    # A sub may call itself ("O Codes": calls nest); each call has its own #1.
    tp = _read(tmp_path, "o100 sub\n  G1 X#1 F10\n  o101 if [#1 GT 1]\n    o100 call [#1 - 1]\n  o101 endif\n  G0 Y#1\no100 endsub\n"
                         "o100 call [3]\nM2\n")
    assert tp.position[:, 0].tolist() == [3, 2, 1, 1, 1, 1]
    assert tp.position[:, 1][3:].tolist() == [1, 2, 3]


def test_if_elseif_else(tmp_path):
    # "Conditional": the first true branch runs, else the else branch.
    text = "#1 = {v}\no1 if [#1 LT 0]\nG0 X-1\no1 elseif [#1 EQ 0]\nG0 X0.5\no1 elseif [#1 LT 10]\nG0 X2\no1 else\nG0 X3\no1 endif\nM2\n"
    xs = [float(_read(tmp_path, text.format(v=v)).position[0, 0]) for v in (-5, 0, 5, 50)]
    assert xs == [-1, 0.5, 2, 3]


def test_while_do_while_and_repeat(tmp_path):
    # "Looping": while tests before the body, do ... while after it (the body runs at least
    # once), repeat [n] runs the body n times.
    tp = _read(tmp_path, "G0 Z0\n#1 = 0\no1 while [#1 LT 3]\n#1 = [#1 + 1]\nG1 X#1 F100\no1 endwhile\n"
                         "#2 = 10\no2 do\nG1 Y#2\n#2 = [#2 + 1]\no2 while [#2 LT 5]\n"
                         "o3 repeat [2]\nG91 G1 Z1\no3 endrepeat\nM2\n")
    assert tp.position[1:4, 0].tolist() == [1, 2, 3]
    assert tp.position[4, 1] == 10  # do-while body once although the condition is false
    assert tp.position[5:, 2].tolist() == [1, 2]
    assert tp.relative[5:].all() and tp.spans[5, 2, 1] == tp.spans[6, 2, 1]


def test_nested_loops_with_break_and_continue(tmp_path):
    # "break" leaves the named loop, "continue" starts its next pass.
    tp = _read(tmp_path, "#1 = 0\no1 while [#1 LT 4]\n  #1 = [#1 + 1]\n  o2 if [#1 EQ 2]\n    o1 continue\n  o2 endif\n"
                         "  #2 = 0\n  o3 do\n    #2 = [#2 + 1]\n    o4 if [#2 GT 2]\n      o3 break\n    o4 endif\n    G1 X#1 Y#2 F9\n"
                         "  o3 while [1]\n  o5 if [#1 EQ 3]\n    o1 break\n  o5 endif\no1 endwhile\nG0 Z5\nM2\n")
    assert tp.position[:-1, :2].tolist() == [[1, 1], [1, 2], [3, 1], [3, 2]]
    assert tp.position[-1].tolist() == [3, 2, 5]


def test_fanuc_m98_calls_o_number_until_m99(tmp_path):
    # Fanuc / LinuxCNC M98 P<n> L<count>: O<n> ... M99 runs <count> times; L0 runs it not at all;
    # the parameters are the caller's (no new scope).
    tp = _read(tmp_path, "#1 = 0\nM98 P1 L3\nM98 P1 L0\nG0 Y1\nM30\nO1\n#1 = [#1 + 1]\nG0 X#1\nM99\n")
    assert tp.position[:, 0].tolist() == [1, 2, 3, 3]
    assert tp.position[-1, 1] == 1


def test_a_sub_never_called_executes_nothing(tmp_path):
    tp = _read(tmp_path, "o<simp> sub\ng0x0y0z1\no<simp> endsub\nG0 X5\nM2\nG0 X9\n")
    assert tp.position[:, 0].tolist() == [5]  # and nothing after M2 either


def test_unknown_parameters_flag_motion_not_the_file(tmp_path):
    # `#<_hal[...]>` (HAL) and an unset system parameter such as #5220 are not known at post
    # time: the motion that reads them is flagged, the others are exact.
    tp = _read(tmp_path, "F#<_hal[plasmac.cut-feed-rate]>\nG1 X1 Y0 Z0\nG1 X#5221 Y2\nM3 $0 S1\nG1 Y4 F50\nG1 X3\nM2\n")
    # lines 2, 3 move at the unknown feed; line 5 keeps the unknown X of line 3; line 6 is exact
    assert tp.resolved.tolist() == [False, False, False, True]
    assert np.isnan(tp.speed[:2]).all() and tp.speed[2] == 50
    assert np.isnan(tp.position[1:3, 0]).all() and tp.position[3].tolist() == [3, 4, 0]  # never the X before it


def test_unknown_condition_lists_each_target_once_flagged(tmp_path):
    tp = _read(tmp_path, "G0 X1 Y0 Z0\no1 while [#<_hal[x]> GT 0]\nG1 X2 F10\no2 if [#5220 EQ 1]\nG1 Y1\no2 else\nG1 Y2\no2 endif\no1 endwhile\nG0 Z9\nM2\n")
    assert tp.line.tolist() == [1, 3, 5, 7, 10]
    assert tp.resolved.tolist() == [True, False, False, False, False]
    assert any("line 2" in n and "cannot be decided" in n for n in tp.notes)


def test_endless_loop_is_refused_with_its_line(tmp_path, monkeypatch):
    monkeypatch.setattr(flow, "MAX_EXECUTED_BLOCKS", 10_000)
    path = tmp_path / "forever.ngc"
    path.write_text("G0 X0\no1 while [1]\nG1 X1 F10\nG1 X0\no1 endwhile\nM2\n")
    with pytest.raises(ParseError, match="blocks executed") as exc:
        parse_program(path)
    assert exc.value.path == str(path) and exc.value.line in (2, 3, 4, 5)


def test_endless_recursion_is_refused(tmp_path):
    path = tmp_path / "deep.ngc"
    path.write_text("o1 sub\nG0 X1\no1 call\no1 endsub\no1 call\nM2\n")
    with pytest.raises(ParseError, match="nested deeper") as exc:
        parse_program(path)
    assert exc.value.line == 3 and exc.value.column == 1


def test_unclosed_and_mismatched_blocks_name_the_line(tmp_path):
    path = tmp_path / "bad.ngc"
    path.write_text("o1 while [1]\nG0 X1\no2 endwhile\nM2\n")
    with pytest.raises(ParseError, match="does not close") as exc:
        parse_program(path)
    assert (exc.value.line, exc.value.column) == (3, 1)


def test_call_of_a_sub_in_another_file(tmp_path):
    # LinuxCNC looks for o<name> in <name>.ngc on its subroutine path; next to the program here.
    (tmp_path / "side.ngc").write_text("o<side> sub\nG1 X#1 F10\no<side> endsub\n")
    tp = _read(tmp_path, "G0 X0\no<side> call [4]\no<side> call [5]\nM2\n")
    assert tp.position[:, 0].tolist() == [0, 4, 5]
    assert tp.file.tolist() == [0, 1, 1] and [Path(s.path).name for s in tp.sources] == ["p.ngc", "side.ngc"]
    texts = emit_texts(tp, tp)
    assert texts[1] == (tmp_path / "side.ngc").read_text()
    path = tmp_path / "missing.ngc"
    path.write_text("G0 X0\n  o<nowhere> call [1]\nM2\n")
    with pytest.raises(ParseError, match="nowhere.ngc") as exc:
        parse_program(path)
    assert (exc.value.line, exc.value.column) == (2, 3)


# ------------------------------------------------------------------ writing back

LOOP = "G21 G90\n#1 = 0\no10 repeat [3]\n#1 = [#1 + 1]\nG1 X#1 Y5 F100\nG0 Z1\no10 endrepeat\nM2\n"


def test_one_text_number_executed_with_different_corrections_is_refused(tmp_path):
    tp = _read(tmp_path, LOOP)
    new = tp.position.copy()
    new[tp.line == 5, 1] += [0.1, 0.2, 0.3]
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(new))
    assert (exc.value.line, exc.value.column) == (5, 9) and str(exc.value).startswith(f"{tmp_path / 'p.ngc'}:5:9: ")
    assert "loop body" in str(exc.value)


def test_one_added_word_with_different_values_is_refused(tmp_path):
    # G0 Z1 has no Y: a correction that differs per pass would add two different Y words.
    tp = _read(tmp_path, LOOP)
    new = tp.position.copy()
    new[tp.line == 6, 1] += [0.1, 0.2, 0.3]
    with pytest.raises(SharedNumberError) as exc:
        emit_texts(tp, tp.with_positions(new))
    assert exc.value.line == 6


def test_the_same_correction_for_every_execution_is_written_once(tmp_path):
    tp = _read(tmp_path, LOOP)
    new = tp.position.copy()
    new[:, 1] += 0.25
    text = emit_texts(tp, tp.with_positions(new))[0]
    assert "G1 X#1 Y5.25 F100\n" in text and text.count("Y") == 1
