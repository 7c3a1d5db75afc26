"""Five-axis G-code programs read through their work offsets and tool lengths, or refused
(issue 12, "G-code work offsets and tool length"; postproc/fivex/offsets.py).

The five-axis kinematics work in the machine frame with the rotary axes at zero (the rotary
axes' points in machines/*.toml are there). The controller puts a program point there with
the work offset in force (LinuxCNC manual, "Coordinate Systems": machine = rotate_R(p + G92)
+ G5x origin); a head machine turns the tool about a pivot gauge_to_tip + the G43 tool length
above the tip (LinuxCNC 5axiskins: tip = joints + (0, 0, L) + L (sin b cos c, sin b sin c,
-cos b), L the pivot length plus the tool offset). An offset or length the program does not
give is taken from --frame / --tool or the job is refused with file:line:column.

Hand-worked numbers (xyzac-trt: A about +X through (0, 20, 10), C about +Z through the origin;
a positive angle turns the table right-handed, so a machine point m is at Rx(-a)(m - p) + p
on the table for C 0):
- machine axes X0 Y20 Z10 A-90 C0 in G54 = (0, -20, -10): machine point (0, 0, 0); m - p =
  (0, -20, -10); Rx(-90) takes (y, z) to (z, -y) = (-10, 20); + p: tip (0, 10, 30), tool axis
  Rx(-90) (0, 0, 1) = (0, 1, 0). Read with G54 as the identity it would be the pivot (0, 20, 10).
- tip X10 Y0 Z5 in G54 = origin 0 turned R90: (0, 10, 5).
- xyzbc-5axiskins (gauge 250): machine axes X0 Y0 Z0 C0 B90 under a 50 mm tool: L = 300,
  tip (0, 0, 300) + 300 (1, 0, 0) = (300, 0, 300); with no length (G49): (250, 0, 250).
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.fivex.machine import load_machine
from postproc.fivex.program import from_toolpath
from postproc.programs import parse_program

runner = CliRunner()
TRT = "G21 G90 G94\n{setup}G54 G0 X0 Y20 Z10 A-90 C0\nG1 X0 Y20 Z10 A-90 C0 F100\nM2\n"


def _tips(text: str) -> np.ndarray:
    """X Y Z of the G0/G1 blocks of an emitted LinuxCNC TCP program."""
    rows = [[float(v) for v in re.findall(r"[XYZ](-?[\d.]+)", line)] for line in text.splitlines() if re.match(r"G[01] X", line)]
    return np.array(rows)


def _convert(tmp_path, text: str, *options: str, machine: str = "xyzac-trt"):
    src, out = tmp_path / "in.ngc", tmp_path / "out.ngc"
    src.write_text(text)
    res = runner.invoke(app, ["convert", str(src), "--to", "gcode", "--machine", machine, "--rtcp", "linuxcnc", "--input-axes", "machine", "-o", str(out), *options])
    return res, out


@pytest.mark.parametrize("setup, options", [("G10 L2 P1 X0 Y-20 Z-10\n", ()), ("", ("--frame", "G54=0,-20,-10,0,0,0"))])
def test_machine_axes_are_read_through_the_work_offset(tmp_path, setup, options):
    res, out = _convert(tmp_path, TRT.format(setup=setup), *options)
    assert res.exit_code == 0, res.output
    np.testing.assert_allclose(_tips(out.read_text()), [[0, 30, -10]] * 2, atol=1e-3)
    tp = parse_program(tmp_path / "in.ngc").with_frames({"G54": np.array([[1, 0, 0, 0], [0, 1, 0, -20], [0, 0, 1, -10], [0, 0, 0, 1.0]])}) if not setup \
        else parse_program(tmp_path / "in.ngc")
    path = from_toolpath(tp, load_machine("xyzac-trt"), "machine")
    np.testing.assert_allclose(path.tip, [[0, 30, -10]] * 2, atol=1e-9)
    np.testing.assert_allclose(path.axis, [[0, -1, 0]] * 2, atol=1e-12)


def test_an_offset_the_program_does_not_set_is_refused(tmp_path):
    res, out = _convert(tmp_path, TRT.format(setup=""))
    assert res.exit_code == 2 and not out.exists()
    assert "in.ngc:2:9:" in res.stderr and "--frame G54=" in res.stderr  # the G0 block, its first number


def test_the_work_offsets_turn_is_applied(tmp_path):
    """G10 L2 P1 R90: program X10 Y0 Z5 (tip, RTCP) is at machine (0, 10, 5)."""
    text = "G21 G90 G94\nG10 L2 P1 X0 Y0 Z0 R90\nG54 G0 X10 Y0 Z5 A0 C0\nM2\n"
    src = tmp_path / "in.ngc"
    src.write_text(text)
    path = from_toolpath(parse_program(src), load_machine("xyzac-trt"), "tip")
    np.testing.assert_allclose(path.tip, [[0, 10, 5]], atol=1e-12)


@pytest.mark.parametrize("text, where", [
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0 A10\nG54 G0 X0 Y0 Z5 A0 C0\nM2\n", ":2:20:"),  # a rotary offset shifts the angles: not followed
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\nG54 G0 X0 Y0 Z5 A0 C0\nG92 C5\nG1 X1 F100\nM2\n", ":4:5:"),
    ("G21 G90 G94\nN10G10L2P1X0Y0Z0 (A0) C5\nG54 G0 X0 Y0 Z5 A0 C0\nM2\n", ":2:23:"),  # compact, after a comment naming A
])
def test_rotary_work_offsets_are_refused(tmp_path, text, where):
    res, out = _convert(tmp_path, text)
    assert res.exit_code == 2 and where in res.stderr and not out.exists(), res.output


def test_a_tilted_frame_is_refused(tmp_path):
    res, out = _convert(tmp_path, TRT.format(setup=""), "--frame", "G54=0,0,0,0,10,0")
    assert res.exit_code == 2 and "turns about Z only" in res.stderr and not out.exists()


HEAD = "G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\n{tool}G54 G0 X0 Y0 Z0 C0 B90\nM2\n"


@pytest.mark.parametrize("tool, options, tip", [
    ("G10 L1 P1 Z50\nG43 H1\n", (), [300, 0, 300]),  # the program's own length (G10 L1)
    ("G43 H1\n", ("--tool", "H1=0,0,50"), [300, 0, 300]),
    ("", (), [250, 0, 250]),  # G49: no length
])
def test_head_machine_takes_the_tool_length(tmp_path, tool, options, tip):
    res, out = _convert(tmp_path, HEAD.format(tool=tool), *options, machine="xyzbc-5axiskins")
    assert res.exit_code == 0, res.output
    np.testing.assert_allclose(_tips(out.read_text()), [tip], atol=1e-3)


def test_head_machine_refuses_an_unknown_tool_length(tmp_path):
    res, out = _convert(tmp_path, HEAD.format(tool="G43 H1\n"), machine="xyzbc-5axiskins")
    assert res.exit_code == 2 and ":4:9:" in res.stderr and "--tool H1=0,0,LENGTH" in res.stderr and not out.exists()


def test_table_machine_does_not_need_the_tool_length(tmp_path):
    """On a table-table machine the tip is the controlled point under G43: H1's length does not enter."""
    res, out = _convert(tmp_path, TRT.format(setup="G10 L2 P1 X0 Y-20 Z-10\nG43 H1\n"))
    assert res.exit_code == 0, res.output


def test_compensate_reads_through_the_work_offset(tmp_path):
    """compensate on the nominal machine's own file: nothing to correct when read through the
    right offset; refused without it."""
    src, out = tmp_path / "in.ngc", tmp_path / "out.ngc"
    src.write_text("G21 G90 G94\nG54 G0 X0 Y20 Z10 A-90 C0\nG1 X5 Y20 Z10 A-90 C0 F100\nM2\n")
    model = str(load_machine("xyzac-trt").source_path)
    res = runner.invoke(app, ["compensate", str(src), "--model", model, "--input-axes", "machine", "-o", str(out)])
    assert res.exit_code == 2 and "--frame G54=" in res.stderr and not out.exists()
    res = runner.invoke(app, ["compensate", str(src), "--model", model, "--input-axes", "machine", "-o", str(out), "--frame", "G54=0,-20,-10,0,0,0"])
    assert res.exit_code == 0, res.output
    np.testing.assert_allclose(parse_program(out).position, parse_program(src).position, atol=1e-9)


@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
def test_rs274_reads_the_emitted_tips(tmp_path):
    """rs274 on the written program (no work offset): its moves are the hand-worked tips."""
    res, out = _convert(tmp_path, TRT.format(setup="G10 L2 P1 X0 Y-20 Z-10\n"))
    assert res.exit_code == 0
    canon = subprocess.run(["rs274", "-g", str(out)], capture_output=True, text=True, timeout=60, cwd=tmp_path).stdout
    moves = [[float(v) for v in m.split(",")[:3]] for m in re.findall(r"STRAIGHT_(?:TRAVERSE|FEED)\(([^)]*)\)", canon)]
    np.testing.assert_allclose(moves[-2:], [[0, 30, -10]] * 2, atol=1e-4)
