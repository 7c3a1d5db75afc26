"""Fanuc TP (.ls) reading, writing back and the R-30iB's configuration rules.

No open interpreter of TP exists to judge the reading: every expected value below was
written by hand from the R-30iB Operator's Manual's rules ("Program structure", "Motion
instructions", "Position data", "Configuration"), as the comments say.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import postproc
from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.dialects import sniff
from postproc.programs.dialects.fanuc.controller import R30IB, config_text, fanuc_config
from postproc.programs.ir import Kind
from postproc.robot import kinematics as kin

SAMPLE = Path(__file__).parent / "data" / "fanuc_sample.ls"


@pytest.fixture(scope="module")
def sample():
    return parse_program(SAMPLE)


def test_sample_targets_as_the_manual_reads_them(sample):
    tp = sample
    # Motion lines 3..9 of /MN (file lines 11..18): J P[1]; L P[2]; C P[3] with its end P[4]
    # on the continuation line; L PR[1]; L P[2] Offset,PR[2]; J P[5] (a joint position).
    assert tp.kind.tolist() == [Kind.JOINT, Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END, Kind.LINEAR, Kind.LINEAR, Kind.ABSJ]
    assert tp.line.tolist() == [11, 12, 14, 15, 16, 17, 18]
    np.testing.assert_array_equal(tp.position[[0, 1, 2, 3, 5]], [[900, 0, 300], [950, 100, 250], [1000, 150, 250], [1050, 100, 250], [950, 100, 250]])
    # W P R are rotations about the fixed X, Y, Z: W = 180 is Rx(180): quaternion (0, 1, 0, 0);
    # W 180, R 90: Rz(90) Rx(180), the tool down and its x along base y.
    np.testing.assert_allclose(tp.orientation[0], [0, 1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(tp.orientation[1], [0, np.sqrt(0.5), np.sqrt(0.5), 0], atol=1e-12)
    # PR[1] and the register offset are set outside the program: unresolved, with notes.
    assert tp.resolved.tolist() == [True, True, True, True, False, False, True]
    assert np.isnan(tp.position[4]).all()
    assert any("PR[1]" in n for n in tp.notes) and any("Offset" in n for n in tp.notes)
    # Speeds: 500mm/sec; 100mm/sec on both points of the C motion; 600cm/min = 100 mm/s; % is no TCP speed.
    np.testing.assert_allclose(tp.speed, [np.nan, 500, 100, 100, 100, 100, np.nan])
    # FINE is an exact stop (zone 0); CNT is a rounding the controller sizes (NaN mm).
    np.testing.assert_array_equal(np.isnan(tp.zone), [False, True, False, False, False, True, False])
    # 'N U T, 0, 0, 0': arm code 0, turns 0.
    np.testing.assert_array_equal(tp.conf[0], [0, 0, 0, 0])
    # Joint position P[5]: J3 = -10 is the forearm to the horizontal; the robot files' J3 is
    # relative to the upper arm: -10 + J2 (20) = 10.
    np.testing.assert_array_equal(tp.joints[6], [10, 20, 10, 0, -80, 0])
    assert tp.target_name[:2] == ("P[1]", "P[2]")
    # CNT values as written (-1: FINE), kept in Toolpath.extras.
    np.testing.assert_array_equal(tp.extras["fanuc.cnt"], [-1, 100, -1, -1, -1, 50, -1])
    assert tp.take([1, 5]).extras["fanuc.cnt"].tolist() == [100, 50]


def test_orientations_are_written_back_as_w_p_r(sample):
    """A new orientation is written as W P R near the numbers there (rotation_forms 'wpr')."""
    from postproc.robot.frames import abc_to_quat_wxyz

    turned = abc_to_quat_wxyz(np.array([[95.0, 0.0, 180.0]]))  # R 95 (about Z), W 180
    rows = np.array([1, 5])  # P[2] is the target of both lines: one number, one value (else SharedNumberError)
    orientation = sample.orientation.copy()
    orientation[rows] = turned
    text = emit_texts(sample, sample.with_orientations(orientation))[0]
    back = parse_program(SAMPLE, "fanuc", text.encode("latin-1"))
    np.testing.assert_allclose(back.values[1, 3:6], [180, 0, 95], atol=1e-9)


def test_every_number_has_its_span(sample):
    text = sample.sources[0].text
    for row in (0, 3):
        for field, want in zip(range(6), sample.values[row, :6]):
            _, s, e = sample.spans[row, field]
            assert float(text[s:e]) == want


def test_unchanged_emit_is_byte_identical(sample):
    assert emit_texts(sample, sample)[0] == SAMPLE.read_text(encoding="latin-1")


def test_compensated_numbers_are_written_in_place(sample):
    moved = sample.with_positions(sample.position + np.array([0.5, -0.25, 0.125]))
    text = emit_texts(sample, moved)[0]
    back = parse_program(SAMPLE, "fanuc", text.encode("latin-1"))
    ok = ~np.isnan(sample.position[:, 0])
    np.testing.assert_allclose(back.position[ok], moved.position[ok], atol=1e-6)
    assert "X =   900.5" in text or "X = 900.5" in text or "900.5" in text


def test_sniffing(tmp_path):
    assert sniff(SAMPLE).name == "fanuc"
    as_txt = tmp_path / "prog.txt"
    as_txt.write_bytes(SAMPLE.read_bytes())
    assert sniff(as_txt).name == "fanuc"  # by content: /PROG and /MN
    gcode = tmp_path / "part.txt"
    gcode.write_text("G1 X10 Y20 F100\nM30\n")
    assert sniff(gcode).name == "gcode"


def _variant(tmp_path, old: str, new: str) -> Path:
    text = SAMPLE.read_text(encoding="latin-1")
    assert old in text
    path = tmp_path / "v.ls"
    path.write_bytes(text.replace(old, new, 1).encode("latin-1"))
    return path


@pytest.mark.parametrize("old, new, line, why", [
    ("   9:J P[5] 50% FINE", "   9:J P[6] 50% FINE", 18, "P[6] is not in /POS"),
    ("CNT100    ;", "CNT100 Frobnicate    ;", 12, "motion option 'Frobnicate'"),
    ("   6:C P[3]    \n    :  P[4] 100mm/sec FINE    ;", "   6:C P[3] 100mm/sec FINE ;", 14, "end point"),
    ("/END\n", "/END\nJ P[1]\n", 51, "after /END"),
    ("	X =  1000.000  mm,", "	X =  1000.000  mm,	X = 1 mm,", 35, "given twice"),
])
def test_refusals_name_file_line_and_column(tmp_path, old, new, line, why):
    path = _variant(tmp_path, old, new)
    with pytest.raises(ParseError) as exc:
        parse_program(path)
    assert exc.value.line == line and why in str(exc.value), str(exc.value)
    assert exc.value.column >= 1


def test_frame_number_mismatch_is_unresolved(tmp_path):
    """UTOOL_NUM=3 in force, positions taught with UT 0: the controller stops (frame mismatch
    alarm) or, with $MCR.$UFRCHK off, runs them with tool 3: not known from the program."""
    tp = parse_program(_variant(tmp_path, "   2:  UTOOL_NUM=0 ;", "   2:  UTOOL_NUM=3 ;"))
    assert not tp.resolved[0] and any("frame mismatch" in n and ":11:" in n.replace("ls:11", ":11:") for n in tp.notes)


def test_frames_and_tools_by_number(tmp_path):
    """UF 1 / UT 2 are set on the pendant: unknown until given (--frame UFRAME[1]=...); a
    UFRAME[1]=PR[3] assignment makes the frame after it another unknown one."""
    path = _variant(tmp_path, "   3:J P[1] 100% FINE    ;", "   3:J P[1] 100% FINE    ;\n    :  UFRAME[1]=PR[3] ;")
    text = path.read_text().replace("UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',\n	X =   950", "UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',\n	X =   950")
    text = text.replace("   1:  UFRAME_NUM=0 ;\n   2:  UTOOL_NUM=0 ;\n", "")
    path.write_text(text)  # (a statement without its number: the ASCII loader numbers it)
    tp = parse_program(path)
    assert "UFRAME[1]@line10" in tp.frame_names and "UTOOL[2]" in tp.tool_names
    rows = tp.target_name.index("P[2]")
    assert not tp.placed()[rows]
    placed = tp.with_frames({"UFRAME[1]@line10": np.eye(4)}, {"UTOOL[2]": np.eye(4)})
    assert placed.placed()[rows]


# ----------------------------------------------------------------- configuration

@pytest.fixture(scope="module")
def m20ia():
    return postproc.load_robot("fanuc_m20ia")


def test_home_posture_is_n_u_t(m20ia):
    # The home posture (J5 = -90, the tool down) is 'N U T, 0, 0, 0' (manual, "Configuration"),
    # and the faceplate is then at X 985 (150 + 835), Z 940 (790 + 250 - 100) in the world frame.
    q = np.array([[0, 0, 0, 0, -90, 0]], float)
    assert config_text(fanuc_config(m20ia, q)[0]) == "N U T, 0, 0, 0"
    np.testing.assert_allclose(kin.fk(m20ia, q)[0, :3, 3], [985, 0, 940], atol=1e-9)
    # J5 > 0 flips the wrist; J6 = 200 is turn 1, J4 = -190 turn -1; behind J1: J1 = 180 with the arm forward -> B.
    q = np.array([[0, 0, 0, -190, 30, 200]], float)
    assert config_text(fanuc_config(m20ia, q)[0]) == "F U T, -1, 0, 1"


def test_branch_from_conf_gives_back_the_joints(m20ia):
    rng = np.random.default_rng(3)
    lo, hi = m20ia.lower_deg, m20ia.upper_deg
    q = rng.uniform(lo * 0.9, hi * 0.9, size=(300, 6))
    q[:, 2] = rng.uniform(-170, 170, 300)  # J3's range (458 deg) holds poses twice; CONFIG names no J3 turn: IK gives J3 in (-180, 180]
    poses = kin.fk(m20ia, q)
    sols = kin.ik(m20ia, poses)
    got, branch = R30IB.branch_from_conf(m20ia, sols, fanuc_config(m20ia, q))
    ok = branch >= 0
    assert ok.mean() > 0.95  # the rest lie within 1e-9 of a boundary or a singular wrist
    np.testing.assert_allclose(got[ok], q[ok], atol=1e-6)


def test_the_one_pass_reading_of_pos_equals_the_block_reading(tmp_path):
    """The controller's own Cartesian layout is read in one pass (positions._canonical); it
    must give what the block-by-block reader gives."""
    from postproc.programs.dialects.fanuc import positions

    text = SAMPLE.read_text(encoding="latin-1").replace("P[5]{", "P[9]{")  # any P numbers
    cartesian = text[: text.index("P[9]{")] + "/END\n"  # the joint position P[9] is not of that layout
    start, end = cartesian.index("/POS") + 5, cartesian.index("/END")
    fast, slow = positions._canonical(cartesian, start, end), positions.read_blocks(cartesian, start, end)
    assert fast is not None and fast.row_of == slow.row_of
    for field in ("values", "spans", "joint", "uf", "ut", "conf"):
        np.testing.assert_array_equal(getattr(fast, field), getattr(slow, field), err_msg=field)
    assert positions._canonical(text, text.index("/POS") + 5, text.index("/END")) is None  # a joint position: block by block


@pytest.mark.parametrize("old, new", [("   4:L P[2:\"approach\"]", "   4:A P[2:\"approach\"]"), ("500mm/sec CNT100    ;", "500mm/sec CNT100 Wjnt    ;")])
def test_arc_and_wrist_joint_motions_are_named_as_inexact(tmp_path, old, new):
    """A (an arc through consecutive points) and Wjnt (wrist joints interpolated) leave the
    straight line between targets (manual, "Circular arc motion", "Wrist joint"): the
    targets are exact, the first such line is named (compensate notes it, --max-deviation refuses)."""
    assert R30IB.inexact_interpolation(parse_program(SAMPLE)) is None
    tp = parse_program(_variant(tmp_path, old, new))
    assert tp.resolved[1] and R30IB.inexact_interpolation(tp).startswith(f"{tmp_path / 'v.ls'}:12: ")


def test_joint_positions_are_written_back_with_the_controllers_j3(tmp_path, sample):
    """The IR's j3 is J3 + J2; a new joint value is written as J3 = j3 - J2 (the J2/J3 interaction)."""
    joints = sample.joints.copy()
    joints[6, 2] = 25.0  # forearm 5 degrees above the horizontal with J2 = 20
    text = emit_texts(sample, sample.with_joints(joints))[0]
    assert "J3=   5.000 deg" in text  # in the number's own width and decimals
    np.testing.assert_allclose(parse_program(SAMPLE, "fanuc", text.encode("latin-1")).joints[6], [10, 20, 25, 0, -80, 0])


def test_continuation_lines_process_tags_and_via_options():
    """Welding listings continue a motion on ': ...' lines (Arc Start[6], Arc End[6]) and give
    options on a C motion's via line (Tool_Offset,PR[28]): read as the manual's "Motion
    instruction options"; an option on the end line leaves the via point unknown too (which
    point the controller applies it to is not determined here)."""
    path = Path(__file__).parent / "data" / "fanuc_weld_tags.ls"
    tp = parse_program(path)
    assert tp.kind.tolist() == [Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END, Kind.CIRC_VIA, Kind.CIRC_END]
    assert tp.line.tolist() == [4, 7, 8, 10, 11]
    assert tp.resolved.tolist() == [True, False, True, False, False]  # WELD_SPEED is a speed; Tool_Offset on the via line, then on the end line
    assert np.isnan(tp.speed[1:3]).all() and tp.zone[2] == 0
    assert emit_texts(tp, tp)[0] == path.read_text(encoding="latin-1")


def test_extended_axes_of_group_1_leave_the_target_unknown(tmp_path):
    """E1 in group 1 is an axis integrated with the arm (a rail moves its base): not modelled."""
    tp = parse_program(_variant(tmp_path, "\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg\n};\nP[2",
                                "\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg,\n\tE1=   250.000  mm\n};\nP[2"))
    assert not tp.resolved[0] and tp.resolved[1] and tp.ext[0, 0] == 250 and any("extended axes" in n for n in tp.notes)


def test_untaught_positions_other_groups_and_point_logic_blocks(tmp_path):
    """Shapes of real cell backups: a position never taught ('********', the controller has no
    value), a position of other groups only (a servo gun's), a TB ...,P-SPS point logic block
    closed by '------ ;'. Read; a motion to the first two is unresolved with the reason."""
    text = SAMPLE.read_text(encoding="latin-1")
    text = text.replace("   9:J P[5] 50% FINE    ;", "   9:J P[6] 100% CNT0 ACC100 TB   0.00sec,P-SPS    ;\n      1:  DO[1]=ON ;\n       ------ ;\n  10:L P[7] 100mm/sec FINE    ;")
    text = text.replace("/END", "P[6]{\n   GP1:\n\tUF : F, UT : F,\t\tCONFIG : 'N D B, 0, 0, 0',\n\tX = ********  mm,\tY = ********  mm,\tZ = ********  mm,\n"
                                "\tW = ******** deg,\tP = ******** deg,\tR = ******** deg\n};\nP[7]{\n   GP2:\n\tUF : F, UT : F,\n\tJ1=   300.000  mm\n};\n/END")
    path = tmp_path / "cell.ls"
    path.write_text(text)
    tp = parse_program(path)
    assert emit_texts(tp, tp)[0] == text
    assert tp.target_name[-2:] == ("P[6]", "P[7]") and not tp.resolved[-2:].any() and np.isnan(tp.position[-2:]).all()
    assert any("never taught" in n for n in tp.notes) and any("no group 1" in n for n in tp.notes)


@pytest.mark.parametrize("old, new, why", [("CONFIG : 'N U T, 0, 0, 0',\n\tX =   900", "KONFIG : 'N U T, 0, 0, 0',\n\tX =   900", "German"),
                                           ("\tX =   900.000  mm,\tY =     0.000  mm,\tZ =   300.000  mm,\n\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000",
                                            "\tRX =   900.000  mm,\tRY =     0.000  mm,\tRZ =   300.000  mm,\n\tRW =   180.000 deg,\tRP =     0.000 deg,\tRR =     0.000", "RX .. RR")])
def test_listings_in_words_postproc_does_not_read_are_refused_with_the_reason(tmp_path, old, new, why):
    with pytest.raises(ParseError, match=why) as exc:
        parse_program(_variant(tmp_path, old, new))
    assert exc.value.line in (22, 23)


def test_a_linear_motion_after_a_jump_keeps_a_posture_the_text_does_not_fix():
    """IF DI[1]=ON,JMP LBL[10] may skip P[2] (CONFIG 'F U T'), on an input the text does not
    give: the L to P[3] keeps P[1]'s posture or P[2]'s, so it is unresolved (R-30iB manual,
    "Branching instructions"); the J motions are placed (each CONFIG sets the posture). The
    same program with an unconditional JMP is followed (tests/test_fanuc_flow.py)."""
    tp = parse_program(Path(__file__).parent / "data" / "fanuc_jump.ls")
    assert tp.resolved.tolist() == [True, True, False]
    assert any("line 10" in note and "flow" in note for note in tp.notes)
    unconditional = (Path(__file__).parent / "data" / "fanuc_jump.ls").read_text().replace("IF DI[1]=ON,JMP LBL[10]", "JMP LBL[10]")
    tp = parse_program("jump.ls", "fanuc", unconditional.encode("latin-1"))
    assert tp.target_name == ("P[1]", "P[3]") and tp.resolved.all()
