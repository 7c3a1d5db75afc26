"""CYCLE800 (swivel plane), AR= and CIP arcs in SINUMERIK programs, by hand.

Expected values are worked out from the manuals' rules, cited at each test:
- CYCLE800: SINUMERIK 840D sl / 828D Operating Manual, "Swivel plane (CYCLE800)" (X0 Y0 Z0 the
  reference point for rotation, X1 Y1 Z1 the zero point of the rotated surface, axis-by-axis
  rotation in the chosen sequence, each about the axes the one before left) and the Cycles
  programming manual's parameter list (_MODE bits 0-5 the axis sequence, 6-7 the angle mode;
  _ST units digit 0 new / 1 additive; _TC="0" deselects); Fundamentals "Frame chain" (the
  swivel frame is a system frame below the programmable one).
- AR=: Fundamentals (6FC5398-1BP40), "Circular interpolation", "Circle with opening angle and
  end point (AR)": from the start to the end point through the opening angle, G2 clockwise,
  G3 counter-clockwise in the active plane (radius = chord / (2 sin(angle/2))).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError, ParseError
from postproc.fivex.machine import load_machine
from postproc.programs import arcs, emit_texts, parse_program
from postproc.programs.dialects.sinumerik import swivel

S30, C30 = 0.5, np.sqrt(3) / 2


def _read(tmp_path: Path, text: str, name: str = "PART.MPF"):
    path = tmp_path / name
    path.write_bytes(text.encode("latin-1"))
    return parse_program(path), path


SWIVEL = """N10 G54 G17 G71 G90
N20 G0 X0 Y0 Z50
N30 CYCLE800(1,"TC1",0,57,10,0,0,0,-30,0,0,0,0,-1)
N40 G0 X0 Y0 Z5
N50 G1 X10 Y0 Z0 F500
N60 TRANS X1
N70 G1 X0 Y0 Z0
N80 CYCLE800(1,"TC1",1,57,0,0,0,0,0,90,0,0,0,-1)
N90 G1 X1 Y0 Z0
N100 CYCLE800(1,"0",0,57,0,0,0,0,0,0,0,0,0,1)
N110 G0 X1 Y2 Z3
N120 M30
"""
SWIVEL_EXPECTED = [
    (0.0, 0.0, 50.0),  # N20: no swivel
    (10 - 5 * S30, 0.0, 5 * C30),  # N40: TRANS(10,0,0) @ Ry(-30) (mode 57 = X-Y-Z, _B the Y angle) on (0,0,5)
    (10 + 10 * C30, 0.0, 10 * S30),  # N50: Ry(-30) (10,0,0) = (10 cos30, 0, 10 sin30), + X0
    (10 + C30, 0.0, S30),  # N70: TRANS X1 (programmable) sits on the swivel frame, which it does not delete
    (10.0, 2.0, 0.0),  # N90: additive (_ST=1, mode 57, _C=90): Rz(90) on the swivel; TRANS X1 kept: (1+1,0,0) -> (0,2,0); Ry(-30) leaves Y; + X0
    (2.0, 2.0, 3.0),  # N110: _TC="0" deletes the swivel frame only; TRANS X1 (programmable) still in force
]


def test_cycle800_axis_by_axis_by_hand(tmp_path):
    tp, path = _read(tmp_path, SWIVEL)
    assert tp.resolved.all()
    np.testing.assert_allclose(tp.base_poses()[:, :3, 3], SWIVEL_EXPECTED, atol=1e-9)
    assert emit_texts(tp, tp)[0] == SWIVEL  # byte-identical round trip
    assert any("line 3: CYCLE800 retracts (_FR=1" in n and "turns the rotary axes (_DIR=-1)" in n for n in tp.notes), tp.notes


def _one_swivel(tmp_path, call: str, points: str = "N40 G1 X0 Y0 Z1\nN50 G1 X0 Y1 Z0\n"):
    return _read(tmp_path, f"N10 G54 G17 G90\nN20 G0 X0 Y0 Z9\nN30 {call}\n{points}N60 M30\n")[0]


def test_cycle800_axis_sequence_and_solid_angle_by_hand(tmp_path):
    # _MODE 27 = 0b011011: 1st rotation about Z (bits 1-0 = 11), 2nd Y (10), 3rd X (01); _A=90, _C=90:
    # Rz(90) @ Rx(90): (0,0,1) -> Rx -> (0,-1,0) -> Rz -> (1,0,0); (0,1,0) -> (0,0,1) -> (0,0,1)
    tp = _one_swivel(tmp_path, 'CYCLE800(0,"TC1",0,27,0,0,0,90,0,90,0,0,0,1)')
    np.testing.assert_allclose(tp.base_poses()[1:, :3, 3], [(1, 0, 0), (0, 0, 1)], atol=1e-9)
    # _MODE 64 (bits 7-6 = 01): solid angle, _A about Z then _B about the turned Y: Rz(90) @ Ry(90)
    # (0,0,1) -> Ry -> (1,0,0) -> Rz -> (0,1,0); (0,1,0) -> (0,1,0) -> (-1,0,0)
    tp = _one_swivel(tmp_path, 'CYCLE800(0,"TC1",0,64,0,0,0,90,90,0,0,0,0,1)')
    np.testing.assert_allclose(tp.base_poses()[1:, :3, 3], [(0, 1, 0), (-1, 0, 0)], atol=1e-9)
    # X1 Y1 Z1: the zero point of the rotated surface, in the rotated axes: T(X0) @ R @ T(X1)
    tp = _one_swivel(tmp_path, 'CYCLE800(0,"TC1",0,57,0,0,5,0,0,90,2,0,0,1)')
    np.testing.assert_allclose(tp.base_poses()[1:, :3, 3], [(0, 2, 6), (-1, 2, 5)], atol=1e-9)


def test_cycle800_not_worked_out_flags_what_follows(tmp_path):
    for call, why in (('CYCLE800(0,"TC1",0,57,0,0,0,R1,0,0,0,0,0,1)', "_A=R1 is not a number"),
                      ('CYCLE800(0,"TC1",0,192,0,0,0,0,30,0,0,0,0,1)', "direct mode"),
                      ('CYCLE800(0,"TC1",0,128,0,0,0,0,30,0,0,0,0,1)', "projection angles")):
        tp = _one_swivel(tmp_path, call)
        assert tp.resolved.tolist() == [True, False, False], call
        assert any(why in note for note in tp.notes) and any("line 3" in note for note in tp.notes), tp.notes
    # a new swivel plane after an unknown one is known again
    tp = _one_swivel(tmp_path, 'CYCLE800(0,"TC1",0,192,0,0,0,0,30,0,0,0,0,1)',
                     'N40 G1 X0 Y0 Z1\nN45 CYCLE800(0,"TC1",0,57,0,0,0,0,0,0,0,0,0,1)\nN50 G1 X0 Y1 Z0\n')
    assert tp.resolved.tolist() == [True, False, True]


def test_cycle800_beside_a_subprogram_call(tmp_path):
    # a program with labels or calls goes through the flow reader: the swivel is read there too
    text = 'N10 G54 G17 G90\nN20 G0 X0 Y0 Z9\nSTART:\nN30 CYCLE800(0,"TC1",0,57,0,0,0,0,0,90,0,0,0,1)\nN40 G1 X1 Y0 Z0\nN60 M30\n'
    tp, _ = _read(tmp_path, text)
    assert tp.resolved.all()
    np.testing.assert_allclose(tp.base_poses()[1, :3, 3], (0, 1, 0), atol=1e-9)


def test_cycle800_rotary_positions_by_dir(tmp_path):
    # xyzac-trt (machines/xyzac-trt.toml): workpiece tool axis = Rz(-c) Rx(-a) (0,0,1) = (sin a sin c, sin a cos c, cos a).
    # Swivel Rx(30) (mode 57, _A=30): tool axis (0, -1/2, cos30): a=-30, c=0 or a=30, c=180 (Operating Manual,
    # "Direction (minus/plus)": minus the lower value of the reference axis, plus the higher).
    machine = load_machine("xyzac-trt")
    turn = swivel.rotation(57, np.array([30.0, 0.0, 0.0]))
    np.testing.assert_allclose(swivel.rotary_positions(machine, turn, -1), (-30, 0), atol=1e-9)
    a, c = swivel.rotary_positions(machine, turn, +1)
    assert abs(a - 30) < 1e-9 and abs(abs(c) - 180) < 1e-9
    # Rx(-60): a=60, c=0 (A's limit is 50: not reachable) or a=-60, c=180; plus gives way to the other
    a, c = swivel.rotary_positions(machine, swivel.rotation(57, np.array([-60.0, 0.0, 0.0])), +1)
    assert abs(a + 60) < 1e-9 and abs(abs(c) - 180) < 1e-9
    with pytest.raises(swivel.Unknown, match="_DIR=0"):
        swivel.rotary_positions(machine, turn, 0)


OPENING = """N10 G54 G17 G71 G90
N20 G1 X0 Y0 Z0 F100
N30 G3 X10 Y10 AR=90
N40 G2 X20 Y0 AR=270
N50 G18 G2 X30 Z0 AR=180
N60 M30
"""


def test_opening_angle_arcs_by_hand(tmp_path):
    tp, path = _read(tmp_path, OPENING)
    assert tp.resolved.all()
    a = arcs.geometry(tp)
    # N30: chord (0,0)->(10,10) = 10 sqrt2, 90 deg: radius 10 sqrt2 / (2 sin 45) = 10; counter-clockwise the short
    # way: centre left of the chord, (0, 10) (start at -90 deg, end at 0 deg around it)
    # N40: (10,10)->(20,0), 270 deg clockwise (the long way): radius 10, centre (20, 10) (start 180 deg, end -90 deg)
    # N50: G18 (Z, X plane): (20,0,0)->(30,0,0), 180 deg: radius 5, centre Z=0 X=25 (in-plane (first, second) = (Z, X))
    np.testing.assert_allclose(a.centre, [(0, 10), (20, 10), (0, 25)], atol=1e-9)
    np.testing.assert_allclose(np.degrees(a.sweep()[1]), [90, -270, -180], atol=1e-9)
    np.testing.assert_allclose(tp.values[1:4, arcs.R_], [10, -10, 5], atol=1e-9)
    assert (tp.spans[1:4, arcs.R_, 1] < 0).all()  # the file's number is the angle: no radius to write there
    assert emit_texts(tp, tp)[0] == OPENING
    with pytest.raises(InputError, match=r"PART.MPF:3:.*opening angle AR="):
        arcs.refuse_uncompensable(tp)  # compensate refuses: it could not write a changed radius


def test_opening_angle_refusals(tmp_path):
    head = "N10 G54 G17 G71 G90\nN20 G1 X0 Y0 Z0 F100\n"
    for block, column, why in (("G3 I5 J0 AR=90", 4, "AR= with a centre"),
                               ("G3 X10 Y0 AR=R1", 11, "not a number"),
                               ("G3 X10 Y0 AR=360", 11, "between 0 and 360"),
                               ("G3 X0 Y0 AR=90", 10, "end point is its start"),
                               ("G1 X5 Y0 AR=90", 10, "not an arc")):
        with pytest.raises(ParseError) as exc:
            _read(tmp_path, head + f"N30 {block}\n")
        assert (exc.value.line, why in exc.value.message) == (3, True), exc.value
        assert exc.value.column == column + 4, (block, exc.value.column)


CIP_PROGRAM = """N10 G54 G17 G71 G90
N20 G1 X0 Y0 Z0 F100
N30 CIP X20 Y0 I1=10 J1=10 K1=0
N40 CIP X30 Y10 I1=30 J1=0 K1=0
N50 CIP X30 Y0 Z10 I1=30 J1=0 K1=0
N60 M30
"""


def test_circle_through_an_intermediate_point_by_hand(tmp_path):
    # Fundamentals, "Circular interpolation with intermediate and end points (CIP)": the circle through start,
    # intermediate and end point, in that order, in the plane of the three points.
    tp, path = _read(tmp_path, CIP_PROGRAM)
    assert tp.resolved.all()
    a = arcs.geometry(tp)
    # N30: (0,0) -> (10,10) -> (20,0): centre (10,0), over the top: clockwise 180 deg
    # N40: (20,0) -> (30,0) -> (30,10): centre (25,5) (equidistant, r = sqrt 50); angles 225 -> 315 -> 405: counter-clockwise 180 deg
    # N50: (30,10,0) -> (30,0,0) -> (30,0,10): all X = 30, the YZ plane (G19, in-plane (Y, Z)): centre (Y, Z) = (5, 5);
    #      seen from +X, about (5,5): start (10,0) at -45 deg, (0,0) at -135, end (0,10) at 135 (= -225): clockwise 180 deg
    np.testing.assert_allclose(a.centre, [(10, 0), (25, 5), (5, 5)], atol=1e-9)
    np.testing.assert_allclose(np.degrees(a.sweep()[1]), [-180, 180, -180], atol=1e-9)
    assert tp.extras["nc.arc"][1:4, 0].tolist() == [17, 17, 19]
    assert emit_texts(tp, tp)[0] == CIP_PROGRAM
    with pytest.raises(InputError, match=r"PART.MPF:3:.*intermediate point CIP"):
        arcs.refuse_uncompensable(tp)


def test_cip_refusals(tmp_path):
    head = "N10 G54 G17 G71 G90\nN20 G1 X0 Y0 Z0 F100\n"
    for block, column, why in (("CIP X20 Y0 I1=10 J1=10 K1=5", 5, "not parallel"),
                               ("CIP X20 Y0 I1=10 J1=0 K1=0", 5, "on a line"),
                               ("CIP X20 Y0 I1=10 J1=10", 5, "all three"),
                               ("CIP X20 Y0", 5, "without its intermediate point"),
                               ("CIP X20 Y0 I1=10 J1=10 K1=0\nN40 X30 Y10", 1, "continued")):
        with pytest.raises(ParseError) as exc:
            _read(tmp_path, head + f"N30 {block}\n")
        assert why in exc.value.message, exc.value
        assert (exc.value.line, exc.value.column) == (3 if column > 1 else 4, column), (block, exc.value)
