"""URScript (.script): reading, spans, the controller's rules, writing back.

No open URScript interpreter exists to judge the reading: every expected position below is
worked out by hand from the URScript manual's rules (Universal Robots, "The URScript
Programming Language", e-Series 5.x): poses p[x, y, z, rx, ry, rz] in metres with a rotation
vector in radians ("Data types: pose"); joint lists in radians ("movej"); pose_trans(F, X)
= F . X ("pose_trans"); pose_add: P1 + P2, R1 . R2 ("pose_add"); comments from # to the end
of the line and strings in quotes are not code ("Syntax").
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import dialects, emit_texts, parse_program
from postproc.programs.ir import Kind

CELL = Path(__file__).parent / "corpus" / "urscript" / "cell.script"


@pytest.fixture(scope="module")
def cell():
    return parse_program(CELL)


def test_the_cell_program_is_read_by_the_manuals_rules(cell):
    assert cell.dialect == "urscript" and cell.orientation_kind == "rotvec"
    assert cell.line.tolist() == [7, 8, 10, 12, 13, 14, 14, 15, 16]  # the comment's and the string's movel are no motion
    assert cell.kind.tolist() == [Kind.ABSJ, Kind.LINEAR, Kind.LINEAR, Kind.LINEAR, Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END, Kind.LINEAR, Kind.JOINT]
    # Joint list in radians -> degrees.
    np.testing.assert_allclose(cell.joints[0], np.degrees([0, -1.5708, 1.5708, -1.5708, -1.5708, 0]))
    tcp = cell.base_positions()
    # p[0.4, -0.2, 0.3, ...] m; the two-line movel; pose_trans(plane, p[0.2, 0.1, 0.3]) with plane
    # 0.1 m along x turned 90 deg about z: (0.1 - 0.1, 0 + 0.2, 0.3); pose_add: (0.41, 0.02, 0.23).
    expected = [[400, -200, 300], [500, -200, 300], [0, 200, 300], [410, 20, 230], [450, 50, 200], [500, 0, 200], [500, -100, 200], [400, -100, 250]]
    np.testing.assert_allclose(tcp[1:], expected, atol=1e-3)  # 1.5708 is pi/2 within 4e-6 rad: < 1 um here
    # The TCP set_tcp gives: 0.15 m along the flange's z.
    np.testing.assert_allclose(cell.tools[cell.tool[1]][:3, 3], [0, 0, 150])
    assert cell.frame_names[cell.frame[3]] == "plane" and cell.target_name[0] == "home"
    # The rotation vector (0, 3.1416, 0) is a half turn about y: the tool points down.
    np.testing.assert_allclose(cell.base_poses()[1][:3, 2], [0, 0, -1], atol=1e-4)
    assert cell.speed[1] == 0.25 and cell.speed[2] == 0.1 and cell.zone[2] == 2.0
    np.testing.assert_allclose(cell.extras["urscript.blend_m"], [0, 0, 0.002, 0, 0, 0, 0, 0.001, 0])
    assert cell.extras["urscript.process_move"].tolist() == [False] * 7 + [True, False]
    assert cell.placed().all()


def test_every_number_has_its_span_and_the_unchanged_program_is_the_same_bytes(cell):
    text = cell.sources[0].text
    spans = cell.spans[1, :3]
    assert [text[s:e] for _, s, e in spans] == ["0.4", "-0.2", "0.3"]
    assert [text[s:e] for _, s, e in cell.spans[3, :6]] == ["0.2", "0.1", "0.3", "0", "3.1416", "0"]  # the literal, not the frame's
    assert emit_texts(cell, cell)[0] == text


def test_compensated_numbers_are_written_back_in_metres_and_radians(cell):
    moved = cell.with_positions(cell.position + np.array([1.0, 0.0, -0.5]))
    text = emit_texts(cell, moved)[0]
    assert "movel(p[0.401, -0.2, 0.2995, 0, 3.1416, 0], a=1.2, v=0.25)" in text
    joints = cell.joints.copy()
    joints[0, 0] = 10.0
    assert "home = [0.174533, -1.5708," in emit_texts(cell, cell.with_joints(joints))[0]


def test_a_turned_orientation_is_written_as_the_rotation_vector_nearest_the_old_one(cell):
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec([0.0, 0.0, 0.01])
    quats = cell.orientation.copy()
    has = ~np.isnan(quats).any(axis=1)
    old = Rotation.from_quat(quats[has][:, [1, 2, 3, 0]])
    quats[has] = (old * turn).as_quat()[:, [3, 0, 1, 2]]
    written = parse_program_text(emit_texts(cell, cell.with_orientations(quats))[0])
    back = Rotation.from_quat(written.orientation[has][:, [1, 2, 3, 0]])
    assert np.degrees((back.inv() * old * turn).magnitude()).max() < 1e-4
    # (0, 3.1416, 0) is just past a half turn: the nearest spelling keeps its numbers, not (0, -3.1416, 0)'s
    assert np.all(written.values[1, 4] > 3.0)


def parse_program_text(text: str):
    return dialects.get("urscript").parse("<text>.script", text.encode("latin-1"))


def test_targets_the_text_does_not_fix_are_unresolved_with_a_note():
    tp = parse_program_text("def p():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  movel(p[x, 0, 0.3, 0, 3.14, 0])\n  if digital_in(0):\n    movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n  end\n"
                            "  movel(p[0.5, 0, 0.3, 0, 3.14, 0])\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  movel(p[0.5, 0, 0.3, 0, 3.14, 0])\n"
                            "  while True:\n    movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n    movej([0, -1.5, 1.5, 0, 0, 0])\n    movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n  end\nend\n")
    assert tp.resolved.tolist() == [True, False, True, False, True, True, False, True, True]
    notes = "\n".join(tp.notes)
    assert "line 3: movel target not known from the text: value 1 of the pose at line 3, column 11 ('x') is not a number" in notes
    assert "line 7: the posture is not known: after the if of line 4" in notes
    assert "line 11: the posture is not known: inside the while of line 10 before any joint target" in notes
    assert "line 10: the while loop runs a number of times the text does not fix: its motions are listed once" in notes


def test_the_tcp_before_any_set_tcp_is_the_installations_and_unknown():
    tp = parse_program_text("movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n")
    assert tp.tool_names[tp.tool[0]] == "<installation TCP>" and not tp.placed()[0]
    given = tp.with_frames(tools={"<installation TCP>": np.eye(4)})
    assert given.placed()[0]


@pytest.mark.parametrize("text, where, message", [
    ("movel(p[0.4, 0, 0.3, 0, 3.14, 0]\n", (1, 6), "movel( is not closed"),
    ("def p():\n  movel([0, 0, 0, 0, 0, 0])\nend\n", (2, 9), "movel takes a pose"),
    ("def p():\n  movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n", (3, 1), "'def' of line 1 has no 'end'"),
    ("movel(p[0.4, 0, 0.3, 0, 3.14, 0], b=1)\n", (1, 6), "movel has no parameter b"),
    ("end\n", (1, 1), "'end' without a block"),
])
def test_refusals_name_the_line_and_column(text, where, message):
    with pytest.raises(ParseError, match=re.escape(message)) as caught:
        parse_program_text(text)
    assert (caught.value.line, caught.value.column) == where


def test_sniffing_tells_urscript_from_krl_and_rapid(tmp_path):
    program = tmp_path / "prog.txt"
    program.write_bytes(CELL.read_bytes())
    assert dialects.sniff(program).name == "urscript"
    assert dialects.sniff(tmp_path / "x.script", b"").name == "urscript"
    krl = tmp_path / "k.txt"
    krl.write_bytes(b"DEF k( )\nPTP {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}\nEND\n")
    assert dialects.sniff(krl).name == "krl"
    rapid = tmp_path / "r.txt"
    rapid.write_bytes(b"MODULE m\nPROC main()\nMoveL p10, v100, fine, tool0;\nENDPROC\nENDMODULE\n")
    assert dialects.sniff(rapid).name == "rapid"


@pytest.mark.parametrize("source", ["rapid/milling_wobj.mod", "rapid/circles.mod", "rapid/absj_home.mod", "krl/circ_arcs.src"])
def test_convert_to_urscript_reads_back_the_same_poses(source):
    from postproc.programs import write_program

    original = parse_program(Path(__file__).parent / "corpus" / source)
    text = write_program(original, "urscript", "converted")[0]
    back = parse_program_text(text)
    assert len(back) == len(original) and back.kind.tolist() == original.kind.tolist()
    cart = original.kind != Kind.ABSJ
    np.testing.assert_allclose(back.base_poses()[cart][:, :3, 3], original.base_poses()[cart][:, :3, 3], atol=1e-3)  # 7 decimals of a metre
    np.testing.assert_allclose(back.base_poses()[cart][:, :3, :3], original.base_poses()[cart][:, :3, :3], atol=1e-6)
    np.testing.assert_allclose(back.tools[back.tool][cart], original.tools[original.tool][cart], atol=1e-3)
    np.testing.assert_allclose(back.joints[~cart], original.joints[~cart], atol=1e-5)
    assert emit_texts(back, back)[0] == text


def test_a_function_runs_where_it_is_called():
    """A def beside top-level statements is a function (URScript manual, "Functions"): its body
    does not run where it is written; after a call of it that moves or sets the TCP, the joints
    and the TCP are the ones it left, which the text does not fix here."""
    tp = parse_program_text("def sub():\n  set_tcp(p[0, 0, 0.1, 0, 0, 0])\n  movel(p[0.4, 0, 0.3, 0, 3.14, 0])\nend\n"
                            "set_tcp(p[0, 0, 0.2, 0, 0, 0])\nmovej([0, -1.57, 1.57, 0, 0, 0])\nmovel(p[0.5, 0, 0.3, 0, 3.14, 0])\n"
                            "sub()\nmovel(p[0.6, 0, 0.3, 0, 3.14, 0])\n")
    assert tp.line.tolist() == [3, 6, 7, 9]
    assert tp.resolved.tolist() == [False, True, True, False]
    np.testing.assert_allclose(tp.tools[tp.tool[2]][:3, 3], [0, 0, 200])  # the def's set_tcp did not run at line 2
    assert tp.tool_names[tp.tool[3]] == "TCP after sub()@8" and not tp.placed()[3]
    notes = "\n".join(tp.notes)
    assert "line 3: the posture is not known: inside def sub (line 1): it runs where it is called" in notes
    assert "line 9: the posture is not known: after the call of sub (line 1) at line 8" in notes
    # PolyScope's form: one def and nothing else at the top level is the program itself
    program = parse_program_text("def prog():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  movel(p[0.5, 0, 0.3, 0, 3.14, 0])\nend\n")
    assert program.resolved.all()


def test_a_while_loop_whose_passes_the_text_fixes_is_run_pass_by_pass():
    """``i = 0`` / ``while i < 3:`` / ... / ``i = i + 1``: three passes (URScript manual, "Flow of
    control"), one row per executed motion in execution order, the passes sharing the numbers."""
    text = ("def p():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  i = 0\n  while (i < 3):\n    movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n"
            "    j = 1\n    while j <= 2:\n      movel(p[0.45, 0, 0.3, 0, 3.14, 0], v=0.1)\n      j = j + 1\n    end\n"
            "    movej([0, -1.5, 1.5, 0, 0, 0])\n    i = i + 1\n  end\n  movel(p[0.5, 0, 0.3, 0, 3.14, 0])\nend\n")
    tp = parse_program_text(text)
    assert tp.line.tolist() == [2] + [5, 8, 8, 11] * 3 + [14]
    assert tp.resolved.all()
    assert "line 4: the while loop runs 3 times (i from 0 while i < 3): its motions are listed per pass" in tp.notes
    assert "line 7: the while loop runs 2 times (j from 1 while j <= 2): its motions are listed per pass" in tp.notes
    assert emit_texts(tp, tp)[0] == text
    # a counter changed otherwise, or a way out of the body: the count is not the text's
    for body in ("    i = i + 2\n", "    if x:\n      break\n    end\n    i = i + 1\n"):
        once = parse_program_text(f"def p():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  i = 0\n  while i < 3:\n    movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n{body}  end\nend\n")
        assert once.line.tolist() == [2, 5] and not once.resolved[1]


def test_motions_without_targets_and_modes_that_leave_the_path():
    """speedl moves the robot with no target: the joints after it are unknown; under force_mode
    (and conveyor tracking, path offsets) the robot does not go to the programmed targets
    (URScript manual, "speedl", "force_mode", "end_force_mode")."""
    tp = parse_program_text("def p():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  speedl([0, 0, -0.01, 0, 0, 0], 0.5, 2)\n"
                            "  movel(p[0.4, 0, 0.3, 0, 3.14, 0])\n  movej([0, -1.57, 1.57, 0, 0, 0])\n"
                            "  force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 10, 0, 0, 0], 2, [0.1, 0.1, 0.1, 0.3, 0.3, 0.3])\n"
                            "  movel(p[0.4, 0, 0.2, 0, 3.14, 0])\n  end_force_mode()\n  movel(p[0.4, 0, 0.3, 0, 3.14, 0])\nend\n")
    assert tp.line.tolist() == [2, 4, 5, 7, 9]
    assert tp.resolved.tolist() == [True, False, True, False, True]
    notes = "\n".join(tp.notes)
    assert "line 4: the posture is not known: after speedl at line 3" in notes
    assert "line 7: force_mode (line 6) is in force: the robot does not go to the programmed target" in notes


def test_crlf_line_ends_read_the_same_and_round_trip(cell):
    text = cell.sources[0].text.replace("\n", "\r\n")
    crlf = parse_program_text(text)
    assert crlf.line.tolist() == cell.line.tolist()
    np.testing.assert_allclose(crlf.base_positions()[1:], cell.base_positions()[1:])
    assert emit_texts(crlf, crlf)[0] == text


def test_a_variable_holding_a_number_gives_a_pose_its_number_and_span():
    text = "def p():\n  global z_safe = 0.25\n  movej([0, -1.57, 1.57, 0, 0, 0])\n  movel(p[0.4, 0, z_safe, 0, 3.14, 0])\n  movel(p[0.5, 0, z_safe, 0, 3.14, 0])\nend\n"
    tp = parse_program_text(text)
    assert tp.resolved.all()
    np.testing.assert_allclose(tp.position[1:, 2], [250.0, 250.0])
    s, e = tp.spans[1, 2, 1:]
    assert text[s:e] == "0.25" and tp.spans[2, 2, 1] == s  # both targets take the assignment's number
    one = emit_texts(tp, tp.with_positions(tp.position + np.array([0.0, 0.0, 1.0])))[0]
    assert "global z_safe = 0.251" in one  # both targets need the same new value: written once
    from postproc.errors import SharedNumberError

    moved = tp.position.copy()
    moved[2, 2] += 2.0
    with pytest.raises(SharedNumberError):  # two different values for one number: refused
        emit_texts(tp, tp.with_positions(moved))
