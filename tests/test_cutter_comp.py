"""Cutter radius compensation (G41 / G42, G41.1 / G42.1, G40): the IR reports the offset path
the controller cuts, judged by LinuxCNC's rs274 on small programs of our own.

LinuxCNC manual, G-codes, "G41, G42 Cutter Compensation" and "G41.1, G42.1 Dynamic Cutter
Compensation", and "Cutter Compensation" (tool-compensation.adoc): G41 keeps the tool on
the left of the programmed path, G42 on the right; G41 / G42 D take the diameter of tool D
from the tool table ("the data can be set at run time with G10 L1"), G41.1 / G42.1 D give
the diameter itself. "The end point of each move depends on the next move. If the next move
creates an outside corner the move will be to the end point of the compensated cut line. If
the next move creates in an inside corner the move will stop short so to not gouge the part."
"The minimum length [of the entry move] is the cutter radius." After G40 the next move goes
from the compensated point to its programmed end, and must be straight.

Each program here is run by rs274 (recordings in tests/data/rs274/cutter_comp/, rewritten by
``python tests/test_cutter_comp.py --record``); every motion call's end point, and every arc's
centre, must equal the IR's target (rs274 prints 4 decimals: 5e-5 mm + 1e-6). Where the
compensation is not followed (a radius in the machine's tool table, an entry move shorter
than the radius that LinuxCNC refuses) the targets under it are flagged, never guessed.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from rs274_recordings import assert_current, needs_rs274, record_all  # noqa: E402
from test_real_corpus import _moves, canonical_endpoints, machine_positions, run_rs274  # noqa: E402

from postproc.errors import EmitError  # noqa: E402
from postproc.programs import emit_texts, parse_program  # noqa: E402
from postproc.programs.arcs import describe  # noqa: E402
from postproc.programs.ir import Kind  # noqa: E402

RECORDED = Path(__file__).parent / "data" / "rs274" / "cutter_comp"
HEAD = "G21 G17 G90 G40 G94\nG0 X-10 Y-10 Z5\nG1 Z-1 F300\n"
SQUARE = "G1 X0 Y0\nX30\nY20\nX0\nY0\nG40\nG1 X-10 Y-10\nG0 Z5\nM2\n"
HEAD18 = "G21 G18 G90 G40 G94\nG0 X-10 Z-10 Y5\nG1 Y-1 F300\n"
SQUARE18 = "G1 X0 Z0\nX30\nZ20\nX0\nZ0\nG40\nG1 X-10 Z-10\nG0 Y5\nM2\n"

PROGRAMS = {
    # G42 around a counter-clockwise square: the tool outside, an arc about each (convex) corner
    "outside_square": HEAD + "G42.1 D4\n" + SQUARE,
    # G41 around it: the tool inside, each move cut back where the offsets meet (concave corners)
    "inside_square": HEAD + "G41.1 D4\n" + SQUARE,
    # lines into arcs and arcs into lines, convex and concave, R and I J words, a full circle
    "line_arc": HEAD + "G41.1 D3\nG1 X0 Y0\nX20\nG3 X30 Y10 R10\nG1 Y30\nG2 X20 Y40 I-10 J0\nG1 X10\nG3 X0 Y30 I0 J-10\n"
    "G1 Y20\nG2 X0 Y10 J-5\nG1 Y0\nG40\nG1 X-10 Y-10\nM2\n",
    # arc into arc at corners (outside and inside)
    "arc_arc": HEAD + "G42.1 D2\nG1 X0 Y0\nG2 X20 Y0 R10\nG2 X40 Y0 R10\nG3 X60 Y0 R10\nG3 X40 Y0 R10\nG1 Y-20\nG40\nG1 X-10 Y-20\nM2\n",
    # a pocket: the tool inside an arc at an inside corner (line into arc), then tangent, then line into line
    "pocket_line_arc": HEAD + "G41.1 D4\nG1 X0 Y0\nX20\nG3 X10 Y10 I-10 J0\nG1 X0\nY0\nG40\nG1 X-10 Y-10\nM2\n",
    # a lens-shaped pocket (two circles' intersection): arc into arc at inside corners, the tool inside both
    "lens_arc_arc": "G21 G17 G90 G40\nG0 X6 Y-20 Z1\nG41.1 D4\nG1 X6 Y-8 F100\nG3 X6 Y8 I-6 J8\nG3 X6 Y-8 I6 J-8\n"
    "G3 X6 Y8 I-6 J8\nG40\nG1 X6 Y20\nM2\n",
    # an arc as the entry move (tool outside, then inside after G40), R and I J
    "entry_arc": "G21 G17 G90 G40\nG0 X0 Y-20 Z1\nG42.1 D4\nG2 X20 Y0 I0 J20 F100\nG1 X30\nG40\nG1 X40 Y-10\nG41.1 D3\n"
    "G3 X60 Y10 R20\nG1 Y20\nG40\nG0 X40\nM2\n",
    # G41 D3 with tool 3's radius set in the program (G10 L1 P3 R1.5), an incremental run, Z-only moves
    "tool_table": "G21 G17 G90 G40\nG10 L1 P3 R1.5\nG0 X-10 Y-10 Z5\nG41 D3\nG1 X0 Y0 F200\nG91 X25\nZ-2\nY15\nG90 X0\nZ1\nY0\nG40\nG0 X-10 Y-10\nM2\n",
    # rapids under compensation (a convex corner: a straight traverse, no arc), a radius from a parameter
    "rapids_param": "G21 G17 G90 G40\n#1 = 2.5\nG0 X-10 Y-10 Z5\nG42.1 D[#1 * 2]\nG0 X0 Y0\nX20\nY20\nG1 X0 F100\nG40\nG0 X-10 Y-10\nM2\n",
    # a negative diameter swaps the side; inches
    "negative_inch": "G20 G17 G90 G40\nG0 X-0.5 Y-0.5 Z0.2\nG41.1 D-0.25\nG1 X0 Y0 F10\nX1\nY1\nX0\nY0\nG40\nG1 X-0.5 Y-0.5\nM2\n",
    # G18 (XZ, LinuxCNC's lathe plane): rs274ngc compensates in (first, second) = (Z, X), left / right and G2 / G3 as
    # seen there; arcs' centre words K I. The same square, lines and arcs, an arc entry, G40 exits.
    "g18_outside_square": HEAD18 + "G42.1 D4\n" + SQUARE18,
    "g18_inside_square": HEAD18 + "G41.1 D4\n" + SQUARE18,
    "g18_line_arc": HEAD18 + "G41.1 D3\nG1 X0 Z0\nX20\nG3 X30 Z10 R10\nG1 Z30\nG2 X20 Z40 I-10 K0\nG1 X10\nG3 X0 Z30 I0 K-10\n"
    "G1 Z20\nG2 X0 Z10 K-5\nG1 Z0\nG40\nG1 X-10 Z-10\nM2\n",
    "g18_entry_arc": "G21 G18 G90 G40\nG0 X0 Z-20 Y1\nG42.1 D4\nG2 X20 Z0 I0 K20 F100\nG1 X30\nG40\nG1 X40 Z-10\nG41.1 D3\n"
    "G3 X60 Z10 R20\nG1 Z20\nG40\nG0 X40\nM2\n",
    # G93 (inverse time): rs274 times each compensated move, and the move after G40, by its programmed length (x F)
    "inverse_time_exit": "G21 G17 G90 G40\nG0 X-10 Y-10 Z1\nG41.1 D3\nG93\nG1 X0 Y0 F2\nX20 F3\nG3 X30 Y10 R10 F4\nG40\nG1 X40 Y-10 F2\nM2\n",
    "g18_inverse_time": "G21 G18 G90 G40 G94\nG0 X-10 Z-10 Y1\nG41.1 D3\nG93\nG1 X0 Z0 F2\nX20 F3\nG3 X30 Z10 R10 F4\nG1 Z30 Y0 F2\n"
    "G2 X20 Z40 I-10 K0 F5\nG1 X10 F6\nG3 X0 Z30 I0 K-10 Y-1 F4\nG1 Z0 F3\nG40\nG1 X-10 Z-10 F2\nM2\n",
}


def _program(folder: Path, name: str) -> Path:
    path = folder / f"{name}.ngc"
    path.write_text(PROGRAMS[name])
    return path


def _arc_centres(text: str) -> tuple[np.ndarray, np.ndarray]:
    """rs274's ARC_FEED calls: (arcs, 3) centres x y z (mm; the plane's normal axis NaN) and
    (arcs,) turn signs (+1 counter-clockwise, G3). ARC_FEED(first_end, second_end, first_centre,
    second_centre, rotation, ...): first, second = X Y in the XY plane, Z X in XZ (G18)."""
    scale = 25.4 if "CANON_UNITS_INCHES" in text else 1.0
    plane, centres, turns = "XY", [], []
    for call, args in re.findall(r"(SELECT_PLANE|ARC_FEED)\(([^)]*)\)", text):
        if call == "SELECT_PLANE":
            plane = args.split("_")[-1]
            continue
        v = [float(a) for a in args.split(",")]
        centres.append({"XY": (v[2], v[3], np.nan), "XZ": (v[3], np.nan, v[2])}[plane])
        turns.append(np.sign(v[4]))
    return np.array(centres).reshape(-1, 3) * scale, np.array(turns)


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_offset_path_equals_rs274s(tmp_path, name):
    tp = parse_program(_program(tmp_path, name))
    text = (RECORDED / f"{name}.canon").read_text(encoding="latin-1")
    canon, tol, arc = canonical_endpoints(text)
    keep = _moves(canon, tol, arc)
    ir_arc = np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW))
    rows = _moves(machine_positions(tp), np.full(len(tp), 1e-9), ir_arc)
    assert len(rows) == len(keep), f"rs274 made {len(keep)} moves, the IR has {len(rows)}"
    err = np.abs(machine_positions(tp)[rows] - canon[keep])
    bad = (err > tol[keep, None]).any(axis=1)
    assert not bad.any(), f"line {tp.line[rows[np.argmax(bad)]]}: IR {machine_positions(tp)[rows[np.argmax(bad)]]}, rs274 {canon[keep][np.argmax(bad)]}"
    assert (ir_arc[rows] == arc[keep]).all()
    rs274_centres, rs274_turns = _arc_centres(text)
    centres = np.array([describe(tp)[int(r)]["centre"] for r in np.nonzero(ir_arc)[0]]).reshape(-1, 3)
    in_plane = ~np.isnan(rs274_centres)
    assert in_plane.sum() == 2 * len(rs274_centres)
    np.testing.assert_allclose(centres[in_plane], rs274_centres[in_plane], atol=5e-5 * (25.4 if "G20" in PROGRAMS[name] else 1) + 1e-6)
    np.testing.assert_array_equal(np.where(tp.kind[ir_arc] == Kind.ARC_CCW, 1, -1), rs274_turns)  # G2 / G3 as rs274 turns
    assert tp.resolved.all() and (tp.ccomp != 2).all()


@pytest.mark.parametrize("name", ["inverse_time_exit", "g18_inverse_time"])
def test_inverse_time_speeds_equal_rs274s(tmp_path, name):
    """G93 under G41/G42 (G17 and G18): every feed move's speed (length x F, mm/min) equals
    the feed rate rs274 sets for it (printed to 4 decimals), the move after G40 included."""
    from test_feed_modes import canonical_feeds

    from postproc.programs.emit.feeds import _speeds

    tp = parse_program(_program(tmp_path, name))
    text = (RECORDED / f"{name}.canon").read_text(encoding="latin-1")
    canon, tol, arc = canonical_endpoints(text)
    theirs = canonical_feeds(text)[_moves(canon, tol, arc)]
    rows = _moves(machine_positions(tp), np.full(len(tp), 1e-9), np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)))
    ours, why = _speeds(tp)
    feed = tp.kind[rows] != Kind.RAPID
    assert len(rows) == len(theirs) and feed.sum() >= 4 and (why[rows][feed] == "").all()
    np.testing.assert_allclose(ours[rows][feed], theirs[feed], atol=1e-4)


def test_corner_arcs_are_generated_rows_and_the_text_comes_back_unchanged(tmp_path):
    """A convex corner's arc has no block of its own: an IR row of the block whose move needs it,
    with no words (no spans, nowhere to insert): parse + emit gives the program text back."""
    path = _program(tmp_path, "outside_square")
    tp = parse_program(path)
    corner = np.nonzero(tp.insert_at[:, 1] < 0)[0]
    assert len(corner) == 3 and (tp.kind[corner] == Kind.ARC_CCW).all()  # G42: about the corner counter-clockwise
    assert tp.line[corner].tolist() == [7, 8, 9] and (tp.spans[corner, :, 1] < 0).all() and (tp.ccomp[corner] == 1).all()
    assert emit_texts(tp, tp)[0] == path.read_text()


def test_compensate_refuses_to_write_back_a_compensated_block(tmp_path):
    """The controller offsets the block's words by the radius again: a compensated position is
    never written back as them; refused with file:line."""
    path = _program(tmp_path, "inside_square")
    tp = parse_program(path)
    moved = tp.with_positions(tp.position + np.where(tp.ccomp[:, None] == 1, 0.01, 0.0))
    with pytest.raises(EmitError, match=r"inside_square\.ngc:5:.*cutter radius compensation"):
        emit_texts(tp, moved)


def test_a_radius_in_the_machines_tool_table_is_not_guessed(tmp_path):
    """G41 without D (the loaded tool) and G42 D7 with no G10 L1 P7 R in the program: the
    diameter is on the controller. The targets under it are flagged (positions as
    programmed), the note names the line; the exit move after G40 is known again."""
    prog = tmp_path / "table.ngc"
    prog.write_text("G21 G90 G17\nG0 X-10 Y0 Z1\nG41\nG1 X0 Y0 F100\nX10\nG40\nG0 X-10 Y0\nG42 D7\nG1 X0 Y0\nG40\nG1 X-10 Y0\nM2\n")
    tp = parse_program(prog)
    assert tp.line.tolist() == [2, 4, 5, 7, 9, 11]
    assert tp.resolved.tolist() == [True, False, False, True, False, True]
    np.testing.assert_allclose(tp.position[1:3, :2], [[0, 0], [10, 0]])
    assert any("line 3" in n and "loaded tool" in n for n in tp.notes)
    assert any("line 8" in n and "tool 7" in n and "G10 L1 P7 R" in n for n in tp.notes)


SHORT_ENTRY = "G21 G90 G17\nG0 X0 Y0 Z1\nG41.1 D10\nG1 X3 Y0 F100\nX20\nG40\nG1 X30\nM2\n"


def test_an_entry_move_shorter_than_the_radius_is_flagged(tmp_path):
    """"The minimum length is the cutter radius": LinuxCNC refuses the 3 mm entry of a 5 mm
    radius; the IR flags the targets under that compensation with the line and the reason."""
    prog = tmp_path / "short.ngc"
    prog.write_text(SHORT_ENTRY)
    tp = parse_program(prog)
    assert tp.resolved.tolist() == [True, False, False, True]
    assert any("line 4" in n and "entry move is not greater than the tool radius" in n for n in tp.notes)


@needs_rs274
def test_rs274_refuses_the_short_entry_too(tmp_path):
    prog = tmp_path / "short.ngc"
    prog.write_text(SHORT_ENTRY)
    accepted, _, err = run_rs274(prog)
    assert not accepted and "entry move is not greater than the tool radius" in err


def test_what_linuxcnc_refuses_under_compensation_is_refused(tmp_path):
    """rs274ngc: "Cannot change coordinate systems with cutter radius compensation on", and an
    arc right after G40 ("must be straight"): ParseError at the line."""
    from postproc.errors import ParseError

    for body, line, why in (("G55\n", 5, "coordinate systems"), ("G40\nG2 X0 Y0 I-5\n", 6, "must be straight"),
                            ("G10 L2 P1 X5\n", 5, "active coordinate system"), ("G92 X0\n", 5, "axis offsets"), ("G43 H1\n", 5, "tool offset")):
        prog = tmp_path / "bad.ngc"
        prog.write_text("G21 G90 G17\nG0 X-10 Y0 Z1\nG41.1 D2\nG1 X0 Y0 F100\n" + body + "M2\n")
        with pytest.raises(ParseError, match=rf"bad\.ngc:{line}:.*{why}"):
            parse_program(prog)


# M6 under G41 / G42: rs274's refusal (stderr: its message, then the block it stopped at), the
# block's line. M6 runs before group 7 (LinuxCNC "Order of Execution"): "G40 M6" is refused,
# "G41.1 M6" changes the tool first and is run.
M6_HEAD = "G21 G90 G17\nT2\nG0 X-10 Y0 Z1\nG41.1 D2\nG1 X0 Y0 F100\n"
M6_CASES = {  # body after M6_HEAD -> (line of the refused block, rs274's stderr after "executing")
    "T3 M6\nG1 X10\nG40\nM2\n": (6, "Cannot change tools with cutter radius compensation on\nT3 M6\n"),
    "G1 X10 M6\nG40\nM2\n": (6, "Cannot change tools with cutter radius compensation on\nG1 X10 M6\n"),
    "G1 X10\nG40 M6\nG1 X20\nM2\n": (7, "Cannot change tools with cutter radius compensation on\nG40 M6\n"),
}
M6_RUNS = "G21 G90 G17\nG0 X-10 Y0 Z1\nG41.1 D2 T2 M6\nG1 X0 Y0 F100\nX10\nG40\nT3 M6\nG1 X20 Y-5\nM2\n"


@pytest.mark.parametrize("body", sorted(M6_CASES))
def test_a_tool_change_under_compensation_is_refused_as_rs274_does(tmp_path, body):
    from postproc.errors import ParseError

    prog = tmp_path / "m6.ngc"
    prog.write_text(M6_HEAD + body)
    line, rs274_says = M6_CASES[body]
    with pytest.raises(ParseError, match=rf"m6\.ngc:{line}:1: {rs274_says.splitlines()[0]}"):
        parse_program(prog)
    assert prog.read_text().splitlines()[line - 1] == rs274_says.splitlines()[1]  # the block rs274 names


def test_a_tool_change_before_compensation_in_its_block_is_run(tmp_path):
    prog = tmp_path / "m6.ngc"
    prog.write_text(M6_RUNS)
    tp = parse_program(prog)
    assert tp.resolved.all() and tp.line.tolist() == [2, 4, 5, 8]


@needs_rs274
def test_rs274_refuses_the_tool_changes_and_runs_the_other(tmp_path):
    for body, (_, rs274_says) in M6_CASES.items():
        prog = tmp_path / "m6.ngc"
        prog.write_text(M6_HEAD + body)
        accepted, _, err = run_rs274(prog)
        assert not accepted and err.endswith(rs274_says), err
    prog.write_text(M6_RUNS)
    accepted, _, err = run_rs274(prog)
    assert accepted, err


@needs_rs274
@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_recordings_are_current(tmp_path, name):
    assert_current(_program(tmp_path, name), RECORDED / f"{name}.canon")


if __name__ == "__main__" and "--record" in sys.argv:
    record_all(PROGRAMS, _program, RECORDED)
    print(f"recorded {len(PROGRAMS)} programs in {RECORDED}")


def test_inspect_and_convert_give_the_path_the_machine_cuts(tmp_path):
    """`inspect --json` marks each compensated target (`cutter_comp`: offset / corner);
    `convert --to rapid` writes the offset path, a corner arc as a MoveC through its middle."""
    import json

    from typer.testing import CliRunner

    from postproc.cli import app

    path = _program(tmp_path, "outside_square")
    res = CliRunner().invoke(app, ["inspect", str(path), "--json"])
    assert res.exit_code == 0, res.output
    marks = [m.get("cutter_comp") for m in json.loads(res.output)["moves"]]
    assert marks == [None, None, "offset", "offset", "corner", "offset", "corner", "offset", "corner", "offset", None, None]
    out = tmp_path / "out.mod"
    res = CliRunner().invoke(app, ["convert", str(path), "--to", "rapid", "--frame", "G54=0,0,0,0,0,0", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "MoveC [[31.4142,-1.4142,-1]" in out.read_text() and "MoveL [[32,20,-1]" in out.read_text()


@pytest.mark.parametrize("body, why", [
    ("G17\nG41.1 D8\nG1 X0 Y0\nX10\nG3 X10 Y6 I0 J3\n", "Tool radius not less than arc radius"),  # rs274ngc refuses the arc
    ("G17\nG41.1 D6\nG1 X0 Y0\nG1 X1 Y0\nG1 X1 Y5\n", "Straight move in concave corner cannot be reached by the tool without gouging"),  # rs274ngc refuses
    # G40 leaves the last arc where it ends: rs274ngc checks that end against the arc's programmed sweep and refuses it
    ("G17\nG1 X-19.132 Y-16.6157\nG42.1 D3.98\nG1 X15.5137 Y-4.7755\nG1 Z-0.61\nG0 X-5.4021 Y8.9472\nG1 X13.399 Y5.4067\n"
     "G2 X29.4492 Y-5.7146 R11.1254\nG3 X28.7518 Y-4.7309 I-12.4760 J-8.1057\nG1 Z0.03\n", "(at G40 or the program's end)"),
])
def test_cases_not_followed_are_flagged_with_the_reason(tmp_path, body, why):
    """Never a guessed number: the targets under a compensation not followed are flagged
    (resolved False, ccomp 2) and a note gives the line and the reason."""
    prog = tmp_path / "nf.ngc"
    prog.write_text("G21 G90\nG0 X-10 Y-10 Z1\nG1 F100\n" + body + "G40\nG1 X-10 Y-10\nM2\n")
    tp = parse_program(prog)
    under = tp.ccomp == 2
    assert under.any() and not tp.resolved[under].any() and tp.resolved[~under].all()
    assert any(why in n for n in tp.notes), tp.notes


def _random_program(rng: np.random.Generator) -> str:
    """A G17 program (G21 or G20) of straight moves, Z moves and consistent arcs (I J or R) in
    G90, with G41.1 / G42.1 / G40 (radius 0 to 3 units, negative diameters too) at random places."""
    x, y = rng.uniform(-20, 20, 2).round(4)
    lines = [("G20" if rng.random() < 0.3 else "G21") + " G17 G90 G40", f"G0 X{x} Y{y} Z1", "G1 F100"]
    for _ in range(int(rng.integers(1, 11))):
        r = rng.random()
        if r < 0.12:
            lines.append(["G40", f"G41.1 D{rng.uniform(-4, 6):.2f}", f"G42.1 D{rng.uniform(0, 6):.2f}"][int(rng.integers(3))])
        elif r < 0.6:
            x, y = rng.uniform(-20, 20, 2).round(4)
            lines.append(f"G{[0, 1, 1, 1][int(rng.integers(4))]} X{x} Y{y}" + (f" Z{rng.uniform(-2, 1):.2f}" if rng.random() < 0.2 else ""))
        elif r < 0.67:
            lines.append(f"G1 Z{rng.uniform(-2, 1):.2f}")
        else:
            i, j = rng.uniform(-15, 15, 2)
            a = rng.uniform(0, 2 * np.pi)
            ex, ey = round(x + i + np.hypot(i, j) * np.cos(a), 4), round(y + j + np.hypot(i, j) * np.sin(a), 4)
            g = 2 + int(rng.integers(2))
            if rng.random() < 0.5 and np.hypot(ex - x, ey - y) > 1e-3:
                radius = max(np.hypot(i, j), np.hypot(ex - x, ey - y) / 2 + 1e-3) * (1 if rng.random() < 0.5 else -1)
                lines.append(f"G{g} X{ex} Y{ey} R{radius:.4f}")
            else:
                lines.append(f"G{g} X{ex} Y{ey} I{i:.4f} J{j:.4f}")
            x, y = ex, ey
    return "\n".join(lines + ["M2"]) + "\n"


@needs_rs274
@pytest.mark.parametrize("plane", ["G17", "G18"])
def test_random_programs_equal_rs274s(tmp_path, plane):
    """Differential check (rs274 installed): 120 random compensated programs (in G18: the same
    programs with X Y Z I J read as Z X Y K I, LinuxCNC's lathe plane); where rs274 runs
    one, the IR's every end point equals rs274's and nothing is flagged; where rs274 refuses
    one (a gouge, a too short entry), the IR flags the targets or refuses the block."""
    from postproc.errors import ParseError

    rng = np.random.default_rng(20261123)
    agree = 0
    for n in range(120):
        path = tmp_path / f"r{n}.ngc"
        text = _random_program(rng)
        path.write_text(text if plane == "G17" else text.replace("G17", "G18").translate(str.maketrans("XYZIJ", "ZXYKI")))
        accepted, calls, err = run_rs274(path)
        try:
            tp = parse_program(path)
        except ParseError:
            assert not accepted, f"{path.read_text()}: the IR refuses what rs274 runs"
            continue
        flagged = tp.ccomp is not None and bool((tp.ccomp == 2).any())
        assert flagged != accepted, f"{path.read_text()}: rs274 {'runs' if accepted else 'refuses'} it ({err.strip()[-120:]}), the IR {'flags' if flagged else 'follows'} it"
        if accepted:
            canon, tol, arc = canonical_endpoints(calls)
            keep = _moves(canon, tol, arc)
            rows = _moves(machine_positions(tp), np.full(len(tp), 1e-9), np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW)))
            assert len(rows) == len(keep) and (np.abs(machine_positions(tp)[rows] - canon[keep]) <= tol[keep, None]).all(), path.read_text()
            agree += 1
    assert agree >= 90


def test_compensation_in_the_g19_plane_is_refused_as_rs274_does(tmp_path):
    """rs274ngc: "Cutter radius compensation allowed only in XY, XZ planes" (at the G41 block)."""
    from postproc.errors import ParseError

    prog = tmp_path / "g19.ngc"
    prog.write_text("G21 G90 G19\nG0 Y-10 Z-10 X1\nG41.1 D4\nG1 Y0 Z0 F100\nG40\nM2\n")
    with pytest.raises(ParseError, match=r"g19\.ngc:3:1: Cutter radius compensation allowed only in XY, XZ planes"):
        parse_program(prog)


@needs_rs274
def test_rs274_refuses_compensation_in_the_g19_plane(tmp_path):
    prog = tmp_path / "g19.ngc"
    prog.write_text("G21 G90 G19\nG0 Y-10 Z-10 X1\nG41.1 D4\nG1 Y0 Z0 F100\nG40\nM2\n")
    accepted, _, err = run_rs274(prog)
    assert not accepted and err.endswith("Cutter radius compensation allowed only in XY, XZ planes\nG41.1 D4\n"), err
