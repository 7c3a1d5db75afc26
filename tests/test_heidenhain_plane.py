"""Heidenhain PLANE SPATIAL: which of the two rotary solutions the TNC takes, on the
table-table machines of machines/*.toml.

Expected values written by hand from the TNC 640 User's Manual, "Tilting the working plane":
PLANE SPATIAL turns the plane by SPA about X, SPB about Y, SPC about Z (fixed axes); "SEQ+
positions the master axis so that it assumes a positive angle" (the master axis: "the last
rotary axis from the table", A of xyzac-trt, B of xyzbc-trt), SEQ- negative; without SEQ the
solution within the traverse range, the shorter way where both are; "Angle not permitted"
where none is. MOVE turns the rotary axes about the tool tip.

The machines turn the TABLE right-handed by +angle (machines/*.toml): machine = Rx(A) Rz(C)
workpiece on xyzac-trt. SPA+30 tilts the tool axis to u = Rx(30) z = (0, -0.5, 0.866) in the
workpiece; Rx(A) Rz(C) u = z for (A-30, C0) and for (A+30, C180) (Rz(180) u = (0, 0.5, 0.866)).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.program import from_toolpath
from postproc.programs import dialects, parse_program

S3 = np.sqrt(3.0)


def tilted(plane: str, before: str = "A+0 C+0"):
    text = (f"BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+0 Y+0 Z+50 {before} R0 FMAX\n{plane}\n"
            "L X+10 Y+0 Z+5 FMAX\nL X+10 Y+10 Z+0 F100\nPLANE RESET STAY\nEND PGM P MM\n")
    return parse_program(Path("p.h"), data=text.encode("latin-1")).with_frames({"PRESET": np.eye(4)}, None)


def solve(plane: str, machine: str = "xyzac-trt", before: str = "A+0 C+0"):
    return _placed(tilted(plane, before), machine)


def _placed(tp, machine):
    return dialects.of(tp).for_machine(tp, load_machine(machine))


def _angles(tp, letters="AC"):
    return tp.ext[1:, ["ABC".index(k) for k in letters]]


@pytest.mark.parametrize("plane, before, want", [
    ("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ MOVE", "A+0 C+0", (30, -180)),  # master A positive: the C180 solution
    ("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ- MOVE", "A+0 C+0", (-30, 0)),
    ("PLANE SPATIAL SPA+30 SPB+0 SPC+0 MOVE", "A+0 C+0", (-30, 0)),  # no SEQ: 30 deg of travel against 30 + 180
    ("PLANE SPATIAL SPA+30 SPB+0 SPC+0 MOVE", "A+10 C+170", (30, 180)),  # no SEQ: 20 + 10 against 40 + 170
    ("PLANE SPATIAL SPA+60 SPB+0 SPC+0 MOVE", "A+0 C+0", (-60, 0)),  # A+60 is past A's limit (+50): the one left
])
def test_rotary_solution_on_xyzac_trt(plane, before, want):
    tp = solve(plane, before=before)
    assert tp.resolved.all(), tp.notes
    np.testing.assert_allclose(_angles(tp), [want] * 3, atol=1e-9)
    # positions in the untilted workpiece frame: Rx(30) (10, 0, 5) and Rx(30) (10, 10, 0); MOVE keeps the tip at (0, 0, 50)
    if "SPA+30" in plane:
        np.testing.assert_allclose(tp.position, [[0, 0, 50], [0, 0, 50], [10, -2.5, 2.5 * S3], [10, 5 * S3, 5]], atol=1e-9)
        assert (tp.frame == 0).all()


def test_the_tool_axis_of_the_solution_is_the_tilted_plane_normal():
    """Read as a five-axis path, the machine's forward kinematics at the chosen angles give the
    tilted plane's normal as the tool axis: u = (0, -0.5, sqrt3/2)."""
    tp = tilted("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ MOVE")
    path = from_toolpath(tp, load_machine("xyzac-trt"), "tip")
    np.testing.assert_allclose(path.axis[1:], [[0, -0.5, S3 / 2]] * 3, atol=1e-9)
    np.testing.assert_allclose(path.tip[2], [10, -2.5, 2.5 * S3], atol=1e-9)


def test_xyzbc_trt_master_axis_b():
    """xyzbc-trt: B turns the table about Y (master), C on it. SPB+30: u = Ry(30) z = (0.5, 0, sqrt3/2);
    Ry(B) Rz(C) u = z for (B-30, C0) and (B+30, C180)."""
    np.testing.assert_allclose(_angles(solve("PLANE SPATIAL SPA+0 SPB+30 SPC+0 SEQ- MOVE", "xyzbc-trt", "B+0 C+0"), "BC"), [(-30, 0)] * 3, atol=1e-9)
    np.testing.assert_allclose(_angles(solve("PLANE SPATIAL SPA+0 SPB+30 SPC+0 SEQ+ MOVE", "xyzbc-trt", "B+0 C+0"), "BC"), [(30, -180)] * 3, atol=1e-9)


def test_angle_not_permitted():
    """SEQ+ asks for A+60, past A's limit (+50): the TNC stops with "Angle not permitted"."""
    with pytest.raises(InputError, match=r"p\.h:4: Angle not permitted"):
        solve("PLANE SPATIAL SPA+60 SPB+0 SPC+0 SEQ+ MOVE")


@pytest.mark.parametrize("plane, machine, why", [
    ("PLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ STAY", "xyzac-trt", "do not stand in the tilted plane"),  # STAY: no block positions the axes
    ("PLANE SPATIAL SPA+0 SPB+30 SPC+0 SEQ+ TURN", "xyzbc-5axiskins", "the tip swings by the tool length"),
])
def test_what_the_manual_leaves_to_the_machine_stays_flagged(plane, machine, why):
    tp = solve(plane, machine, "B+0 C+0" if "b" in machine[:4] else "A+0 C+0")
    assert not tp.resolved[1:].any()
    assert any(why in n for n in tp.notes), tp.notes


def test_without_seq_and_no_start_position_stays_flagged():
    tp = _placed(parse_program(Path("p.h"), data=b"BEGIN PGM P MM\nL X+0 Y+0 Z+50 R0 FMAX\nPLANE SPATIAL SPA+30 SPB+0 SPC+0 MOVE\n"
                                                  b"L X+10 Y+0 Z+5 FMAX\nEND PGM P MM\n").with_frames({"PRESET": np.eye(4)}, None), "xyzac-trt")
    assert not tp.resolved[1:].any() and any("shorter way" in n for n in tp.notes)


def test_compensate_refuses_a_tilted_plane_and_convert_to_m128_is_the_way(tmp_path):
    """A correction of a tilted plane's targets would change the PLANE's angles (and the TNC's
    solution), not its blocks' numbers: refused with the PLANE's line. Converted to M128 (tool tip
    + axis positions), the same path is compensated."""
    from typer.testing import CliRunner

    from postproc.cli import app

    runner, true = CliRunner(), Path(__file__).parent / "data" / "fivex" / "xyzac-trt-true.toml"
    source = tmp_path / "p.h"
    source.write_text("BEGIN PGM P MM\nTOOL CALL 1 Z S1000\nL X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\nPLANE SPATIAL SPA+30 SPB+0 SPC+0 SEQ+ MOVE\n"
                      "L X+10 Y+0 Z+5 FMAX\nL X+10 Y+10 Z+0 F100\nPLANE RESET STAY\nEND PGM P MM\n", encoding="latin-1")
    common = ["--input-axes", "tip", "--frame", "PRESET=0,0,0,0,0,0"]
    res = runner.invoke(app, ["compensate", str(source), "--model", str(true), "-o", str(tmp_path / "c.h"), *common])
    assert res.exit_code == 2 and "p.h:4: targets in a tilted working plane" in res.output, res.output
    res = runner.invoke(app, ["convert", str(source), "--to", "heidenhain", "--machine", "xyzac-trt", "--rtcp", "tcpm", "-o", str(tmp_path / "m.h"), *common])
    assert res.exit_code == 0 and "rotary solution A+30.0000 C-180.0000 (SEQ+)" in res.output, res.output
    res = runner.invoke(app, ["compensate", str(tmp_path / "m.h"), "--model", str(true), "-o", str(tmp_path / "mc.h"), *common])
    assert res.exit_code == 0, res.output
