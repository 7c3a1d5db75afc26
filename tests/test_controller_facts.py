"""The controllers read the facts a program states from the IR (``Toolpath.extras``, written
by each language's parser), never the program text (issue 27): a toolpath whose text is
blanked after parsing gets the same answers from its controller."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.programs import dialects, parse_program
from postproc.programs.ir import SourceDoc

T = "[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _blanked(tp):
    """``tp`` with every source's text replaced by spaces (same length): only the IR is left."""
    return replace(tp, sources=tuple(SourceDoc(d.path, " " * len(d.text), d.role) for d in tp.sources))


def _read(tmp_path, name, text):
    (tmp_path / name).write_text(text)
    tp = parse_program(tmp_path / name)
    return tp, dialects.of(tp).controller


def test_rapid_confl_and_confj_are_ir_columns_the_controller_reads(tmp_path):
    text = ("MODULE P\n  PROC main()\n    approach;\n    ConfL\\Off;\n    cut;\n    ConfJ\\Off;\n"
            f"    MoveJ {T}, v100, z1, tool0;\n  ENDPROC\n"
            f"  PROC approach()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\n"
            f"  PROC cut()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    tp, controller = _read(tmp_path, "p.mod", text)
    order = np.argsort(tp.line)  # rows in program (text) order: MoveJ (7), approach (10), cut (13)
    assert tp.extras["rapid.confl_off"][order].tolist() == [True, False, True]
    assert tp.extras["rapid.confj_off"][order].tolist() == [True, False, False]
    assert controller.conf_applies(tp)[order].tolist() == [False, True, False]
    assert controller.conf_applies(_blanked(tp)).tolist() == controller.conf_applies(tp).tolist()


def test_a_rapid_switch_under_a_condition_is_refused_from_the_ir(tmp_path):
    text = f"MODULE P\n  PROC main()\n    IF di1 = 1 ConfL\\Off;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"
    tp, controller = _read(tmp_path, "p.mod", text)  # reading it is fine: only the posture rule is refused
    assert "p.mod:3:16" in tp.extras["rapid.conf_refused"][0]
    with pytest.raises(InputError, match=r"p.mod:3:16: ConfL\\Off runs only under a condition"):
        controller.conf_applies(_blanked(tp))


def test_rapid_singarea_is_an_ir_column(tmp_path):
    text = f"MODULE P\n  PROC main()\n    ! SingArea \\Wrist;\n    SingArea \\LockAxis4;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"
    tp, controller = _read(tmp_path, "p.mod", text)
    assert tp.extras["rapid.singarea"].tolist() == [f"{tmp_path / 'p.mod'}:4: SingArea \\LockAxis4"]
    assert controller.inexact_interpolation(_blanked(tp)).startswith(f"{tmp_path / 'p.mod'}:4: SingArea \\LockAxis4: between targets")
    plain, _ = _read(tmp_path, "q.mod", text.replace("    SingArea \\LockAxis4;\n", ""))
    assert controller.inexact_interpolation(plain) is None


def test_krl_circular_angle_is_an_ir_column(tmp_path):
    text = ("DEF arcs( )\n  PTP {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}\n"
            "  CIRC {X 110, Y 10, Z 500}, {X 120, Y 0, Z 500, A 0, B 90, C 0}, CA 90\n"
            "  CIRC {X 130, Y 10, Z 500}, {X 140, Y 0, Z 500, A 0, B 90, C 0}\nEND\n")
    tp, controller = _read(tmp_path, "arcs.src", text)
    ends = tp.kind == 3  # Kind.CIRC_END
    assert tp.extras["krl.circular_angle"][ends].tolist() == [True, False]
    assert controller.arc_ends_at_target(_blanked(tp))[ends].tolist() == [False, True]


def test_sinumerik_continuous_path_mode_is_an_ir_column(tmp_path):
    tp, controller = _read(tmp_path, "p.mpf", "G54 G71\nG1 X1 Y2 Z3 F100\nG642\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(tp)).startswith(f"{tmp_path / 'p.mpf'}:3: continuous-path mode")
    plain, _ = _read(tmp_path, "q.mpf", "G54 G71\nG1 X1 Y2 Z3 F100\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(plain)) is None


def test_sinumerik_continuous_words_in_comments_or_other_words_do_not_count(tmp_path):
    text = "G54 G71 ; G64 here is a comment\nG1 X1 Y2 Z3 F100\nR1=1 ; COMPCAD too\nG1 X2\nG6420 X3\ncompcad\nG1 X4\nM30\n"
    tp, controller = _read(tmp_path, "c.mpf", text)
    assert tp.extras["sinumerik.continuous"][0] == f"{tmp_path / 'c.mpf'}:6"
    none, _ = _read(tmp_path, "d.mpf", "G54 G71 ; G642\nG1 X1 Y2 Z3 F100\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(none)) is None
