"""G-code motion semantics read as LinuxCNC executes them (issue 12): canned cycles, G92 /
G10 L2 / L20 / G53 offsets with an XY rotation, polar @ ^ words.

Each program below is ours; the positions each test expects are worked out by hand from the
LinuxCNC G-code manual (the section is named in the test, linuxcnc.org/docs/html/gcode/g-code.html
and .../gcode/overview.html), in the machine frame, mm. LinuxCNC's own interpreter judges
them too: rs274's output for every program is kept in tests/data/rs274/motion/<name>.canon
(regenerate: python tests/test_gcode_motion.py --record) and the IR is compared with it
the way tests/test_real_corpus.py compares the real corpus; where rs274 is installed the
recordings are checked against a fresh run.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest
from rs274_recordings import assert_current, needs_rs274, record_all
from test_real_corpus import _moves, canonical_endpoints, machine_positions

from postproc.errors import EmitError, ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

RECORDED = Path(__file__).parent / "data" / "rs274" / "motion"

PROGRAMS = {
    # G81 with G98 (back to the initial level) and its modal continuation `X15`
    "g81_g98": "G21 G17 G90 F100\nG0 X0 Y0 Z10\nG98 G81 X5 Y5 Z-2 R2\nX15\nG80\nM2\n",
    # the same with G99 (back to R)
    "g81_g99": "G21 G17 G90 F100\nG0 X0 Y0 Z10\nG99 G81 X5 Y5 Z-2 R2\nX15\nG80\nM2\n",
    # G91: R from the initial level, Z from R, X Y increments repeated L3 times
    "g81_g91_l3": "G21 G17 G90 F100\nG0 X1 Y2 Z3\nG91 G98 G81 X4 Y5 Z-6 R1 L3\nG90 G80\nM2\n",
    # G18: the cycle plane is Z X, the drilling axis Y
    "g81_g18": "G21 G18 G90 F100\nG0 X0 Y10 Z0\nG99 G81 X5 Z5 Y-2 R2\nG80\nM2\n",
    # G19: the cycle plane is Y Z, the drilling axis X; G98 with `Y8` repeating it
    "g81_g19": "G21 G19 G90 F100\nG0 X10 Y0 Z0\nG98 G81 Y5 Z5 X-2 R2\nY8\nG80\nM2\n",
    # G83 peck drilling, Q1.5 (G99 is rs274's start-up retract mode)
    "g83_peck": "G21 G17 G90 F100\nG0 X0 Y0 Z5\nG83 X1 Y1 Z-3 R1 Q1.5\nG80\nM2\n",
    # G92, G92.2, G92.3, G92.1
    "g92_family": "G21 G90\nG0 X10 Y20 Z30\nG92 X0 Y0 Z0\nG0 X5\nG92.2\nG0 Z0\nG92.3\nG0 X0\nG92.1\nG0 Y5\nM2\n",
    # G10 L2 with R90, G10 L20 while active, G53, then a move that keeps the G53 point's X
    "g10_rotation_g53": "G21 G90\nG10 L2 P1 X10 Y0 Z0 R90\nG54 G0 X1 Y0 Z0\nG0 X0 Y2\nG10 L20 P1 X0 Y0\nG0 X1\nG53 G0 X0\nG0 Y0\nM2\n",
    # G10 L2 R90 of the active system: the tool stays, the program point it is at turns
    "g10_l2_active": "G21 G90\nG0 X1 Y0 Z0\nG10 L2 P1 X0 Y0 Z0 R90\nG0 Z1\nG0 X1\nM2\n",
    # polar: absolute, angle only, G91 angle and radius increments, and a word value `sqrt[4]`
    "polar": "G21 G90 F100\nG0 X0 Y0 Z0\nG0 @10 ^90\nG0 ^180\nG91 G0 ^90\nG0 @5\nG90 G1 @2 ^0\nG1 Y sqrt[4]\nM2\n",
    # a bolt circle: G91 G81 with a polar angle increment, L4 repeats
    "polar_bolt_circle": "G21 G17 G90 F100\nG0 X10 Y0 Z0\nG91 G99 G81 R1 Z-3 ^90 L4\nG90 G80\nM2\n",
}


def _program(tmp_path: Path, name: str) -> Path:
    path = tmp_path / f"{name}.ngc"
    path.write_text(PROGRAMS[name], encoding="latin-1")
    return path


def _machine(name: str, tmp_path: Path) -> np.ndarray:
    return machine_positions(parse_program(_program(tmp_path, name)))


def test_g81_g98_returns_to_the_initial_level(tmp_path):
    """Manual, "G81 Drilling Cycle" and "Canned Cycles > Preliminary and In-Between Motion":
    rapid to X Y at the current Z (above R), rapid down to R, feed to Z, rapid out; "G98": out
    to the initial level Z10. `X15` repeats the cycle ("Sticky numbers": Z and R kept)."""
    expected = [(5, 5, 10), (5, 5, 2), (5, 5, -2), (5, 5, 10), (15, 5, 10), (15, 5, 2), (15, 5, -2), (15, 5, 10)]
    got = _machine("g81_g98", tmp_path)
    np.testing.assert_allclose(got[1:], expected, atol=1e-9)


def test_g81_g99_returns_to_r(tmp_path):
    """Manual, "G98/G99 Canned Cycle Return Level": G99 retracts to R (Z2); the next hole
    starts from R, so no move down to R is needed."""
    expected = [(5, 5, 10), (5, 5, 2), (5, 5, -2), (5, 5, 2), (15, 5, 2), (15, 5, -2), (15, 5, 2)]
    tp = parse_program(_program(tmp_path, "g81_g99"))
    np.testing.assert_allclose(machine_positions(tp)[1:], expected, atol=1e-9)
    assert list(tp.kind[1:4]) == [Kind.RAPID, Kind.RAPID, Kind.LINEAR]  # rapid, rapid, feed


def test_g81_incremental_with_repeats(tmp_path):
    """Manual, "Canned Cycles > Common Text" (G91: R is an increment from the initial level,
    Z from R; L repeats the X Y increment) and "G81, Example 2": from (1, 2, 3), R1 puts the R
    plane at 4 (above the tool: first straight up to it), Z-6 the bottom at -2; G98 retracts
    to the R plane here, the higher of the two."""
    holes = [(5, 7), (9, 12), (13, 17)]
    expected = [(1, 2, 4)] + [p for x, y in holes for p in ((x, y, 4), (x, y, -2), (x, y, 4))]
    np.testing.assert_allclose(_machine("g81_g91_l3", tmp_path)[1:], expected, atol=1e-9)


def test_g81_in_the_g18_plane(tmp_path):
    """Manual, "Canned Cycles": in G18 the hole is drilled along Y, positioned in Z X."""
    expected = [(5, 10, 5), (5, 2, 5), (5, -2, 5), (5, 2, 5)]
    np.testing.assert_allclose(_machine("g81_g18", tmp_path)[1:], expected, atol=1e-9)


def test_g81_in_the_g19_plane(tmp_path):
    """Manual, "Canned Cycles": in G19 the hole is drilled along X, positioned in Y Z; G98
    returns to the initial X10 before the next hole."""
    expected = [(10, 5, 5), (2, 5, 5), (-2, 5, 5), (10, 5, 5), (10, 8, 5), (2, 8, 5), (-2, 8, 5), (10, 8, 5)]
    np.testing.assert_allclose(_machine("g81_g19", tmp_path)[1:], expected, atol=1e-9)


def test_g83_pecks(tmp_path):
    """Manual, "G83 Peck Drilling Cycle": feed Q deeper, rapid out to R, rapid back down to
    just above the last depth, until the bottom (the back-off, 0.254 mm, is rs274's)."""
    z = [5, 1, -0.5, 1, -0.246, -2, 1, -1.746, -3, 1]
    expected = [(1, 1, v) for v in z]
    np.testing.assert_allclose(_machine("g83_peck", tmp_path)[1:], expected, atol=1e-9)


def test_g92_family(tmp_path):
    """Manual, "G92 Coordinate System Offset", "G92.1, G92.2 Reset G92 Offsets", "G92.3
    Restore G92 Offsets": at (10, 20, 30) G92 X0 Y0 Z0 makes the offset (10, 20, 30); X5 goes
    to machine 15; G92.2 turns it off (kept in #5211-#5213), Z0 is then machine 0; G92.3 puts
    it back, X0 is machine 10; G92.1 clears it, Y5 is machine 5."""
    expected = [(10, 20, 30), (15, 20, 30), (15, 20, 0), (10, 20, 0), (10, 5, 0)]
    np.testing.assert_allclose(_machine("g92_family", tmp_path), expected, atol=1e-9)


def test_g10_rotation_l20_and_g53(tmp_path):
    """Manual, "G10 L2 Set Coordinate System" (R: rotation about Z of the XY plane), "G10 L20",
    "G53 Move in Machine Coordinates": G54 at (10, 0, 0) turned 90 deg takes program (1, 0) to
    machine (10, 1) and (0, 2) to (8, 0); G10 L20 X0 Y0 there moves the origin to (8, 0);
    X1 is machine (8, 1); G53 X0 goes to machine X0, Y stays 1; Y0 then keeps the program X
    of that point (1, in the turned G54) and reaches machine (8, 1)."""
    expected = [(10, 1, 0), (8, 0, 0), (8, 1, 0), (0, 1, 0), (8, 1, 0)]
    np.testing.assert_allclose(_machine("g10_rotation_g53", tmp_path), expected, atol=1e-9)


def test_g10_l2_rotation_of_the_active_system(tmp_path):
    """Manual, "G10 L2": changing the active system changes the program point the tool is at,
    not the tool: at machine (1, 0) G54 turned 90 deg reads (0, -1); Z1 keeps that X Y
    (machine (1, 0, 1)); X1 is program (1, -1), machine (1, 1, 1)."""
    expected = [(1, 0, 0), (1, 0, 1), (1, 1, 1)]
    np.testing.assert_allclose(_machine("g10_l2_active", tmp_path), expected, atol=1e-9)


def test_polar_words(tmp_path):
    """Manual, "Polar Coordinates": @ radius, ^ angle in degrees; G90 ^180 keeps the radius;
    in G91 ^ is added to the angle and @ to the radius; `Y sqrt[4]` is a unary function as a
    word value ("Unary Operation Value")."""
    expected = [(0, 10, 0), (-10, 0, 0), (0, -10, 0), (0, -15, 0), (2, 0, 0), (2, 2, 0)]
    np.testing.assert_allclose(_machine("polar", tmp_path)[1:], expected, atol=1e-9)


def test_polar_bolt_circle(tmp_path):
    """Manual, "Polar Coordinates" (bolt-hole example) with "Canned Cycles" (G91, L): each
    repeat turns the hole 90 deg about the origin on radius 10."""
    holes = [(0, 10), (-10, 0), (0, -10), (10, 0)]
    expected = [(10, 0, 1)] + [p for x, y in holes for p in ((x, y, 1), (x, y, -2), (x, y, 1))]
    np.testing.assert_allclose(_machine("polar_bolt_circle", tmp_path)[1:], expected, atol=1e-9)


# ------------------------------------------------------------------ refusals

def test_cycle_moves_are_refused_by_compensation_with_file_line_column(tmp_path):
    """A compensated cycle move cannot be written in place: EmitError names file:line:column."""
    path = _program(tmp_path, "g81_g98")
    tp = parse_program(path)
    moved = tp.position.copy()
    moved[3, 2] += 0.01  # the feed to the bottom of the first hole (line 3)
    with pytest.raises(EmitError, match=re.escape(f"{path}:3:5: ")):
        emit_texts(tp, tp.with_positions(moved))
    moved = tp.position.copy()
    moved[0, 0] += 0.01  # only the G0 before the cycle: the cycle starts from it, so it is refused too
    with pytest.raises(EmitError, match=re.escape(f"{path}:3:5: ")):
        emit_texts(tp, tp.with_positions(moved))
    assert emit_texts(tp, tp)[0] == PROGRAMS["g81_g98"]  # unmoved: the text as it was


def test_polar_moves_are_refused_by_compensation(tmp_path):
    path = _program(tmp_path, "polar")
    tp = parse_program(path)
    moved = tp.position.copy()
    moved[1, 0] += 0.01
    with pytest.raises(EmitError, match=re.escape(f"{path}:3:4: ")):  # `G0 @10 ^90`: the @ word
        emit_texts(tp, tp.with_positions(moved))


def test_a_cycle_rs274_refuses_is_refused_with_its_line(tmp_path):
    """R below the bottom (LinuxCNC: "R less than Z in cycle") and a cycle without R."""
    path = tmp_path / "bad.ngc"
    path.write_text("G21 G90 F100\nG0 X0 Y0 Z5\nG81 X1 Y1 Z2 R1\n")
    with pytest.raises(ParseError, match=r"bad.ngc:3:1: .*R less than Z"):
        parse_program(path)
    path.write_text("G21 G90 F100\nG0 X0 Y0 Z5\nG81 X1 Y1 Z-2\n")
    with pytest.raises(ParseError, match=r"bad.ngc:3:1: .*R clearance plane unspecified"):
        parse_program(path)


def test_an_unknown_g92_value_flags_what_follows(tmp_path):
    path = tmp_path / "p.ngc"
    path.write_text("G21 G90\nG0 X1 Y1 Z1\nG92 X#1000\nG0 X2 Y2 Z2\n")
    tp = parse_program(path)
    assert list(tp.resolved) == [True, False]  # the point after the unknown offset is flagged, not guessed


def test_moves_to_a_stored_position_or_a_probe_contact_are_listed_and_flag_what_follows(tmp_path):
    """LinuxCNC manual, G28/G30: "makes a rapid traverse move to the position specified by
    axes including any offsets, then ... to the absolute position of the values in parameters
    5161-5166 for all axes specified" (all axes without words); G38.2: a straight probe move
    that stops at contact. rs274 (default parameters) moves line 5 to Z0 and the probe to
    Z-9.746: neither is in the program, so those targets and the moves after them on those
    axes are flagged until the axes get G90 words again; they were dropped, and line 6 was
    reported at Z10."""
    path = tmp_path / "home.ngc"
    path.write_text("G21 G90 G17\nG10 L2 P1 X0 Y0 Z0\nG54\nG0 X10 Y10 Z10\nG91 G28 Z0\nG90 G1 X30 F100\n"
                    "G1 X1 Y2 Z3\nG38.2 Z-10 F50\nG1 X5\nG1 Z4\nG28\nM2\n")
    tp = parse_program(path)
    assert list(tp.line) == [4, 5, 5, 6, 7, 8, 9, 10, 11]
    assert list(tp.resolved) == [True, True, False, False, True, False, False, True, False]
    assert np.allclose(tp.position[[0, 1, 4, 7], :3], [[10, 10, 10], [10, 10, 10], [1, 2, 3], [5, 2, 4]])
    assert list(tp.kind[[1, 2, 5, 8]]) == [Kind.RAPID, Kind.RAPID, Kind.LINEAR, Kind.RAPID]
    assert any("G28/G30" in n for n in tp.notes)


# ------------------------------------------------------------------ rs274, the judge

@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_ir_matches_the_rs274_recording(name, tmp_path):
    tp = parse_program(_program(tmp_path, name))
    canon, tol, arc = canonical_endpoints((RECORDED / f"{name}.canon").read_text(encoding="latin-1"))
    keep = _moves(canon, tol, arc)
    machine = machine_positions(tp)
    rows = _moves(machine, np.full(len(tp), 1e-9), np.zeros(len(tp), bool))
    assert len(rows) == len(keep), f"rs274 made {len(keep)} moves, the IR {len(rows)}"
    np.testing.assert_allclose(machine[rows], canon[keep], atol=1e-4 + 1e-9)


@needs_rs274
@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_rs274_recordings_are_current(name, tmp_path):
    assert_current(_program(tmp_path, name), RECORDED / f"{name}.canon")


if __name__ == "__main__":
    if sys.argv[1:] == ["--record"]:
        record_all(PROGRAMS, _program, RECORDED)


def test_runs_of_holes_read_at_once_equal_the_block_by_block_reading(tmp_path, monkeypatch):
    """Blocks that only give the next hole are expanded for the whole run at once; the
    result must be the block-by-block one (G98 below R, G99, G83 pecks, G18, F words)."""
    import postproc.programs.dialects.gcode.interp as interp

    holes = "".join(f"X{i * 1.5:.3f} Y{(i % 7) * 0.5:.3f}{' F80' if i % 5 == 0 else ''}\n" for i in range(40))
    zx_holes = "".join(f"X{i * 1.5:.3f} Z{(i % 3) * 0.5:.3f}\n" for i in range(10))
    text = ("G21 G17 G90 F100\nG0 X0 Y0 Z0\nG98 G81 X1 Y1 Z-3 R2\n" + holes + "G99 G83 X0 Y0 Z-4 R1 Q1.5\n" + holes
            + "G80\nG18 G0 Y5\nG81 X0 Z0 Y-1 R1\n" + zx_holes + "G80\nM2\n")
    path = tmp_path / "holes.ngc"
    path.write_text(text)
    fast = parse_program(path)
    slow_run = interp.run
    monkeypatch.setattr(interp, "run", lambda *a, **k: slow_run(*a, **{**k, "fast": False}))
    slow = parse_program(path)
    assert len(fast) == len(slow) > 3 * 90
    np.testing.assert_array_equal(fast.position, slow.position)
    np.testing.assert_array_equal(fast.kind, slow.kind)
    np.testing.assert_array_equal(fast.line, slow.line)


def test_targets_under_cutter_radius_compensation_are_flagged(tmp_path):
    """LinuxCNC manual, G-codes, "G41, G42 Cutter Compensation": with G41/G42 active the
    controller runs the path offset by the tool radius (from the tool table, or the D
    diameter of G41.1/G42.1). G41 D1 takes tool 1's diameter from the machine's tool table,
    which the program does not set (no G10 L1 P1 R): the targets between G41 and G40 are
    flagged (never reported as the programmed contour). G42.1 D2 gives the diameter: the
    entry move ends one radius (1 mm) right of its end point, perpendicular to it
    (tests/test_cutter_comp.py compares such paths with rs274)."""
    prog = tmp_path / "ccomp.ngc"
    prog.write_text("G21 G90 G17\nG0 X0 Y0 Z1\nG41 D1\nG1 X10 Y0 F100\nG1 X10 Y10\nG40\nG0 X0 Y0\nG42.1 D2\nG1 X5 Y5\nG40\nM2\n")
    tp = parse_program(prog)
    assert tp.line.tolist() == [2, 4, 5, 7, 9]
    assert tp.resolved.tolist() == [True, False, False, True, True]
    assert tp.ccomp.tolist() == [0, 2, 2, 0, 1]
    np.testing.assert_allclose(tp.position[4], [5 + 0.5**0.5, 5 - 0.5**0.5, 1.0], atol=1e-12)
    assert any("cutter radius compensation" in n and "line 3" in n and "tool table" in n for n in tp.notes)


def test_a_u_v_w_axis_word_is_refused_with_its_column(tmp_path):
    """A W word moves an axis the IR has no place for: refused at the word (file:line:column),
    never dropped (LinuxCNC's cone.ngc drills with `g1 w100` on a machine with a W axis)."""
    from postproc.errors import ParseError

    prog = tmp_path / "w.ngc"
    prog.write_text("G21 G90\nG0 X0 Y0 Z0\nG1 W100 F100\n")
    with pytest.raises(ParseError, match=r"w\.ngc:3:4.*axis word W"):
        parse_program(prog)
