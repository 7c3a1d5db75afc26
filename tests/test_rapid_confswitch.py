"""RAPID ConfL/ConfJ by execution order (issue 13): the switch in force at a motion is the
one that last ran, following the calls from main, not the module's text order; a motion
reached with the switch both on and off is refused with its line."""

from __future__ import annotations

import pytest

from postproc.errors import InputError
from postproc.programs import dialects, parse_program

T = "[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _applies(tmp_path, text, name="p.mod"):
    path = tmp_path / name
    path.write_text(text)
    tp = parse_program(path)
    return dialects.of(tp).controller.conf_applies(tp).tolist(), tp


@pytest.mark.parametrize("text, applies", [
    # Text order: main (ConfL\Off at its end), then approach: text order would say Off for
    # approach's MoveL; but main calls approach before switching: On.
    pytest.param("MODULE P\n  PROC main()\n    approach;\n    ConfL\\Off;\n    cut;\n  ENDPROC\n"
                 f"  PROC approach()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\n"
                 f"  PROC cut()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n",
                 [True, False], id="written_after_confl_off_but_called_before_it_runs_with_confl_on"),
    pytest.param("MODULE P\n"
                 f"  PROC cut()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\n"
                 f"  PROC main()\n    ConfL\\Off;\n    cut;\n    ConfL\\On;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n",
                 [False, True], id="written_before_the_switch_but_called_after_it_runs_with_confl_off"),
    pytest.param("MODULE P\n  PROC main()\n    cut;\n    ConfL\\Off;\n    cut;\n  ENDPROC\n"
                 f"  PROC cut()\n    ConfL\\On;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n",
                 [True], id="that_sets_the_switch_itself_is_not_ambiguous"),
])
def test_a_routine_runs_with_the_switch_in_force_where_it_is_called(tmp_path, text, applies):
    assert _applies(tmp_path, text)[0] == applies


def test_calls_across_modules_of_a_program_file(tmp_path):
    (tmp_path / "Main.mod").write_text("MODULE Main\n  PROC main()\n    ConfJ\\Off;\n    Work;\n  ENDPROC\nENDMODULE\n")
    (tmp_path / "Work.mod").write_text(f"MODULE Work\n  PROC Work()\n    MoveJ {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    (tmp_path / "cell.pgf").write_text('<?xml version="1.0" encoding="ISO-8859-1" ?>\n<Program>\n  <Module>Main.mod</Module>\n  <Module>Work.mod</Module>\n</Program>\n')
    tp = parse_program(tmp_path / "cell.pgf")
    assert dialects.of(tp).controller.conf_applies(tp).tolist() == [False]


def test_a_routine_called_with_both_states_is_refused_with_its_line(tmp_path):
    text = ("MODULE P\n  PROC main()\n    cut;\n    ConfL\\Off;\n    cut;\n  ENDPROC\n"
            f"  PROC cut()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    with pytest.raises(InputError, match=r"p.mod, line 8: this motion runs with ConfL/ConfJ both on and off .*main -> cut \(line 5\)"):
        _applies(tmp_path, text)


def test_without_main_the_module_text_order_is_kept(tmp_path):
    text = ("MODULE Lib\n"
            f"  PROC a()\n    ConfL\\Off;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\n"
            f"  PROC b()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    applies, _ = _applies(tmp_path, text)
    assert applies == [False, False]


@pytest.mark.parametrize("switch_block, where", [
    ("    IF di1 = 1 THEN\n      ConfL\\Off;\n    ENDIF\n", "p.mod:4:7"),
    ("    IF di1 = 1 ConfL\\Off;\n", "p.mod:3:16"),
    ("    WHILE n < 3 DO\n      ConfL\\Off;\n      n := n + 1;\n    ENDWHILE\n", "p.mod:4:7"),
])
def test_a_switch_that_runs_only_under_a_condition_is_refused_with_its_column(tmp_path, switch_block, where):
    """RAPID reference, ConfL: the switch holds from where it runs. Under an IF (or the
    statement of a one-line IF) or in a loop it may or may not run, so the posture rule of
    the MoveL after it is a run-time matter: refused, never taken as written."""
    text = f"MODULE P\n  PROC main()\n{switch_block}    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"
    with pytest.raises(InputError, match=where + r": ConfL\\Off runs only under a condition"):
        _applies(tmp_path, text)
