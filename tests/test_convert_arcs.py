"""convert writes G2/G3 arcs as the target language's circular moves (issue 12, "convert: arcs
written as arcs where the target language has them"), never as their chord.

KUKA KSS 8 "CIRC": the robot moves from the current position through the auxiliary point to
the end point on the circle the three points define; ABB RAPID reference "MoveC": likewise
through CirPoint to ToPoint. A full circle needs two such moves (three points of one move
must be distinct). LinuxCNC manual "G2, G3 Arc": centre = start + (I, J) in G17 (G91.1)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.programs import parse_program
from postproc.programs.ir import Kind

runner = CliRunner()
ARCS = """G21 G90 G17
G0 X0 Y0 Z5
G1 Z-1 F600
G2 X20 Y0 I10 J0
G3 X40 Y0 I10 J0
G2 I-5 J0
M2
"""


def _convert(tmp_path, text: str, to: str, out_name: str):
    src = tmp_path / "arcs.ngc"
    src.write_text(text)
    out = tmp_path / out_name
    return runner.invoke(app, ["convert", str(src), "--to", to, "-o", str(out), "--frame", "G54=0,0,0,0,0,0"]), out  # G54: the robot base


@pytest.mark.parametrize("to, name", [("krl", "arcs.src"), ("rapid", "arcs.mod")])
def test_arcs_become_circular_moves_through_points_of_the_intended_circle(tmp_path, to, name):
    res, out = _convert(tmp_path, ARCS, to, name)
    assert res.exit_code == 0, res.output
    tp = parse_program(out)
    via = np.nonzero(tp.kind == Kind.CIRC_VIA)[0]
    assert len(via) == 4  # two arcs, and the full circle in two halves
    # hand-worked: G2 from (0,0) about (10,0) clockwise passes (10,10) and ends at (20,0);
    # G3 from (20,0) about (30,0) counter-clockwise passes (30,-10) and ends at (40,0);
    # the full circle about (35,0) from (40,0) clockwise: (35,-5) at a quarter, (30,0) at half.
    expected = [((10, 10), (20, 0)), ((30, -10), (40, 0)), ((35, -5), (30, 0)), ((35, 5), (40, 0))]
    for row, (aux, end) in zip(via, expected):
        np.testing.assert_allclose(tp.position[row, :2], aux, atol=1e-3)
        np.testing.assert_allclose(tp.position[row + 1, :2], end, atol=1e-3)
        np.testing.assert_allclose(tp.position[[row, row + 1], 2], -1.0, atol=1e-9)


def test_a_helix_is_refused_with_its_line_not_written_as_a_chord(tmp_path):
    res, out = _convert(tmp_path, "G21 G90 G17\nG0 X0 Y0 Z0\nG2 X20 Y0 Z-2 I10 J0 F600\nM2\n", "krl", "helix.src")
    assert res.exit_code == 2
    assert re.search(r"\.ngc:3:\d+: a helical arc", res.output) and "--arc-tol" in res.output  # its place, and the remedy
    assert not out.exists() and not out.with_suffix(".dat").exists()

