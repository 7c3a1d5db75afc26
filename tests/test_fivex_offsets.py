"""Five-axis G-code programs read through their work offsets and tool lengths, or refused
(issue 12, "G-code work offsets and tool length"; postproc/jobs/five_axis/offsets.py).

The five-axis kinematics work in the machine frame with the rotary axes at zero (the rotary
axes' points in machines/*.toml are there). The controller puts a program point there with
the work offset in force (LinuxCNC manual, "Coordinate Systems": machine = rotate_R(p + G92)
+ G5x origin); a head machine turns the tool about a pivot gauge_to_tip + the G43 tool length
above the tip (LinuxCNC 5axiskins: tip = joints + (0, 0, L) + L (sin b cos c, sin b sin c,
-cos b), L the pivot length plus the tool offset). An offset or length the program does not
give is taken from --frame / --tool or the job is refused with file:line:column.

Rotary work offsets and G43.1 / G43.2 (the second half of this file). The rule, LinuxCNC
src/emc/task/emccanon.cc rotate_and_offset_pos: the machine position of a programmed point
is ``rotate_R(p + G92) + G5x + tool offset`` and of a programmed angle ``a + G92.a + G5x.a +
tool.a``; the interpreter keeps the programmed values (rs274 prints them in STRAIGHT_FEED and
the offsets in SET_G5X_OFFSET / SET_G92_OFFSET / USE_TOOL_LENGTH_OFFSET), and an offset change
re-reads the current angle so that the machine does not move. The kinematics get the offset
pose: with RTCP off its X Y Z A C are the machine axes (the tool length compensated: the
controlled point is the tip), with RTCP on (LinuxCNC TCP kinematics) X Y Z are the tip in the
workpiece frame and A C the joint angles. G43.1 Z.. sets the length in force, G43.2 H.. adds
tool H's (LinuxCNC manual, "G43.1", "G43.2"). rs274's outputs for the programs below are in
tests/data/rs274/fivex_offsets/ (regenerate: .venv/bin/python tests/test_fivex_offsets.py
--record); the IR's machine axes must equal them within 1e-6, and the tool tips through the
kinematics the values worked by hand at each program (Rx, Rz right-handed; a table axis
turned by a carries machine point m to Rx(-a)(m - p) + p, as above).

Hand-worked numbers (xyzac-trt: A about +X through (0, 20, 10), C about +Z through the origin;
a positive angle turns the table right-handed, so a machine point m is at Rx(-a)(m - p) + p
on the table for C 0):
- machine axes X0 Y20 Z10 A-90 C0 in G54 = (0, -20, -10): machine point (0, 0, 0); m - p =
  (0, -20, -10); Rx(-a) = Rx(90) takes (y, z) to (-z, y) = (10, -20); + p: tip (0, 30, -10), tool
  axis Rx(90) (0, 0, 1) = (0, -1, 0). Read with G54 as the identity it would be the pivot (0, 20, 10).
- tip X10 Y0 Z5 in G54 = origin 0 turned R90: (0, 10, 5).
- xyzbc-5axiskins (gauge 250): machine axes X0 Y0 Z0 C0 B90 under a 50 mm tool: L = 300,
  tip (0, 0, 300) + 300 (1, 0, 0) = (300, 0, 300); with no length (G49): (250, 0, 250).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rs274_recordings import assert_current, needs_rs274, record_all
from typer.testing import CliRunner

from postproc.cli import app
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.offsets import program_to_machine, to_machine
from postproc.jobs.five_axis.program import from_toolpath
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


# ---------------------------------------------------------------- rotary work offsets, G43.1 / G43.2
RECORDED = Path(__file__).parent / "data" / "rs274" / "fivex_offsets"
S100, C100 = np.sin(np.radians(100)), np.cos(np.radians(100))
H = np.sqrt(0.5)
S70, C70 = np.sin(np.radians(70)), np.cos(np.radians(70))


def _rx(degrees: float, y: float, z: float) -> tuple[float, float]:
    """(y, z) turned right-handed about X."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return y * c - z * s, y * s + z * c


# name: (program, machine, input axes, hand-worked tool tips, tool axes)
PROGRAMS = {
    # xyzac-trt, RTCP off. G54 = (0, -20, -10) A30 C90, G55 the same without angles.
    "rotary_offsets_trt": ("G21 G90 G94\nG10 L2 P1 X0 Y-20 Z-10 A30 C90\nG10 L2 P2 X0 Y-20 Z-10 A0 C0\n"
                           "G54 G0 X0 Y20 Z10 A-120 C-90\n"  # machine (0, 0, 0) A-90 C0: the docstring's first case, tip (0, 30, -10)
                           "G1 X10 C0 F100\n"  # (10, 0, 0) A-90 C90: Rx(90) about (0, 20, 10) -> (10, 30, -10); Rz(-90) (x, y) -> (y, -x)
                           "G10 L2 P1 A0\nG1 X0\n"  # A re-read -120 + 30 - 0 = -90: the machine stays at A-90 C90; (0, 30, -10) -> (30, 0, -10)
                           "G92 C10\nG1 C20\n"  # G92.c = 0 + 0 - 10: C 20 is machine 100; Rz(-100) (0, 30) = 30 (sin 100, cos 100)
                           "G92.1\nG55 G1 X0\n"  # C re-read 20 - 10 + 90 - 0 = 100: machine unchanged
                           "G10 L20 P2 C0\nG1 C-10\nM2\n",  # G55's C origin 100 (machine 100 reads 0): C-10 is machine 90
                           "xyzac-trt", "machine",
                           [[0, 30, -10], [30, -10, -10], [30, 0, -10], [30 * S100, 30 * C100, -10], [30 * S100, 30 * C100, -10], [30, 0, -10]],
                           [[0, -1, 0], [-1, 0, 0], [-1, 0, 0], [-S100, -C100, 0], [-S100, -C100, 0], [-1, 0, 0]]),
    # xyzac-trt, RTCP on: the tip is the programmed point through G54 (X5, turned R90), the angles
    # are A-60 - 30 = -90 and C45 + 45 = 90, then C0 + 45: tool axis Rz(-c) Rx(90) (0, 0, 1) = Rz(-c) (0, -1, 0)
    "rotary_offsets_tcp": ("G21 G90 G94\nG10 L2 P1 X5 Y0 Z0 R90 A-30 C45\nG54 G0 X1 Y2 Z3 A-60 C45\nG1 X1 Y2 Z3 A-60 C0 F100\nM2\n",
                           "xyzac-trt", "tip", [[3, 1, 3], [3, 1, 3]], [[-1, 0, 0], [-H, -H, 0]]),
    # xyzbc-5axiskins (pivot 250): G43.1 Z30, then G43.2 H1 adds tool 1's 20 (G10 L1): L = 250 + 50;
    # G54 C90: machine C = programmed + 90. tip = (X, Y, Z) + L (sin b cos c, sin b sin c, 1 - cos b) and the
    # pivot is at (X, Y, Z + L): tool axis (tip -> spindle) = (-sin b cos c, -sin b sin c, cos b)
    "dynamic_length_head": ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0 C90\nG10 L1 P1 Z20\nG43.1 Z30\nG43.2 H1\n"
                            "G54 G0 X0 Y0 Z0 C-90 B90\nG1 X10 Y0 Z0 C0 B30 F100\nM2\n",
                            "xyzbc-5axiskins", "machine", [[300, 0, 300], [10, 150, 300 * (1 - np.cos(np.radians(30)))]],
                            [[-1, 0, 0], [0, -0.5, np.cos(np.radians(30))]]),
    # G43.1 Z50 A10 on a table machine (xyzac-trt, RTCP off): rs274 re-reads Z (10 - 50) and A (-90 - 10), the machine
    # does not move; the length does not enter (the tip is the controlled point), the A offset does: A-80 is machine -70.
    # G49 takes both off again (Z -40 + 50, A -80 + 10). Rx(-a) about (0, 20, 10) as in the first case.
    "tool_offsets_trt": ("G21 G90 G94\nG10 L2 P1 X0 Y-20 Z-10\nG54 G0 X0 Y20 Z10 A-90 C0\nG43.1 Z50 A10\nG1 X10 F100\nG1 A-80\nG49\nG1 X0\nM2\n",
                         "xyzac-trt", "machine",
                         [[0, 30, -10], [10, 80, -10], [10, 20 + _rx(70, -20, -60)[0], 10 + _rx(70, -20, -60)[1]],
                          [0, 20 + _rx(70, -20, -10)[0], 10 + _rx(70, -20, -10)[1]]],
                         [[0, -1, 0], [0, -1, 0], [0, -S70, C70], [0, -S70, C70]]),
    # the rest of the offsets' rules, machine axes against rs274 only: G52 A, G91 increments after an offset change
    # (the machine moves by the increment), G92 C / G92.2 / G92.3, G43.1 C (the tool's C offset), G10 L2 P0 (the active
    # system), G49 with G92.1
    "rotary_g52_g91": ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0 A5 C10\nG54 G0 X0 Y0 Z10 A0 C0\nG52 A3\nG91 G1 A2 F100\nG90 G1 X1\nG92 C20\n"
                       "G92.2\nG1 X2\nG92.3\nG1 X3 C5\nG43.1 C-4\nG91 G1 C1\nG90 G10 L2 P0 A-5\nG1 X4\nG49 G92.1\nG1 X5\nG1 A0 C0\nM2\n",
                       None, None, None, None),
    # G53 Z0 under G43.1 Z50 in G54 Z5: the words place the spindle; the current tip Z reads 0 - 5 - 50 (rs274)
    "g53_under_g43_1": ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z5\nG54 G0 X0 Y0 Z10\nG43.1 Z50\nG53 G0 Z0\nG1 X5 F100\nM2\n", None, None, None, None),
}


def _program_file(folder: Path, name: str) -> Path:
    path = folder / f"{name}.ngc"
    path.write_text(PROGRAMS[name][0])
    return path


def rs274_machine_axes(text: str) -> np.ndarray:
    """(N, 6) machine X Y Z A B C of rs274's STRAIGHT_TRAVERSE / STRAIGHT_FEED calls (mm, deg), the
    offsets it announces applied as emccanon.cc rotate_and_offset_pos does: rotate(p + G92) + G5x +
    tool offset, angles + G92 + G5x + tool (programs in mm)."""
    g5x, g92, tool, turn, out = np.zeros(6), np.zeros(6), np.zeros(6), 0.0, []
    for call, args in re.findall(r"(SET_G5X_OFFSET|SET_G92_OFFSET|SET_XY_ROTATION|USE_TOOL_LENGTH_OFFSET|STRAIGHT_TRAVERSE|STRAIGHT_FEED)\(([^)]*)\)", text):
        v = np.array([float(x) for x in re.split(r"[,\s]+", args.strip())])
        if call == "SET_G5X_OFFSET":
            g5x = v[1:7]
        elif call == "SET_G92_OFFSET":
            g92 = v[:6]
        elif call == "SET_XY_ROTATION":
            turn = np.radians(v[0])
        elif call == "USE_TOOL_LENGTH_OFFSET":
            tool = v[:6]
        else:
            p = v[:6] + g92
            c, s = np.cos(turn), np.sin(turn)
            p[:2] = c * p[0] - s * p[1], s * p[0] + c * p[1]
            out.append(p + g5x + tool)
    return np.array(out)


def ir_machine_axes(tp) -> np.ndarray:
    """(N, 6) the machine axes the IR gives: X Y Z through the work offset + the tool length in
    force, A B C programmed + the rotary work offsets."""
    xyz = to_machine(program_to_machine(tp), tp.position) + tp.tools[tp.tool][:, :3, 3]
    abc = tp.ext[:, :3] + (0.0 if tp.rotary_offset is None else tp.rotary_offset)
    return np.c_[xyz, abc]


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_machine_axes_equal_rs274s(name, tmp_path):
    tp = parse_program(_program_file(tmp_path, name))
    want = rs274_machine_axes((RECORDED / f"{name}.canon").read_text(encoding="latin-1"))
    got = ir_machine_axes(tp)
    used = ~np.isnan(got).all(axis=0)  # B on an A C machine: not programmed (rs274 prints 0)
    assert got.shape == want.shape and used[:3].all()
    rows = tp.resolved  # a G53 target under a tool offset is flagged (its words place the spindle); the moves after it are compared
    assert rows.sum() >= len(tp) - 1
    np.testing.assert_allclose(got[rows][:, used], want[rows][:, used], atol=1e-6, rtol=0)


@pytest.mark.parametrize("name", sorted(n for n in PROGRAMS if PROGRAMS[n][1]))
def test_tool_tips_are_the_hand_worked_ones(name, tmp_path):
    _, machine, input_axes, tips, axes = PROGRAMS[name]
    path = from_toolpath(parse_program(_program_file(tmp_path, name)), load_machine(machine), input_axes)
    np.testing.assert_allclose(path.tip, tips, atol=1e-9)
    np.testing.assert_allclose(path.axis, axes, atol=1e-12)


def test_the_written_program_has_the_machine_angles(tmp_path):
    """convert to LinuxCNC TCP: the output runs with zero offsets, so it carries the machine's
    angles (A-90 C90, A-90 C45) and the tips in the machine frame."""
    src, out = _program_file(tmp_path, "rotary_offsets_tcp"), tmp_path / "out.ngc"
    res = runner.invoke(app, ["convert", str(src), "--to", "gcode", "--machine", "xyzac-trt", "--rtcp", "linuxcnc", "--input-axes", "tip", "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    np.testing.assert_allclose(_tips(text), [[3, 1, 3]] * 2, atol=1e-3)
    angles = [[float(v) for v in re.findall(r"[AC](-?[\d.]+)", line)] for line in text.splitlines() if re.match(r"G[01] X", line)]
    np.testing.assert_allclose(angles, [[-90, 90], [-90, 45]], atol=1e-3)


def test_compensate_writes_back_the_programmed_angles(tmp_path):
    """compensate on the nominal machine: nothing to correct, and the angles are written in the
    program's own offsets (the rotary offset taken off again)."""
    src, out = _program_file(tmp_path, "rotary_offsets_tcp"), tmp_path / "out.ngc"
    res = runner.invoke(app, ["compensate", str(src), "--model", str(load_machine("xyzac-trt").source_path), "--input-axes", "tip", "-o", str(out)])
    assert res.exit_code == 0, res.output
    before, after = parse_program(src), parse_program(out)
    np.testing.assert_allclose(after.ext[:, [0, 2]], before.ext[:, [0, 2]], atol=1e-6)
    np.testing.assert_allclose(after.position, before.position, atol=1e-6)


@pytest.mark.parametrize("text, machine, where, message", [
    # an offset from a parameter the program does not determine (a probe result)
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0 A#5061\nG54 G0 X0 Y0 Z5 A0 C0\nM2\n", "xyzac-trt", ":3:", r"position depends"),
    # G92 A5 before any A move: the machine's A there (so the offset) is not known (rs274 would take 0)
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\nG92 A5\nG54 G0 X0 Y0 Z5 A0 C0\nM2\n", "xyzac-trt", ":4:9:", r"rotary axes' work offset"),
    # G43.2 without H: rs274 (LinuxCNC 2.9) refuses it
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\nG43.2 Z5\nG54 G0 X0 Y0 Z0 C0 B0\nM2\n", "xyzbc-5axiskins", ":3:1:", r"G43.2 needs an H word"),
    # G43.1 with an X word: the tool is off the spindle axis, not followed
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\nG43.1 X1 Z50\nG54 G0 X0 Y0 Z0 C0 B0\nM2\n", "xyzbc-5axiskins", ":4:9:", r"G43.1@line3"),
    # G43.2 H1 on a length the program does not give (tool 1 in the controller's table)
    ("G21 G90 G94\nG10 L2 P1 X0 Y0 Z0\nG43.1 Z50\nG43.2 H1\nG54 G0 X0 Y0 Z0 C0 B0\nM2\n", "xyzbc-5axiskins", ":5:9:", r"--tool G43.2@line4="),
    # G54 with a rotary offset but its X Y Z left to the controller: refused without --frame
    ("G21 G90 G94\nG10 L2 P1 A10\nG54 G0 X0 Y0 Z5 A0 C0\nM2\n", "xyzac-trt", ":3:9:", r"--frame G54@line2="),
])
def test_what_is_not_followed_is_refused(tmp_path, text, machine, where, message):
    res, out = _convert(tmp_path, text, machine=machine)
    flat = " ".join(res.output.split())
    assert res.exit_code == 2 and f"in.ngc{where}" in flat and re.search(message, flat) and not out.exists(), flat


@needs_rs274
@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_rs274_recordings_are_current(name, tmp_path):
    assert_current(_program_file(tmp_path, name), RECORDED / f"{name}.canon")


if __name__ == "__main__" and "--record" in sys.argv:
    record_all(PROGRAMS, _program_file, RECORDED)
