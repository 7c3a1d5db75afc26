"""CYCLE800 swivel planes on a five-axis machine: placed with the 840D's rotary positions,
converted, and refused by compensate (postproc/programs/dialects/sinumerik/swivel_place.py).

By hand, for machines/xyzac-trt (workpiece tool axis = Rz(-c) Rx(-a) (0,0,1) = (sin a sin c,
sin a cos c, cos a), A limits -100..50): CYCLE800 _MODE 57 (X-Y-Z) _A=-30 turns the frame by
Rx(-30): tool axis (0, 1/2, cos 30), reached at (A, C) = (30, 0) or (-30, 180); _DIR=-1 takes the
lower A (SINUMERIK Operating Manual, "Swivel plane (CYCLE800)", "Direction (minus/plus)": the
direction reference axis, here the machine file's first rotary axis A), _DIR=+1 the higher.
The tips: the swivel frame TRANS(_X0=10) @ Rx(-30) on the programmed points (Operating Manual,
"X0 Y0 Z0 reference point for rotation").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import InputError
from postproc.fivex.kinematics import fk
from postproc.fivex.machine import load_machine
from postproc.jobs.five_axis.emit import solve
from postproc.jobs.five_axis.program import from_toolpath
from postproc.programs import dialects, parse_program

S30, C30 = 0.5, np.sqrt(3) / 2
TRUE = Path(__file__).parent / "data" / "fivex" / "xyzac-trt-true.toml"
PLANES = """N10 G54 G17 G71 G90
N20 CYCLE800(1,"TC1",0,57,10,0,0,-30,0,0,0,0,0,{dir})
N30 G0 X0 Y0 Z5
N40 G1 X10 Y0 Z0 F500
N50 G1 X10 Y10 Z0
N60 M30
"""
AT_G54 = ["--frame", "G54=0,0,0,0,0,0"]


def _program(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "PLANE.MPF"
    path.write_bytes(text.encode("latin-1"))
    return path


@pytest.mark.parametrize("direction, angles", [(-1, (-30.0, 180.0)), (1, (30.0, 0.0))])
def test_swivel_plane_targets_placed_with_the_cycles_rotary_positions(tmp_path, direction, angles):
    tp = parse_program(_program(tmp_path, PLANES.format(dir=direction))).with_frames({"G54": np.eye(4)})
    path = from_toolpath(tp, load_machine("xyzac-trt"), "tip")
    np.testing.assert_allclose(path.tip, [(10, 5 * S30, 5 * C30), (10 + 10, 0, 0), (20, 10 * C30, -10 * S30)], atol=1e-9)
    np.testing.assert_allclose(path.axis, np.broadcast_to((0, S30, C30), (3, 3)), atol=1e-9)
    np.testing.assert_allclose(np.abs(path.angles), np.broadcast_to(np.abs(angles), (3, 2)), atol=1e-9)  # C 180 = -180
    assert path.angles[0, 0] == pytest.approx(angles[0])


def test_what_the_program_leaves_open_stays_flagged(tmp_path):
    machine = load_machine("xyzac-trt")
    tp = parse_program(_program(tmp_path, PLANES.format(dir=0))).with_frames({"G54": np.eye(4)})
    with pytest.raises(InputError, match="PLANE.MPF:3: the target's position depends"):
        from_toolpath(tp, machine, "tip")
    placed = dialects.of(tp).for_machine(tp, machine)
    assert not placed.resolved.any() and any("line 2: CYCLE800 _DIR=0" in n for n in placed.notes), placed.notes
    # direct mode (_MODE bits 7-6 = 11): the swivel frame is not worked out, its targets are not placed
    tp = parse_program(_program(tmp_path, PLANES.format(dir=-1).replace('"TC1",0,57,', '"TC1",0,192,')))
    placed = dialects.of(tp).for_machine(tp, machine)
    assert not placed.resolved.any() and any("line 2: CYCLE800 whose swivel frame is not known" in n for n in placed.notes), placed.notes
    # a move before the first CYCLE800: where the rotary axes stand is not in the program
    tp = parse_program(_program(tmp_path, PLANES.format(dir=-1).replace("N10 G54 G17 G71 G90\n", "N10 G54 G17 G71 G90\nN15 G0 X0 Y0 Z50\n")))
    with pytest.raises(InputError, match="PLANE.MPF:2: the target's position depends"):
        from_toolpath(tp.with_frames({"G54": np.eye(4)}), machine, "tip")


def test_compensate_refuses_a_swivel_plane_and_convert_writes_its_rotary_positions(tmp_path):
    runner, source = CliRunner(), _program(tmp_path, PLANES.format(dir=-1))
    res = runner.invoke(app, ["compensate", str(source), "--model", str(TRUE), "-o", str(tmp_path / "c.mpf"), "--input-axes", "tip", *AT_G54])
    assert res.exit_code == 2 and "PLANE.MPF:2: targets in a CYCLE800 swivel plane are not compensated" in res.output, res.output
    assert not (tmp_path / "c.mpf").exists()
    res = runner.invoke(app, ["convert", str(source), "--to", "heidenhain", "--machine", "xyzac-trt", "--input-axes", "tip", "-o",
                              str(tmp_path / "m.h"), *AT_G54])
    assert res.exit_code == 0 and "rotary positions A-30.0000 C+180.0000 (_DIR=-1)" in res.output, res.output
    moves = [line for line in (tmp_path / "m.h").read_text().splitlines() if " L " in f" {line.split(' ', 1)[1]} "]
    assert all("A-30" in line and "C+180" in line for line in moves) and len(moves) == 3, moves
    # converted to TRAORI, the same path is compensated
    res = runner.invoke(app, ["convert", str(source), "--to", "sinumerik", "--machine", "xyzac-trt", "--input-axes", "tip", "-o",
                              str(tmp_path / "T.MPF"), *AT_G54])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["compensate", str(tmp_path / "T.MPF"), "--model", str(TRUE), "-o", str(tmp_path / "TC.MPF"), "--input-axes", "tip",
                              *AT_G54])
    assert res.exit_code == 0, res.output


TWO_PLANES = """N10 G54 G17 G71 G90
N20 CYCLE800(1,"TC1",0,57,0,0,0,-30,0,0,0,0,0,-1)
N30 G0 X0 Y0 Z5
N40 G1 X10 Y0 Z0 F500
N50 CYCLE800(1,"TC1",0,57,0,0,0,-30,0,0,0,0,0,1)
N60 G0 X0 Y0 Z5
N70 G1 X10 Y0 Z0 F500
N80 M30
"""


def test_the_writer_keeps_each_planes_rotary_positions(tmp_path):
    # the same plane with _DIR=-1, then +1: (A, C) = (-30, 180), then (30, 0); the writer's continuity rule alone would stay
    # on the first branch (no travel): the input's positions are kept where they reach the tool axis (fivex/given_angles.py)
    machine = load_machine("xyzac-trt")
    tp = parse_program(_program(tmp_path, TWO_PLANES)).with_frames({"G54": np.eye(4)})
    path = from_toolpath(tp, machine, "tip")
    result = solve(machine, path)
    np.testing.assert_allclose(np.abs(result.axes[:, 3:5]), [(30, 180), (30, 180), (30, 0), (30, 0)], atol=1e-9)
    assert (np.sign(result.axes[:, 3]) == [-1, -1, 1, 1]).all()
    tip, axis = fk(machine, result.axes)
    np.testing.assert_allclose(tip, path.tip, atol=1e-9)
    np.testing.assert_allclose(axis, path.axis, atol=1e-9)
