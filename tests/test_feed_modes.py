"""G93 / G94 / G95 feed rate modes: the IR's feed_mode column, inspect --json, and convert
writing the speed the machine really moves at.

LinuxCNC manual, "G93, G94, G95 Feed Rate Mode" (docs/src/gcode/g-code.adoc):
- G93 inverse time: "an F word means the move should be completed in [one divided by the
  F number] minutes"; "an F word must appear on every line that has a G1, G2, or G3 motion".
- G94 units per minute; G95 units per revolution: "F word is interpreted to mean the
  controlled point should move a certain number of inches per revolution of the spindle".
LinuxCNC's interpreter (rs274, linuxcnc-uspace) is the judge: for G93 moves it prints
SET_FEED_RATE(length x F), arcs along the arc (a helix along the helix), a move of X Y Z and
A the X Y Z length (SET_FEED_REFERENCE(CANON_XYZ)). Its output for tests/data/rs274/feed_modes/
feeds.ngc is recorded beside it; where rs274 is installed it is run again and must match.
Record again: .venv/bin/python tests/test_feed_modes.py --record
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import EmitError, ParseError
from postproc.programs import parse_program
from postproc.programs.emit.feeds import machine_speeds
from postproc.programs.ir import Kind

HERE = Path(__file__).parent
PROGRAM = HERE / "data" / "rs274" / "feed_modes" / "feeds.ngc"
RECORDED = PROGRAM.with_suffix(".canon")
runner = CliRunner()
_CALL = re.compile(r"(SET_FEED_RATE|SET_SPINDLE_SPEED|STRAIGHT_FEED|ARC_FEED|COMMENT)\(([^)]*)\)")


def rs274_feeds(canon: str) -> list[float]:
    """The speed (program units per minute) of each feed move in rs274's canonical output:
    SET_FEED_RATE before it, times SET_SPINDLE_SPEED where the mode is units per revolution."""
    rate = spindle = 0.0
    per_rev = False
    out = []
    for call, args in _CALL.findall(canon):
        if call == "COMMENT" and "feed mode set to" in args:
            per_rev = "per revolution" in args
        elif call == "SET_FEED_RATE":
            rate = float(args)
        elif call == "SET_SPINDLE_SPEED":
            spindle = float(args.split(",")[1])
        elif call in ("STRAIGHT_FEED", "ARC_FEED"):
            out.append(rate * spindle if per_rev else rate)
    return out


def run_rs274(path: Path) -> str:
    proc = subprocess.run(["rs274", "-g", str(path)], capture_output=True, text=True, timeout=60, cwd=path.parent)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_speeds_equal_rs274s_feed_rates():
    """Every feed move's speed (G93: length x F, arcs and a helix along their path; G94: F;
    G95: F x S) equals rs274's, which prints them to 4 decimals."""
    tp = parse_program(PROGRAM)
    feed = tp.kind != Kind.RAPID
    ours = machine_speeds(tp)[feed]
    theirs = rs274_feeds(RECORDED.read_text())
    assert len(theirs) == feed.sum() == 10
    np.testing.assert_allclose(ours, theirs, atol=1e-4)


@pytest.mark.skipif(shutil.which("rs274") is None, reason="rs274 (linuxcnc-uspace) not installed")
def test_rs274_recording_is_current():
    assert run_rs274(PROGRAM) == RECORDED.read_text()


def test_ir_keeps_f_as_written_and_carries_the_mode_and_spindle():
    """The speed column keeps F as read (the five-axis writer re-emits a G93 F); the mode
    and S in force are columns of their own."""
    tp = parse_program(PROGRAM)
    assert tp.feed_mode.tolist() == [94, 93, 93, 93, 93, 93, 93, 94, 95, 95, 94]
    np.testing.assert_allclose(tp.speed[1:7], [2, 4, 3, 6, 5, 2])
    assert np.isnan(tp.spindle[:8]).all() and (tp.spindle[8:] == 1200).all()
    assert tp.take([1, 8]).feed_mode.tolist() == [93, 95]


def test_inverse_time_in_inches_by_hand(tmp_path):
    """G20 G93: a 1 inch move with F2 takes half a minute: 2 in/min = 50.8 mm/min (rs274:
    SET_FEED_RATE(2.0000) in inches); G95 F0.01 in/rev at S100 is 1 in/min = 25.4 mm/min."""
    prog = tmp_path / "inch.ngc"
    prog.write_text("G20 G90 G17\nG0 X0 Y0 Z0\nG93\nG1 X1 F2\nG95 S100 M3\nG1 X2 F0.01\nM2\n")
    np.testing.assert_allclose(machine_speeds(parse_program(prog))[1:], [50.8, 25.4])


@pytest.mark.parametrize("to, name", [("krl", "out.src"), ("rapid", "out.mod")])
def test_convert_writes_the_machine_speed(tmp_path, to, name):
    """100 mm in 1/2 minute (G93 F2) is 200 mm/min = 3.3333 mm/s; G95 F0.05 at S1200 is
    60 mm/min = 1 mm/s; G94 F300 is 5 mm/s. KRL writes $VEL.CP in m/s, RAPID \\V:= in mm/s."""
    src = tmp_path / "in.ngc"
    src.write_text("G21 G90 G17\nG0 X0 Y0 Z0\nG93\nG1 X100 F2\nG94\nG1 X0 F300\nS1200 M3\nG95\nG1 X10 F0.05\nM2\n")
    out = tmp_path / name
    res = runner.invoke(app, ["convert", str(src), "--to", to, "--frame", "G54=0,0,0,0,0,0", "-o", str(out)])
    assert res.exit_code == 0, res.output
    text = out.read_text(encoding="latin-1")
    if to == "krl":
        assert re.findall(r"\$VEL\.CP\s*=\s*([\d.]+)", text)[-3:] == ["0.003333", "0.005", "0.001"]
    else:
        assert re.findall(r"MoveL [^;]*\\V:=([\d.]+)", text) == ["3.333", "5", "1"]


@pytest.mark.parametrize("body, where, why", [
    # (a plain convert refuses A/B/C words first: the rotary-only G93 move is machine_speeds' own refusal below)
    ("G0 X0 Y0 Z0 A0\nG93\nG1 A90 F1\n", ":2:5:", "rotary axis words"),
    ("G0 X0 Y0 Z0\nG93\nG1 X0 F1\n", ":4:7:", "zero length"),
    ("G93\nG1 X10 Y0 Z0 F1\n", ":3:14:", "start is not known"),
    ("G0 X0 Y0 Z0\nG95\nG1 X10 F0.1\n", ":4:8:", "no known spindle speed"),
    ("G0 X0 Y0 Z0\nG95 S0 M3\nG1 X10 F0.1\n", ":4:8:", "S0"),
])
def test_convert_refuses_a_move_without_a_machine_speed(tmp_path, body, where, why):
    """No length (rotary-only, zero, unknown start) under G93, or no S under G95: no speed
    can be written; refused with file:line:column of the F word, nothing written."""
    src = tmp_path / "bad.ngc"
    src.write_text("G21 G90 G17\n" + body + "M2\n")
    out = tmp_path / "bad.src"
    res = runner.invoke(app, ["convert", str(src), "--to", "krl", "--frame", "G54=0,0,0,0,0,0", "-o", str(out)])
    assert res.exit_code == 2 and f"bad.ngc{where}" in res.output and why in res.output, res.output
    assert not out.exists() and not out.with_suffix(".dat").exists()
    with pytest.raises(EmitError):
        machine_speeds(parse_program(src))


@pytest.mark.parametrize("body, line, why", [
    ("G0 X0 Y0 Z0\nG93\nG1 X10 F1\nG1 X20\n", 5, "without its own F"),
    ("G0 X0 Y0 Z5\nG93\nG81 X10 Y10 Z-2 R1 F2\nG80\n", 4, "canned cycle in G93"),
])
def test_reader_refuses_what_linuxcnc_refuses_in_g93(tmp_path, body, line, why):
    """F is not modal in G93 (rs274: "F word missing with inverse time G1 move"); a canned
    cycle in G93 (rs274: "Cannot feed with zero feed rate")."""
    src = tmp_path / "g93.ngc"
    src.write_text("G21 G90 G17\n" + body + "M2\n")
    with pytest.raises(ParseError, match=rf"g93\.ngc:{line}:1: .*{why}"):
        parse_program(src)


def test_five_axis_program_to_a_robot_keeps_the_tip_feed(tmp_path):
    """convert --machine: F600 (G94) is 10 mm/s = $VEL.CP 0.01 m/s (it was written 60 times
    too slow); the G93 move of the tip 60 mm with F2 takes 1/2 minute: 120 mm/min = 0.002 m/s."""
    src = tmp_path / "five.ngc"
    src.write_text("G21 G90 G17\nG0 X0 Y0 Z0 A0 C0\nG1 X60 F600\nG93\nG1 X120 A10 F2\nG94\nM2\n")
    out = tmp_path / "five.src"
    res = runner.invoke(app, ["convert", str(src), "--to", "krl", "--machine", "xyzac-trt", "--input-axes", "tip", "--frame", "G54=0,0,0,0,0,0", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert re.findall(r"\$VEL\.CP\s*=\s*([\d.]+)", out.read_text(encoding="latin-1")) == ["0.01", "0.002"]


def test_inspect_reports_the_mode_and_no_mm_per_min_for_inverse_time(tmp_path):
    res = runner.invoke(app, ["inspect", "--json", str(PROGRAM)])
    assert res.exit_code == 0, res.output
    moves = json.loads(res.stdout)["moves"]
    g93 = moves[1]
    assert g93["feed_mode"] == "G93" and g93["speed"] is None and g93["f"] == 2.0 and "inverse time" in g93["f_unit"]
    assert g93["speed_derived_mm_per_min"] == 200.0
    assert moves[7]["feed_mode"] == "G94" and moves[7]["speed"] == 300.0 and "f_unit" not in moves[7]
    assert moves[8]["feed_mode"] == "G95" and moves[8]["f_unit"] == "mm/rev" and moves[8]["speed_derived_mm_per_min"] == 60.0


_MOTION = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED|RIGID_TAP|START_SPEED_FEED_SYNC|USE_LENGTH_UNITS|SET_FEED_RATE|SET_FEED_MODE|SET_SPINDLE_SPEED)\(([^)]*)\)")


def canonical_feeds(text: str) -> np.ndarray:
    """(moves,) mm/min of each of rs274's motion calls (canonical_endpoints' order), NaN for a
    traverse: SET_FEED_RATE (inverse time already turned into units/min by rs274), times
    SET_SPINDLE_SPEED under SET_FEED_MODE(0, 1) (units per revolution), times 25.4 in inches.
    RIGID_TAP (G33.1: in and back out, two moves) runs at START_SPEED_FEED_SYNC's units per
    revolution times the spindle speed."""
    scale, rate, spindle, per_rev, out, sync = 1.0, np.nan, np.nan, False, [], np.nan
    for call, args in _MOTION.findall(text):
        if call == "USE_LENGTH_UNITS":
            scale = 25.4 if "INCHES" in args else 1.0
        elif call == "SET_FEED_RATE":
            rate = float(args)
        elif call == "SET_FEED_MODE":
            per_rev = args.split(",")[1].strip() == "1"
        elif call == "SET_SPINDLE_SPEED":
            spindle = float(args.split(",")[1])
        elif call == "START_SPEED_FEED_SYNC":
            sync = float(args.split(",")[0])
        elif call == "RIGID_TAP":
            out += [sync * spindle * scale] * 2
        else:
            out.append(np.nan if call == "STRAIGHT_TRAVERSE" else rate * scale * (spindle if per_rev else 1.0))
    return np.array(out)


def _corpus_cases():
    from test_real_corpus import RECORDED, RS274_XFAIL

    return [n for n in RECORDED if n not in RS274_XFAIL]


@pytest.mark.parametrize("name", _corpus_cases())
def test_corpus_feeds_equal_rs274s(name):
    """Every feed move of the real G-code corpus that rs274 runs (its recordings, kept for
    test_real_corpus.py; LinuxCNC's daisy.ngc is a G93 program): the speed convert writes
    (mm/min) equals rs274's feed rate (printed to 4 decimals: 1e-4 of the program unit / min
    plus the G93 length's rounding). A move convert refuses (no machine speed) is one rs274
    gives no tool speed either: a rotary-only or zero-length G93 move."""
    from test_real_corpus import _moves, canonical_endpoints, corpus_file, machine_positions, recording

    from postproc.programs.emit.feeds import _speeds

    tp = parse_program(corpus_file(name))
    text = recording(name).read_text(encoding="latin-1")
    canon, tol, arc = canonical_endpoints(text)
    theirs = canonical_feeds(text)[_moves(canon, tol, arc)]
    rows = _moves(machine_positions(tp), np.full(len(tp), 1e-9), np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)))
    assert len(rows) == len(theirs)
    ours, why = _speeds(tp)
    ours, why = ours[rows], why[rows]
    feed = np.isfinite(theirs) & (tp.kind[rows] != Kind.RAPID) & np.isfinite(ours) & (why == "")
    off = feed & ~(np.abs(ours - theirs) <= 1e-5 * np.abs(theirs) + 2e-3 * tp.scale[rows, 0])
    if off.any():
        i = int(np.nonzero(off)[0][0])
        pytest.fail(f"{name}: line {tp.line[rows[i]]}: {ours[i]} mm/min, rs274 {theirs[i]}; {int(off.sum())} of {int(feed.sum())} feed moves differ")
    assert all(("rotary" in w or "zero length" in w) for w in why[why != ""]), set(why[why != ""])


if __name__ == "__main__" and "--record" in sys.argv:
    RECORDED.write_text(run_rs274(PROGRAM))
    print(f"recorded {RECORDED}")
