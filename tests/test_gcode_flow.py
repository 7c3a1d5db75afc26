"""G-code control flow (postproc/programs/dialects/gcode/flow.py): every executed motion is one IR row.

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

from postproc.errors import ParseError, SharedNumberError
from postproc.programs import emit_texts, parse_program
from postproc.programs.dialects.gcode import flow


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
    tp = _read(tmp_path, "#1 = 0\nM98 P1 L3\nM98 P1 L0\nG0 Y1\nM30\nO0001\n#1 = [#1 + 1]\nG0 X#1\nM99\n")
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
    path.write_text("#1 = 0\nG0 X0\no1 while [1]\n#1 = [#1 + 1]\nG1 X1 F10\nG1 X0\no1 endwhile\nM2\n")  # #1 grows: no state repeats
    with pytest.raises(ParseError, match="more than 10,000 blocks executed") as exc:
        parse_program(path)
    assert exc.value.path == str(path) and exc.value.line in (3, 4, 5, 6, 7)


@pytest.mark.parametrize("text, loop_lines", [
    ("G0 X0\no1 while [1]\nG1 X1 F10\nG1 X0\no1 endwhile\nM2\n", (2, 5)),
    ("#2 = 0\no1 while [#2 LT 3]\no2 repeat [2]\nG1 X1 F10\no2 endrepeat\no1 endwhile\nM2\n", (2, 6)),  # the #2 increment forgotten
    ("o5 sub\n#<_n> = 0\no5 endsub\no1 do\no5 call\nG1 X1 F10\no1 while [#<_n> LT 1]\nM2\n", (1, 7)),
])
def test_loop_back_in_the_same_state_is_refused_at_once(tmp_path, text, loop_lines):
    """No parameter, counter or call changes from one pass to the next: refused after
    ~CYCLE_CHECK_AFTER blocks, not after MAX_EXECUTED_BLOCKS (seconds and ~1 GB)."""
    path = tmp_path / "forever.ngc"
    path.write_text(text)
    with pytest.raises(ParseError, match="same parameters, counters and calls") as exc:
        parse_program(path)
    assert exc.value.path == str(path) and loop_lines[0] <= exc.value.line <= loop_lines[1]


def test_long_loop_whose_state_changes_is_run_to_its_end(tmp_path):
    path = tmp_path / "long.ngc"
    path.write_text("#1 = 0\no1 while [#1 LT 3000]\n#1 = [#1 + 1]\no2 repeat [1]\no2 endrepeat\no1 endwhile\nG1 X#1 F10\nM2\n")
    tp = parse_program(path)
    assert tp.position[:, 0].tolist() == [3000]


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


# ------------------------------------------------------------------ Siemens SINUMERIK 828D / 840D
# SINUMERIK 840D sl / 828D "Job Planning" programming manual (6FC5398-2BP40): DEF (an INT or
# REAL without an initial value is 0; REAL assigned to INT is rounded), IF/ELSE/ENDIF,
# WHILE/ENDWHILE, FOR var = a TO b / ENDFOR (body while var <= b, step 1), REPEAT/UNTIL,
# MSG (a message, no motion), PROC / EXTERN / call NAME(args) / RET; "Fundamentals"
# (6FC5398-1BP40): G70/G700 inch, G71/G710 metric; SUPA: this block in machine coordinates.

SIEMENS_SUB = "PROC SIDE(REAL _X, INT _N)\nDEF INT IDX\nFOR IDX = 1 TO _N\n  G1 SUPA X=_X Y=IDX F100\nENDFOR\nRET\n"


def test_siemens_variables_loops_and_branches(tmp_path):
    tp = _read(tmp_path, "G71 G90\nDEF INT CNT, KK=2\nDEF REAL RR\nMSG(\"start\")\nRR = 2.25\nCNT = RR * 2\nG0 X=CNT Y0 Z0\n"
                         "WHILE CNT > 3\n  CNT = CNT - 1\n  G1 X=CNT F100\nENDWHILE\nIF KK == 2\n  G0 Y1\nELSE\n  G0 Y2\nENDIF\n"
                         "REPEAT\n  KK = KK + 1\n  G0 Z=KK\nUNTIL KK >= 4\nG70\nG0 X1\nM30\n", "MAIN.MPF")
    # CNT = 4.5 rounded (INT) = 5: X5; while CNT > 3: X4, X3; KK == 2: Y1; repeat: Z3, Z4; G70: X1 inch
    assert tp.position.tolist() == [[5, 0, 0], [4, 0, 0], [3, 0, 0], [3, 1, 0], [3, 1, 3], [3, 1, 4], [25.4, 1, 4]]
    assert tp.resolved.all()


def test_siemens_subprogram_in_its_own_file(tmp_path):
    (tmp_path / "SIDE.SPF").write_text(SIEMENS_SUB)
    tp = _read(tmp_path, "EXTERN SIDE(REAL, INT)\nG71 G90 G0 SUPA X0 Y0 Z0\nSIDE(7, 2)\nSIDE(8, 0)\nG0 SUPA X9\nM30\n", "MAIN.MPF")
    assert tp.position[:, :2].tolist() == [[0, 0], [7, 1], [7, 2], [9, 2]]
    assert tp.file.tolist() == [0, 1, 1, 0] and tp.line.tolist() == [2, 4, 4, 5]
    assert tp.resolved.all() and (tp.frame_names[tp.frame[0]] == "machine")


def test_siemens_subprogram_alone_is_listed_once_and_flagged(tmp_path):
    tp = _read(tmp_path, SIEMENS_SUB, "SIDE.SPF")
    assert len(tp) == 1 and not tp.resolved.any()  # _N unknown: the FOR body once, flagged
    assert any("FOR" in n for n in tp.notes)


def _warmup(tmp_path: Path, program: str) -> Path:
    """A corpus Siemens program with WARMUP_CYCLE.SPF beside it under the name the controller uses."""
    from test_real_corpus import corpus_file

    prefix = "gcode/AlloyX-MFG_syil-X7-warmup-routines__"
    for name in (program, "WARMUP_CYCLE.SPF"):
        (tmp_path / name).write_bytes(corpus_file(prefix + name).read_bytes())
    return tmp_path / program


def test_siemens_daily_warmup_from_the_corpus(tmp_path):
    # DAILY.MPF (AlloyX-MFG/syil-X7-warmup-routines): G70 inch; G0 SUPA Z0, G0 SUPA X0 Y0; then
    # WARMUP_CYCLE(3600, 600) and (7200, 600): CYCLES = 600 / 15 = 40 passes of 13 SUPA moves;
    # then G0 SUPA Z0 and G0 SUPA X0 Y0.
    tp = parse_program(_warmup(tmp_path, "DAILY.MPF"))
    cycle = np.array([[0, 0, -4], [-5, 0, -4], [-5, -5, -4], [-5, -5, 0], [0, -5, 0], [0, 0, 0], [-5, -5, 0],
                      [-5, -5, -4], [0, 0, -4], [0, 0, 0], [0, -5, 0], [-5, 0, 0], [0, 0, 0]], float) * 25.4
    expected = np.vstack([[[np.nan, np.nan, 0], [0, 0, 0]], np.tile(cycle, (80, 1)), [[0, 0, 0], [0, 0, 0]]])
    assert len(tp) == 2 + 80 * 13 + 2
    np.testing.assert_allclose(tp.position, expected)
    assert tp.resolved[1:].all() and set(tp.file.tolist()) == {0, 1}
    texts = emit_texts(tp, tp)
    assert [t.encode("latin-1") for t in texts] == [Path(d.path).read_bytes() for d in tp.sources]


def test_siemens_run_in_without_its_subprogram_is_flagged_not_refused(tmp_path):
    from test_real_corpus import corpus_file

    tp = _read(tmp_path, corpus_file("gcode/AlloyX-MFG_syil-X7-warmup-routines__FIRST_SPINDLE_RUN_IN.MPF").read_text(encoding="latin-1"), "RUN_IN.MPF")
    assert len(tp) == 4 and tp.resolved.tolist() == [False, True, False, False]
    assert any("WARMUP_CYCLE" in n for n in tp.notes)


def test_a_lines_parameter_settings_take_effect_after_the_line(tmp_path):
    # LinuxCNC "Parameters": all parameter values on a line are read before any is set.
    tp = _read(tmp_path, "#1 = 1\n#1 = 5 #2 = #1\nG0 X#1 Y#2 Z0\n#3 = #<_hal[x]>\n#3 = 7 G0 X#3\n#3 = #<_hal[x]>\nG0 Y#3\nM2\n")
    assert tp.position[0].tolist() == [5, 1, 0]
    assert np.isnan(tp.position[1, 0]) and np.isnan(tp.position[2, 1])  # never the old #3 (7)


def test_a_tilted_plane_set_in_a_loop_is_named_by_its_line(tmp_path):
    tp = _read(tmp_path, "G0 X0 Y0 Z0\no1 repeat [2]\nG68.2 X0 Y0 Z0 I0 J0 K90\nG1 X1 F100\nG69\no1 endrepeat\nM2\n")
    assert len(tp) == 3 and {tp.frame_names[f] for f in tp.frame[1:]} == {"G54+G68.2@line3"}
    np.testing.assert_allclose(tp.base_positions()[1:], [[0, 1, 0]] * 2, atol=1e-12)  # X1 turned 90 degrees about Z
