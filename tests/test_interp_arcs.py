"""G2/G3 arcs in programs read block by block (interp.py: G92 / G52, G10 L2 ... R / L20, G53,
canned cycles, O-word flow with G10): each arc carries its I J K / R words, plane, IJK mode
and turns as the vectorised reader gives them, so that its centre is the one LinuxCNC's
interpreter computes (rs274's ARC_FEED; issue 12 "G17/G18/G19 arcs with I J K and R",
"G90.1/G91.1", "G10 L2/L20 work offsets", "G92"), and compensate / convert accept it.

The programs are ours; rs274's output for each is kept in tests/data/rs274/interp_arcs/
(regenerate: python tests/test_interp_arcs.py --record) and checked against a fresh run
where rs274 is installed. rs274 prints ARC_FEED(first_end, second_end, first_axis,
second_axis, rotation, axis_end, ...) in program coordinates: the centre is (first_axis,
second_axis), rotation's sign is the direction (+1 G3) and its size the turns (P).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from rs274_recordings import Recordings
from test_arcs import _rs274_arcs
from test_real_corpus import _moves, canonical_endpoints, corpus_file, machine_positions

from postproc.errors import ParseError
from postproc.programs import arcs, parse_program
from postproc.programs.dialects.gcode import interp
from postproc.programs.ir import Kind

RECORDED = Path(__file__).parent / "data" / "rs274" / "interp_arcs"

PROGRAMS = {
    # G10 L2 with R30 (rotated G54), G92 between arcs, G90.1 centre under G92, G92.1, R < 0
    "g10r_g92": "G21 G90 G17\nG10 L2 P1 X10 Y20 Z5 R30\nG54\nG0 X0 Y0 Z10\nG1 X5 F100\nG2 X15 Y0 I5 J0\nG92 X0 Y0\nG3 X10 Y0 R5\n"
                "G90.1\nG2 X0 Y0 I5 J0\nG91.1\nG92.1\nG3 X-5 Y0 R-10\nM2\n",
    # G52 local offset; G18 (Z X) and G19 (Y Z) arcs in both formats; a full circle (no end words)
    "g52_planes": "G21 G90 G17 F200\nG0 X1 Y2 Z3\nG52 X100 Y-50 Z10\nG1 X0 Y0 Z0\nG18 G2 X20 Z0 I10 K0\nG3 X10 Z10 R10\n"
                  "G19 G2 Y10 Z0 J0 K-10\nG3 Y0 Z10 J-10 K0\nG17 G2 I5 J0\nG52 X0 Y0 Z0\nG1 X0 Y0 Z0\nM2\n",
    # inch, G10 L20 P2 (G55 origin from the current point), full circle, two turns (P2), G91 arc
    "g10l20_inch": "G20 G90 G17 F10\nG0 X0 Y0 Z1\nG10 L20 P2 X1 Y1 Z0\nG55\nG1 X2 Y1\nG2 X3 Y2 I0 J1\nG3 I-0.5 J0\n"
                   "G2 X2 Y1 R1 P2\nG91\nG3 X-1 Y-1 I-1 J0\nG90\nG54\nG1 X0 Y0\nM2\n",
    # arcs after a canned cycle (they start at its last retract), G91 arc end
    "cycle_arcs": "G21 G90 G17 F100\nG0 X0 Y0 Z10\nG98 G81 X5 Y5 Z-2 R2\nX15\nG80\nG2 X25 Y5 I5 J0\nG91 G3 X-10 Y0 R5\nG90 G1 X0 Y0\nM2\n",
    # G53 moves (machine coordinates) before arcs in an offset G54
    "g53_arc": "G21 G90 G17 F100\nG10 L2 P1 X50 Y60 Z-5\nG54 G0 X0 Y0 Z5\nG53 G0 Z0\nG1 X10 Y0\nG53 G1 X70 Y60\nG3 X20 Y20 R10\n"
               "G2 X10 Y10 I-10 J0\nM2\n",
    # O-word repeat (flow.py) in a G54 rotated by 90 degrees; a full circle in R format is refused, so this one is I J
    "flow_g10_arcs": "G21 G90 G17 F100\nG10 L2 P1 X100 Y0 Z0 R90\nG0 X0 Y0 Z0\n#1 = 0\no100 repeat [3]\n  G2 X[#1 + 10] Y0 I5 J0\n"
                     "  #1 = [#1 + 10]\no100 endrepeat\nG91.1 G3 X0 Y0 R15\nM2\n",
}


RECORDINGS = Recordings(PROGRAMS, RECORDED)
_program = RECORDINGS.write


def _read_block_by_block(path: Path):
    """The program as the block-by-block reader gives it (even where the vectorised one would do)."""
    with mock.patch.object(interp, "needs_interpreter", lambda t: True):
        return parse_program(path)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_arc_centres_turns_and_ends_equal_rs274s(name, tmp_path):
    tp = parse_program(_program(tmp_path, name))
    text = (RECORDED / f"{name}.canon").read_text(encoding="latin-1")
    centres, turns = _rs274_arcs(text)
    geo = arcs.geometry(tp)
    assert len(geo.rows) == len(centres) > 0
    # rs274 prints 4 decimals of the program unit
    tol = 5e-5 * (25.4 if "INCHES" in text else 1.0) + 1e-9
    np.testing.assert_allclose(geo.centre, centres, atol=tol)
    np.testing.assert_array_equal(np.where(geo.ccw, 1.0, -1.0) * tp.extras["nc.arc"][geo.rows, 2], turns)
    canon, ctol, carc = canonical_endpoints(text)
    keep = _moves(canon, ctol, carc)
    machine = machine_positions(tp)
    rows = _moves(machine, np.full(len(tp), 1e-9), np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)))
    assert len(rows) == len(keep)
    np.testing.assert_allclose(machine[rows], canon[keep], atol=2 * tol + 1e-6)


def test_hand_worked_centres_under_a_rotated_g54_and_g92(tmp_path):
    """LinuxCNC manual, "G2, G3 Arc Feed" and "Coordinate Systems": I J (G91.1) are offsets from
    the arc's start in program coordinates, under G90.1 the centre's program coordinates; a
    program point p is at machine rotate_R(p + G92) + origin. g10r_g92, line 10: `G90.1 G2 X0
    Y0 I5 J0` under G92 X15 (set at line 7 where the tool was at X15) and G54 = (10, 20, 5) R30:
    centre (5, 0) in program coordinates -> rotate_30((20, 0)) + (10, 20) = (27.3205, 30)."""
    tp = parse_program(_program(tmp_path, "g10r_g92"))
    described = arcs.describe(tp)
    row = int(np.nonzero(tp.line == 10)[0][0])
    np.testing.assert_allclose(described[row]["centre"], [10 + 20 * np.cos(np.radians(30)), 20 + 20 * np.sin(np.radians(30)), 15.0], atol=1e-9)
    assert described[row]["radius"] == pytest.approx(5.0)
    assert tp.extras["nc.arc"][row].tolist() == [17.0, 1.0, 1.0]


# A G-code file of the corpus with arcs, read by the vectorised reader: the block-by-block
# reader must give exactly the same toolpath.
VECTORISED = ["gcode/CauldronDevelopmentLLC_CAMotics__heart.ngc", "gcode/LinuxCNC_linuxcnc__cds.ngc",
              "gcode/winder_Universal-G-Code-Sender__arc_rword_test.gcode", "gcode/shooshx_led_floor__1101_bore_tests.nc"]


@pytest.mark.parametrize("name", VECTORISED)
def test_the_block_by_block_reader_gives_the_vectorised_readers_arcs(name):
    fast = parse_program(corpus_file(name))
    slow = _read_block_by_block(corpus_file(name))
    assert "nc.arc" in fast.extras and len(fast) == len(slow)
    for field in ("kind", "line", "position", "values", "spans", "scale", "frame", "resolved"):
        np.testing.assert_array_equal(getattr(slow, field), getattr(fast, field), err_msg=field)
    np.testing.assert_array_equal(slow.extras["nc.arc"], fast.extras["nc.arc"], err_msg="nc.arc")


# Real programs read block by block (canned cycles, G92) with arcs: centres equal the recordings.
REAL_BLOCK_BY_BLOCK = ["gcode/LinuxCNC_linuxcnc__mmount.ngc", "gcode/LinuxCNC_linuxcnc__ccomp_mill-g90g91g92.ngc"]


@pytest.mark.parametrize("name", REAL_BLOCK_BY_BLOCK)
def test_real_programs_read_block_by_block_have_rs274s_centres(name):
    from test_real_corpus import RECORDINGS

    spy = mock.Mock(wraps=interp.run)
    with mock.patch.object(interp, "run", spy):
        tp = parse_program(corpus_file(name))
    assert spy.called  # this program does need the block-by-block reader
    text = (RECORDINGS / (Path(name).name + ".txt")).read_text(encoding="latin-1")
    centres, turns = _rs274_arcs(text)
    geo = arcs.geometry(tp)
    assert len(geo.rows) == len(centres) > 0
    np.testing.assert_allclose(geo.centre, centres, atol=2 * (5e-5 * (25.4 if "INCHES" in text else 1.0)) + 1e-6)
    np.testing.assert_array_equal(np.where(geo.ccw, 1.0, -1.0), np.sign(turns))


@pytest.mark.parametrize("text, line, column, message", [
    ("G21 G90\nG92 X0\nG1 X0 Y0\nG2 R5\n", 4, 5, "radius-format arc"),
    ("G21 G90\nG92 X0\nG1 X0 Y0\nG17 G2 X1 Y1 K1\n", 4, 15, "not a centre word of the G17 plane"),
    ("G21 G90\nG92 X0\nG1 X0 Y0\nG53 G2 X1 Y1 I1\n", 4, 1, "G53 moves in machine coordinates with G0 or G1 only"),
])
def test_arcs_the_controller_refuses_are_refused_block_by_block_too(tmp_path, text, line, column, message):
    prog = tmp_path / "bad.ngc"
    prog.write_text(text)
    with pytest.raises(ParseError, match=message) as err:
        parse_program(prog)
    assert (err.value.line, err.value.column) == (line, column)


test_rs274_recordings_are_current = RECORDINGS.freshness_test()


if __name__ == "__main__":
    RECORDINGS.record_if_asked(sys.argv)


# ------------------------------------------------------------------ compensate and convert accept them

from test_arcs import BODY, H1, START, WORK, _off_the_intended_arcs, model  # noqa: E402,F401  (model: the fixture)

from postproc.jobs.compensate import compensate  # noqa: E402
from postproc.programs import emit_texts, write_program  # noqa: E402

G92_HEAD = "G21 G90 G17 G54\nG43.5 H1\nG1 X0 Y0 Z0 I0 J0 K1 F500\nG92 X10 Y0\n"  # G92: read block by block


def test_compensated_arcs_under_g92_pass_the_intended_ones(tmp_path, model):
    """As tests/test_arcs.py's arcs, under G92 (the frame G54 + G92 offset): compensation
    accepts them and the re-parsed output puts the robot on the intended arcs."""
    prog = tmp_path / "g92arcs.ngc"
    prog.write_text(G92_HEAD + BODY + "M30\n")
    tp = parse_program(prog)
    assert "nc.arc" in tp.extras and tp.frame_names[tp.frame[-1]] == "G54+G92@line4"
    new, report = compensate(tp, model, frames={"G54": WORK}, tools={"H1": H1}, start_joints=START)
    assert not report.failed.any(), report.failures()
    out = tmp_path / "out.ngc"
    out.write_bytes(emit_texts(tp, new)[0].encode("latin-1"))
    _, got, before, after = _off_the_intended_arcs(model, tp, out)
    assert before.max() > 0.5 and after[~got.full].max() < 0.03, after.max(axis=1)


def test_converted_arcs_pass_rs274s_circles(tmp_path):
    """convert: each G2/G3 of a program read block by block becomes a KRL CIRC whose via and end
    points lie on rs274's circle (centre and radius from its ARC_FEED), in the machine frame."""
    from postproc.robot.frames import abc_to_matrix

    tp = parse_program(_program(tmp_path, "g53_arc"))  # G54 set by G10 L2; G53 moves; an R and an I J arc
    src, _ = write_program(tp, "krl", "conv")
    base, points = np.eye(4), []
    for line in src.splitlines():
        frames = [[float(v) for v in re.findall(r"[XYZABC] (-?[\d.]+)", f)] for f in re.findall(r"\{([^}]*)\}", line)]
        if line.startswith("$BASE"):
            base = np.eye(4)
            base[:3, :3], base[:3, 3] = abc_to_matrix(np.array(frames[0][3:])[None])[0], frames[0][:3]
        elif line.startswith("CIRC"):
            points.append([(base @ np.r_[f[:3], 1.0])[:3] for f in frames])
    text = (RECORDED / "g53_arc.canon").read_text(encoding="latin-1")
    centres, _ = _rs274_arcs(text)
    g54 = np.array([50.0, 60.0])  # SET_G5X_OFFSET(1, 50, 60, -5, ...) in the recording
    assert len(points) == len(centres) == 2
    for (via, end), centre in zip(points, centres + g54):
        radius = np.linalg.norm(end[:2] - centre)
        assert np.linalg.norm(via[:2] - centre) == pytest.approx(radius, abs=2e-4)
        assert radius == pytest.approx(10.0, abs=2e-4)
