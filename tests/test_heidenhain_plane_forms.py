"""Heidenhain PLANE forms other than SPATIAL, and the positioning modes TURN and MOVE DIST.

Expected values written by hand from the TNC 640 User's Manual (Klartext), "Tilting the working
plane: PLANE function" (each form's definition, quoted in postproc/programs/dialects/heidenhain/plane_forms.py)
and "Automatic positioning: MOVE/TURN/STAY":
- MOVE turns about the tool tip; MOVE DIST d about the point d along the tool axis from the tip
  ("the tool is at the same position relative to the workpiece after positioning");
- TURN positions only the rotary axes: the linear axes stay, the tip moves with the table
  (table machines) or swings with the head (head machines).
The machines turn the TABLE right-handed by +angle (machines/*.toml): machine = Rx(A) Rz(C)
workpiece on xyzac-trt, A about the line through (0, 20, 10); the head of xyzbc-5axiskins turns
the tool by Rz(C) Ry(-B) about a pivot 250 mm + the tool length above the tip.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.fivex.errors import MachineFileError
from postproc.fivex.machine import load_machine
from postproc.programs import dialects, emit_texts, parse_program

S3 = np.sqrt(3.0)
RY30 = np.array([[S3 / 2, 0, 0.5], [0, 1, 0], [-0.5, 0, S3 / 2]])  # Ry(30): columns tilted X, Y, Z


def read(body: str, before: str = "A+0 C+0", tool: str = ""):
    text = (f"BEGIN PGM P MM\n{tool}TOOL CALL 1 Z S1000\nL X+0 Y+0 Z+50 {before} R0 FMAX\n{body}\n"
            "L X+10 Y+0 Z+5 FMAX\nPLANE RESET STAY\nEND PGM P MM\n")
    return parse_program(Path("p.h"), data=text.encode("latin-1")).with_frames({"PRESET": np.eye(4)}, None)


def tilt_of(tp) -> np.ndarray:
    """The rotation of the frame of the last target in the tilted plane."""
    return tp.frames[tp.frame[-1]][:3, :3]


@pytest.mark.parametrize("plane, want", [
    # Rz(90) Rx(30) Rz(-90) turns 30 deg about Rz(90) x = y: Ry(30)
    ("PLANE EULER EULPR+90 EULNU+30 EULROT-90 STAY", RY30),
    # traces (cos30, 0, -sin30) on ZX and (0, 1, 0) on YZ: normal (sin30, 0, cos30), X the ZX trace: Ry(30)
    ("PLANE PROJECTED PROPR+30 PROMIN+0 PROROT+0 STAY", RY30),
    # base (0.866, 0, -0.5) and normal (0.5, 0, 0.866) are Ry(30) x and Ry(30) z
    ("PLANE VECTOR BX+0.8660254 BY+0 BZ-0.5 NX+0.5 NY+0 NZ+0.8660254 STAY", RY30),
    # base not perpendicular to the normal: corrected onto the plane, the normal (given unnormalized) stays
    ("PLANE VECTOR BX+1 BY+0 BZ+0.3 NX+0 NY+0 NZ+2 STAY", np.eye(3)),
    # P1 P2 along X; P3 above +Y and +Z: normal x cross (0, 10, 10) = (0, -10, 10): Rx(45)
    ("PLANE POINTS P1X+0 P1Y+0 P1Z+0 P2X+10 P2Y+0 P2Z+0 P3X+0 P3Y+10 P3Z+10 STAY",
     np.array([[1, 0, 0], [0, 1 / np.sqrt(2), -1 / np.sqrt(2)], [0, 1 / np.sqrt(2), 1 / np.sqrt(2)]])),
    # relative to the tilt in force: Ry(30) then 90 about the tilted Z
    ("PLANE SPATIAL SPA+0 SPB+30 SPC+0 STAY\nPLANE RELATIV SPC+90 STAY", RY30 @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])),
    # without a tilt in force RELATIV is about the untilted axes
    ("PLANE RELATIV SPB+30 STAY", RY30),
])
def test_plane_forms(plane, want):
    np.testing.assert_allclose(tilt_of(read(plane)), want, atol=1e-7)


def test_projected_with_two_angles():
    """PROPR+30 PROMIN+30: traces a = (sqrt3/2, 0, -1/2), b = (0, sqrt3/2, 1/2); the tool axis
    a x b / |a x b| = (sqrt3/4, -sqrt3/4, 3/4) / (sqrt15/4); the tilted X is a."""
    r = tilt_of(read("PLANE PROJECTED PROPR+30 PROMIN+30 PROROT+0 STAY"))
    np.testing.assert_allclose(r[:, 2], np.array([S3, -S3, 3]) / np.sqrt(15), atol=1e-12)
    np.testing.assert_allclose(r[:, 0], [S3 / 2, 0, -0.5], atol=1e-12)


def test_a_plane_that_is_no_plane_is_refused_with_its_line():
    with pytest.raises(ParseError, match=r"p\.h:4:\d+: PLANE VECTOR: the tool axis \(normal\) is a zero vector"):
        read("PLANE VECTOR BX+1 BY+0 BZ+0 NX+0 NY+0 NZ+0 STAY")
    with pytest.raises(ParseError, match=r"p\.h:4:\d+: PLANE RELATIV takes one angle"):
        read("PLANE RELATIV SPA+10 SPB+10 STAY")


def placed(body, machine="xyzac-trt", before="A+0 C+0", tool=""):
    tp = read(body, before, tool)
    return dialects.of(tp).for_machine(tp, load_machine(machine))


def test_euler_placed_as_the_same_spatial_plane():
    """EULER Ry(30) on xyzbc-trt: SEQ- B-30 C0 (test_heidenhain_plane's SPB+30), tip Ry(30) (10, 0, 5)."""
    tp = placed("PLANE EULER EULPR+90 EULNU+30 EULROT-90 SEQ- MOVE", "xyzbc-trt", "B+0 C+0")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.ext[-1, 1:3], [-30, 0], atol=1e-9)
    np.testing.assert_allclose(tp.position[-1], [5 * S3 + 2.5, 0, 2.5 * S3 - 5], atol=1e-9)


def test_turn_moves_the_tip_with_the_table():
    """xyzac-trt, A0 C0, tip (0, 0, 50) = its machine position. SPA+30 SEQ+: A+30 C-180. The
    linear axes stay: workpiece = Rz(180) (Rx(-30) ((0, 0, 50) - (0, 20, 10)) + (0, 20, 10))
    = Rz(180) (0, 40 - 10 sqrt3, 20 + 20 sqrt3) = (0, 10 sqrt3 - 40, 20 + 20 sqrt3)."""
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ TURN")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1], [0, 10 * S3 - 40, 20 + 20 * S3], atol=1e-9)
    np.testing.assert_allclose(tp.ext[1, [0, 2]], [30, -180], atol=1e-9)


def test_move_dist_turns_about_a_point_on_the_tool_axis():
    """MOVE DIST+50 from (0, 0, 50), tool axis z: the centre (0, 0, 100) stays; the tilted tool axis
    Rx(30) z = (0, -1/2, sqrt3/2): tip = (0, 0, 100) - 50 (0, -1/2, sqrt3/2) = (0, 25, 100 - 25 sqrt3)."""
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ MOVE DIST+50 F1000")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1], [0, 25, 100 - 25 * S3], atol=1e-9)


@pytest.mark.parametrize("seq, want", [("SEQ+", (30, -180)), ("SEQ-", (-30, 0))])
def test_head_head_master_axis_is_the_head_axis_nearest_the_tool(seq, want):
    """xyzbc-5axiskins: tool axis Rz(C) Ry(-B) z = Rz(C) (-sin B, 0, cos B); SPB+30 asks for
    (1/2, 0, sqrt3/2): B-30 C0 or B+30 C180. The master axis ("the 1st rotary axis from the tool")
    is B. MOVE: the tip keeps its place, the next target is Ry(30) (10, 0, 5)."""
    tp = placed(f"PLANE SPATIAL SPA+0 SPB+30 SPC+0 {seq} MOVE", "xyzbc-5axiskins", "B+0 C+0")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.ext[1:, 1:3], [want] * 2, atol=1e-9)
    np.testing.assert_allclose(tp.position[1:], [[0, 0, 50], [5 * S3 + 2.5, 0, 2.5 * S3 - 5]], atol=1e-9)


def test_turn_on_a_head_machine_swings_the_tip_about_the_pivot():
    """TOOL DEF 1 L+100: the pivot 250 + 100 mm above the tip, at (0, 0, 400) with B0 C0. TURN to
    B+30 C-180: tool axis (1/2, 0, sqrt3/2), the tip 350 mm below the pivot along it:
    (-175, 0, 400 - 175 sqrt3)."""
    tp = placed("PLANE SPATIAL SPA+0 SPB+30 SPC+0 SEQ+ TURN", "xyzbc-5axiskins", "B+0 C+0", tool="TOOL DEF 1 L+100 R+5\n")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1], [-175, 0, 400 - 175 * S3], atol=1e-9)


def test_turn_without_the_rotary_positions_before_stays_flagged():
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ TURN", before="")
    assert not tp.resolved[1:].any() and any("TURN moves the tool tip" in n for n in tp.notes), tp.notes


# ---------------------------------------------------------------- STAY, Cycle 19, PLANE AXIAL
# The tip values: xyzac-trt with the table at A (C0) puts workpiece point p at Rx(A) (p - c) + c,
# c = (0, 20, 10); the tip (0, 0, 50) stays in the machine when only rotary axes move, so in the
# workpiece it goes to Rx(-A) ((0, 0, 50) - c) + c:
TIP_AT_A_MINUS_30 = [0, -10 * S3, 20 * S3]  # Rx(30) (0, -20, 40) + c
TIP_AT_A_PLUS_30 = [0, 40 - 10 * S3, 20 + 20 * S3]  # Rx(-30) (0, -20, 40) + c
RX30_P = [10, -2.5, 2.5 * S3]  # Rx(30) (10, 0, 5): the next target in the plane tilted by SPA+30
RXM30_P = [10, 2.5, 2.5 * S3]  # Rx(-30) (10, 0, 5)


def test_stay_with_q120_q122_is_the_tncs_solution():
    """STAY stores the solution in Q120 (A) and Q122 (C): A+30 C-180 with SEQ+; the rotary-only
    block moves no linear axis (the TURN tip, test_turn_moves_the_tip_with_the_table)."""
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ STAY\nL A+Q120 C+Q122 R0 FMAX")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.ext[1:, [0, 2]], [(30, -180)] * 2, atol=1e-9)
    np.testing.assert_allclose(tp.position[1:], [[0, 10 * S3 - 40, 20 + 20 * S3], RX30_P], atol=1e-9)
    assert any("Q120..Q122 are the TNC's solution A+30.0000 C-180.0000" in n for n in tp.notes), tp.notes


def test_stay_with_the_programs_own_numbers():
    """The program may position the other solution itself (A-30 C0 turns Rx(30) z onto z)."""
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 STAY\nL A-30 C+0 R0 FMAX")
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1:], [TIP_AT_A_MINUS_30, RX30_P], atol=1e-9)


def test_stay_with_axes_off_the_plane_is_flagged():
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 STAY\nL A+10 C+0 R0 FMAX")
    assert tp.resolved[0] and not tp.resolved[1:].any()
    assert any("from line 5 on" in n and "do not stand in the tilted plane" in n for n in tp.notes), tp.notes


def test_stay_q120_without_seq_or_start_stays_flagged():
    tp = placed("PLANE SPATIAL SPA+30 SPB+0 SPC+0 STAY\nL A+Q120 C+Q122 R0 FMAX", before="")
    assert not tp.resolved[1:].any() and any("Q120..Q122 (the TNC's solution)" in n for n in tp.notes), tp.notes


CYCLE19 = "CYCL DEF 19.0 WORKING PLANE\nCYCL DEF 19.1 A{a}\nL A{axis} C+0 R0 FMAX"


def test_cycle19_spatial_angles_by_default():
    """Without [heidenhain] cycle19_angles the angles are spatial: A+30 is Rx(30), reached at A-30 C0."""
    tp = placed(CYCLE19.format(a="+30", axis="-30"))
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1:], [TIP_AT_A_MINUS_30, RX30_P], atol=1e-9)
    assert not placed(CYCLE19.format(a="+30", axis="+30")).resolved[1:].any()  # A+30 C0 tilts to Rx(-30)


def axis_angle_machine(tmp_path):
    text = (Path(__file__).parents[1] / "machines" / "xyzac-trt.toml").read_text()
    path = tmp_path / "xyzac-axis.toml"
    path.write_text(text.replace('name = "xyzac-trt"', 'name = "xyzac-axis"') + '\n[heidenhain]\ncycle19_angles = "axis"\n')
    return str(path)


def test_cycle19_axis_angles_from_the_machine_file(tmp_path):
    """cycle19_angles = "axis": A+30 is the table at A+30: the plane Rx(-30); A-30 is Rx(30), the
    same plane as spatial A+30."""
    machine = axis_angle_machine(tmp_path)
    tp = placed(CYCLE19.format(a="+30", axis="+30"), machine)
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1:], [TIP_AT_A_PLUS_30, RXM30_P], atol=1e-9)
    tp = placed(CYCLE19.format(a="-30", axis="-30"), machine)
    np.testing.assert_allclose(tp.position[1:], [TIP_AT_A_MINUS_30, RX30_P], atol=1e-9)


def test_machine_file_heidenhain_key_is_checked(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(Path(axis_angle_machine(tmp_path)).read_text().replace('"axis"', '"axes"'))
    with pytest.raises(MachineFileError, match="heidenhain.cycle19_angles"):
        load_machine(str(path))


@pytest.mark.parametrize("plane, tip, after", [
    ("PLANE AXIAL A-30 MOVE", [0, 0, 50], RX30_P),  # C not given: stays at C0; MOVE keeps the tip
    ("PLANE AXIAL A+30 TURN", TIP_AT_A_PLUS_30, RXM30_P),
])
def test_plane_axial(plane, tip, after):
    tp = placed(plane)
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(tp.position[1:], [tip, after], atol=1e-9)
    np.testing.assert_allclose(tp.ext[1:, [0, 2]], [(float(plane.split()[2][1:]), 0)] * 2, atol=1e-9)


def test_the_corpus_program_of_every_form_is_placed_on_a_machine():
    """tests/corpus/heidenhain/planes.h: every PLANE form and positioning mode, Cycle 19, LN and
    M140 in one program; byte-identical round trip; on xyzac-trt every target is placed but the
    two M140 retracts whose Z the text does not give (before any position, and MB MAX)."""
    path = Path(__file__).parent / "corpus" / "heidenhain" / "planes.h"
    tp = parse_program(path)
    assert emit_texts(tp, tp)[0].encode("latin-1") == path.read_bytes()
    placed_tp = dialects.of(tp).for_machine(tp.with_frames({"PRESET": np.eye(4)}, None), load_machine("xyzac-trt"))
    assert placed_tp.line[~placed_tp.resolved].tolist() == [5, 41], placed_tp.notes
    np.testing.assert_allclose(placed_tp.position[2], [0, 10 * S3 - 40, 20 + 20 * S3], atol=1e-9)  # TURN, as above
