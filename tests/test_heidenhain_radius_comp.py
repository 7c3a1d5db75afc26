"""Heidenhain Klartext RL / RR: the tool-centre path as the TNC cuts it.

Expected positions written by hand from the TNC 640 User's Manual (34059x-05), section 5.3
"Tool compensation": RL the tool left of the contour in the direction of travel, RR right;
compensation value R (TOOL DEF) + DR (TOOL CALL); "Outside corners: ... on a transitional
arc" about the programmed corner; "Inside corners: ... the intersection of the tool center
paths"; the block that opens RL / RR ends one radius beside its end point, perpendicular to
it; R0 ends the compensation, its block going from the compensated point to its programmed end.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

S2 = np.sqrt(2.0)


def read(text: str):
    return parse_program(Path("rc.h"), data=text.encode("latin-1"))


def program(*blocks: str, tool: str = "TOOL DEF 1 L+50 R+2\nTOOL CALL 1 Z S1000") -> str:
    return "BEGIN PGM RC MM\n" + tool + "\n" + "\n".join(blocks) + "\nEND PGM RC MM\n"


SQUARE_RL = program("L X-10 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 RL F100", "L X+20", "L Y+20", "L X+0", "L Y+0", "L X-10 Y-10 R0")


@pytest.mark.parametrize("marker", ["", " M3"])  # plain lines are read in bulk; an M word sends them block by block
def test_rl_inside_a_square(marker):
    """Counter-clockwise square, RL, R 2: the tool inside. Entry (-10,-10) -> (0,0) ends one
    radius left of (0,0), perpendicular to its direction (1,1)/sqrt2: (-sqrt2, sqrt2). The turn
    to +X at (0,0) is an outside corner for a tool on the left: a transitional arc about (0,0)
    (clockwise) to (0,2). The three square corners are inside: intersections (18,2) (18,18)
    (2,18). The last side (-Y) ends at (2,0), where R0 leaves it for (-10,-10)."""
    text = SQUARE_RL.replace("L X+20\n", f"L X+20{marker}\n")
    tp = read(text)
    np.testing.assert_allclose(tp.position[:, :2], [[-10, -10], [-S2, S2], [0, 2], [18, 2], [18, 18], [2, 18], [2, 0], [-10, -10]], atol=1e-9)
    assert tp.line.tolist() == [4, 5, 6, 6, 7, 8, 9, 10]
    assert tp.kind[2] == Kind.ARC_CW and tp.kind[3] == Kind.LINEAR
    np.testing.assert_allclose(tp.values[2, 19:21], [0, 0])  # the arc's centre: the programmed corner
    assert tp.ccomp.tolist() == [0, 1, 1, 1, 1, 1, 1, 0]
    assert tp.resolved.all() and (tp.position[:, 2] == 5).all()


def test_rr_outside_with_tool_call_dr():
    """RR, R 1.5 + DR 0.5 = 2 (5.3: compensation value R + DR TOOL CALL). Entry (0,-10) -> (0,0)
    going +Y ends at (2,0) (right of +Y is +X) but the turn to +X is an inside corner for a tool
    on the right: cut back to the intersection of X=2 and Y=-2. (20,0) turning to +Y is outside:
    (20,-2), a counter-clockwise transitional arc about (20,0) to (22,0), then (22,20)."""
    tp = read(program("L X+0 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 RR F100", "L X+20", "L Y+20", "L X+30 Y+30 R0",
                      tool="TOOL DEF 1 L+50 R+1.5\nTOOL CALL 1 Z S1000 DR+0.5 DR2+0.1"))
    np.testing.assert_allclose(tp.position[:, :2], [[0, -10], [2, -2], [20, -2], [22, 0], [22, 20], [30, 30]], atol=1e-9)
    assert tp.kind[3] == Kind.ARC_CCW and tp.line.tolist() == [4, 5, 6, 7, 7, 8]


def test_rl_along_a_circle():
    """RL over a clockwise half circle about CC (10,0) from (0,0) to (20,0): the tool on the left
    of +Y at (0,0) is outside the arc, so the offset arc has radius 12 and ends at (22,0); the
    tangent line down to (20,-10) ends at (22,-10). No corner (all tangent): no arc added."""
    tp = read(program("L X+0 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 RL F100", "CC X+10 Y+0", "C X+20 Y+0 DR-", "L X+20 Y-10",
                      "L X+30 Y-20 R0"))
    np.testing.assert_allclose(tp.position[:, :2], [[0, -10], [-2, 0], [22, 0], [22, -10], [30, -20]], atol=1e-9)
    assert tp.kind[2] == Kind.ARC_CW and tp.resolved.all()


def test_zero_tool_and_unknown_radius():
    """T0 is the zero tool, R 0 (5.2 Tool data): RL moves nothing. A tool from the tool table:
    its radius is not in the text: the targets stay as programmed, flagged, with a note."""
    tp = read(program("L X+0 Y+0 Z+5 R0 FMAX", "L X+10 RL F100", "L Y+10", "L X+0 Y+0 R0", tool="TOOL CALL 0 Z"))
    np.testing.assert_allclose(tp.position[:, :2], [[0, 0], [10, 0], [10, 10], [0, 0]])
    assert tp.resolved.all()
    tp = read(program("L X+0 Y+0 Z+5 R0 FMAX", "L X+10 RL F100", "L Y+10", "L X+0 Y+0 R0", tool="TOOL CALL 4 Z"))
    assert tp.resolved.tolist() == [True, False, False, True]
    assert any("tool table's radius" in n for n in tp.notes)


@pytest.mark.parametrize("blocks, line, column, words", [
    (("L X+0 Y+0 Z+5 R0 FMAX", "CC X+10 Y+0", "C X+20 Y+0 DR- RL F100"), 6, 16, "circle block"),
    (("L X+0 Y+0 Z+5 R0 FMAX", "L X+10 RL F100", "L Y+10 RR"), 6, 8, "R0 between"),
])
def test_what_the_tnc_refuses(blocks, line, column, words):
    """5.3: compensation cannot be opened in a circle block; RL to RR needs an R0 block between."""
    with pytest.raises(ParseError) as err:
        read(program(*blocks))
    assert (err.value.line, err.value.column) == (line, column), str(err.value)
    assert words in str(err.value)


def test_a_corner_the_tool_cannot_fit_is_flagged():
    """A slot narrower than the tool (1 mm wide, R 2, the tool inside on the left): the offset of
    the side X+10 Y+0 -> Y+1 would run backwards, the tool cannot cut it: the stretch stays as
    programmed, flagged, with the line and the reason."""
    tp = read(program("L X+0 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 RL F100", "L X+10", "L Y+1", "L X+0", "L X+0 Y-10 R0"))
    assert not tp.resolved[1:5].any() and tp.resolved[[0, -1]].all()
    np.testing.assert_allclose(tp.position[1:5, :2], [[0, 0], [10, 0], [10, 1], [0, 1]])
    assert tp.ccomp.tolist() == [0, 2, 2, 2, 2, 0]
    assert any("line 5: radius compensation RL" in n for n in tp.notes)


def test_round_trip_unchanged():
    tp = read(SQUARE_RL)
    assert emit_texts(tp, tp)[0] == SQUARE_RL


FIVE_AXIS_RL = program("L X+10 Y+10 Z+5 A-10 C+15 R0 FMAX", "L X+0 Y+0 A-10 C+15 RL F100", "L X+20 Y+0 A-10 C+15", "L X+20 Y+20 A-10 C+15",
                       "L X+0 Y+20 A-10 C+15", "L X+0 Y+0 A-10 C+15", "L X+10 Y+10 A-10 C+15 R0")


def _compensate(tmp_path, text: str):
    from typer.testing import CliRunner

    from postproc.cli import app

    source = tmp_path / "rl.h"
    source.write_text(text, encoding="latin-1")
    out = tmp_path / "out.h"
    res = CliRunner().invoke(app, ["compensate", str(source), "--model", str(TRUE), "-o", str(out), "--input-axes", "machine",
                                   "--frame", "PRESET=0,0,0,0,0,0"])
    return res, out


TRUE = Path(__file__).parent / "data" / "fivex" / "xyzac-trt-true.toml"


def test_compensate_rewrites_the_contour(tmp_path):
    """The text under RL holds the contour; compensate moves the tool-centre path, so it writes
    the contour whose offset path lands there: the square's corners stay the radius outside the
    compensated centre path (inside corners: (-2, 2) ... ; the last side's end: (2, 0) beside it), and the written program, read again, puts
    the tool where the compensation wants it (checked by compensate itself within 5 µm)."""
    res, out = _compensate(tmp_path, FIVE_AXIS_RL)
    assert res.exit_code == 0, res.output
    before, after = read(FIVE_AXIS_RL), read(out.read_text(encoding="latin-1"))
    np.testing.assert_allclose(after.values[1:6, :2] - before.values[1:6, :2], after.position[1:6, :2] - before.position[1:6, :2], atol=2e-3)
    assert np.abs(after.position[1:6, :2] - before.position[1:6, :2]).max() > 0.03  # it did move (the true machine's error)
    np.testing.assert_allclose(after.position[2:6, :2] - after.values[2:6, :2], [[-2, 2], [-2, -2], [2, -2], [2, 0]], atol=2e-3)


def test_compensate_refuses_a_modal_axis_under_rl(tmp_path):
    res, out = _compensate(tmp_path, FIVE_AXIS_RL.replace("L X+20 Y+0 A-10", "L X+20 A-10"))
    assert res.exit_code == 2 and "rl.h:6" in res.output and "write X and Y" in res.output, res.output
    assert not out.exists()


def test_a_contour_point_from_the_control_flags_its_stretch():
    """A contour point from an FN 18 value: the offset path is not computed from a guess."""
    tp = read(program("FN 18: SYSREAD Q5 = ID270 NR1 IDX1", "L X+0 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 RL F100", "L X+Q5", "L Y+10",
                      "L X+0 Y-10 R0"))
    assert tp.resolved.tolist() == [True, False, False, False, True]
    assert any("not determined by the text at line 7" in n for n in tp.notes), tp.notes


def test_ct_after_one_line_that_follows_an_arc():
    """CT is tangent to the element before it ("Path contours - Cartesian coordinates", CT): after
    C ... and one L X+0 from (20,20) the direction is -X, so the arc to (-5,15) has its centre
    below (0,20): (0,15), radius 5, counter-clockwise (a single plain L read in bulk once took
    the direction of an older line). Under RL (R 2.5) the tangent chain has no corner: the
    offset arcs end 2.5 inside, (20,17.5) and (-2.5,15), and no transitional arc is added."""
    body = ("L X-10 Y-10 Z+5 R0 FMAX", "L X+0 Y+0 {c}F100", "L X+20", "CC X+20 Y+10", "C X+20 Y+20 DR+", "L X+0", "CT X-5 Y+15",
            "L Y+0", "L X-10 Y-10 R0")
    tp = read(program(*[b.format(c="") for b in body]))
    np.testing.assert_allclose(tp.values[5, 19:21], [0, 15])
    assert tp.kind[5] == Kind.ARC_CCW
    tp = read(program(*[b.format(c="RL ") for b in body], tool="TOOL DEF 1 L+50 R+2\nTOOL CALL 1 Z S1000 DR+0.5"))
    np.testing.assert_allclose(tp.position[:, :2], [[-10, -10], [-2.5 / S2, 2.5 / S2], [0, 2.5], [20, 2.5], [20, 17.5], [0, 17.5],
                                                    [-2.5, 15], [-2.5, 0], [-10, -10]], atol=1e-9)
