"""SINUMERIK SCALE / ASCALE / MIRROR / AMIRROR (postproc/programs/dialects/sinumerik/frames.py, scaled.py).

Expected tool-tip positions worked out by hand from the 840D sl Fundamentals programming
manual (6FC5398-1BP40), "Coordinate transformations (frames)": a point p at
``settable @ programmable @ p``; "Programmable scaling factor (SCALE, ASCALE)": factors per
axis in the current coordinate system, "if ATRANS is programmed with SCALE/ASCALE active,
these offset values are also scaled", the same factor in both axes for circles;
"Programmable mirroring (MIRROR, AMIRROR)": the named axes mirrored (the value has no
meaning), G2/G3 swapped under a mirror of one axis of the plane.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.arcs import geometry
from postproc.programs.ir import Kind

MIRRORED = """N10 G54 G17 G71 G90
N20 G0 X0 Y0 Z5
N30 MIRROR X0
N40 G1 X10 Y5 Z0 F100
N50 G2 X20 Y5 I5 J0
N60 SCALE X2 Y2
N70 G1 X10 Y5 Z1
N80 G3 X20 Y5 CR=5
N90 ATRANS X1
N100 G1 X0 Y0 Z1
N110 AMIRROR Y0
N120 G1 X1 Y1 Z1
N130 AROT RPL=90
N140 G1 X1 Y0 Z1
N150 MIRROR
N160 G1 X1 Y1 Z1
N170 M30
"""
# By hand, in G54 (rules in the module docstring):
EXPECTED = [
    (0, 0, 5),  # N20: no programmable frame
    (-10, 5, 0),  # N40: MIRROR X0 -> x turned round
    (-20, 5, 0),  # N50: the end point mirrored; the arc (G2 in the file) runs G3 in G54
    (20, 10, 1),  # N70: SCALE (absolute: the mirror deleted) X2 Y2
    (40, 10, 1),  # N80
    (2, 0, 1),  # N100: ATRANS X1 under SCALE 2: the offset scaled, 2
    (4, -2, 1),  # N120: AMIRROR Y0 in that frame: (2*1 + 2, -(2*1))
    (2, -2, 1),  # N140: AROT 90 in the mirrored-Y frame: local (1,0) -> (0,1) -> scaled, mirrored (0,-2), + (2,0)
    (1, 1, 1),  # N160: MIRROR without axes deletes the whole programmable frame
]


def _read(tmp_path: Path, text: str):
    path = tmp_path / "PART.MPF"
    path.write_bytes(text.encode("latin-1"))
    return parse_program(path), path


def test_scaled_and_mirrored_positions_are_the_hand_worked_ones(tmp_path):
    tp, path = _read(tmp_path, MIRRORED)
    np.testing.assert_allclose(tp.base_positions(), EXPECTED, atol=1e-12)
    assert tp.resolved.all()
    assert emit_texts(tp, tp)[0].encode("latin-1") == path.read_bytes()  # byte-identical round trip


def test_mirrored_arc_runs_the_other_way_and_a_scaled_radius_grows(tmp_path):
    tp, _ = _read(tmp_path, MIRRORED)
    assert tp.kind[2] == Kind.ARC_CCW and tp.kind[4] == Kind.ARC_CCW  # N50 G2 under MIRROR X: G3 in G54; N80 G3 scaled: G3
    arcs = geometry(tp)
    centre = {int(r): c for r, c in zip(arcs.rows, arcs.centre)}
    np.testing.assert_allclose(centre[2], (-15, 5))  # centre X=15 mirrored
    np.testing.assert_allclose(np.linalg.norm(centre[4] - (20, 10)), 10.0)  # CR=5 under SCALE 2: radius 10
    assert arcs.ccw[list(arcs.rows).index(2)]


def test_numbers_written_back_are_the_text_the_840d_scales_again(tmp_path):
    tp, path = _read(tmp_path, MIRRORED)
    moved = tp.position.copy()
    moved[1] += (0.5, 0.0, 0.0)  # N40: 0.5 mm further in +X of G54 -> under MIRROR X the text's X goes to 9.5
    moved[3] += (0.0, 1.0, 0.0)  # N70: 1 mm in +Y under SCALE 2 -> Y 5.5
    out = emit_texts(tp, tp.with_positions(moved))[0]
    lines = out.splitlines()
    assert lines[3] == "N40 G1 X9.5 Y5 Z0 F100" and lines[6] == "N70 G1 X10 Y5.5 Z1"
    back = parse_program(path.with_name("OUT.MPF"), data=out.encode("latin-1"))
    np.testing.assert_allclose(back.position, moved, atol=1e-9)  # as placed: read back where compensate put them


@pytest.mark.parametrize("text, line, why", [
    ("G0 X0 Y0 Z0\nSCALE X2 Y3\nG2 X2 Y0 Z0 CR=1 F10\n", 3, "not a circle"),
    ("G0 X0 Y0 Z0\nN20 MIRROR X0\nG1 X1 F10\n", 3, "leaves out X, Y or Z"),
    ("G0 X0 Y0 Z0\nSCALE X2 Y3\nAROT Z30\n", 3, "sheared"),
    ("G0 X0 Y0 Z0\nSCALE X0\n", 2, "factor 0"),
    ("G0 X0 Y0 Z0\nMIRROR X0\nG1 X1 Y0 Z0 F10\nG91 G1 X1 Y0 Z0\n", 4, "G91"),
    ("G0 X0 Y0 Z0\nMIRROR X0\nG93 G1 X1 Y0 Z0 F10\n", 3, "G93"),
    ("G0 X0 Y0 Z0\nMIRROR X0\nG41 G1 X1 Y0 Z0 D1 F10\nG40 G1 X6 Y0 Z0\n", 2, "cutter radius compensation"),
    ("TRAORI\nG1 X0 Y0 Z0 A0 C0 F10\nMIRROR X0\nG1 X1 Y0 Z0 A0 C0\n", 4, "tool orientation"),
])
def test_what_the_manual_does_not_define_is_refused(tmp_path, text, line, why):
    with pytest.raises(ParseError) as exc:
        _read(tmp_path, text)
    assert exc.value.line == line and why in str(exc.value)


def test_uniform_scale_arc_in_another_plane_and_helix(tmp_path):
    # G18 (Z X plane): MIRROR Z0 swaps the arc; Y (the helix axis) scaled by its own factor
    tp, _ = _read(tmp_path, "G18 G0 X0 Y0 Z0\nSCALE Y3\nAMIRROR Z0\nG2 X10 Y1 Z0 CR=5 F10\n")
    assert tp.kind[1] == Kind.ARC_CCW
    np.testing.assert_allclose(tp.base_positions()[1], (10, 3, 0))


def test_a_mirror_holds_through_a_jump_loop(tmp_path):
    # the flow reader (labels, GOTOB): the factors follow the executed blocks
    tp, _ = _read(tmp_path, "G0 X0 Y0 Z0\nMIRROR X0\nR1=0\nLOOP: G1 X=R1+1 Y0 Z0 F10\nR1=R1+1\nIF R1<3 GOTOB LOOP\nMIRROR\nG1 X1 Y1 Z1\n")
    np.testing.assert_allclose(tp.base_positions(), [(0, 0, 0), (-1, 0, 0), (-2, 0, 0), (-3, 0, 0), (1, 1, 1)])
