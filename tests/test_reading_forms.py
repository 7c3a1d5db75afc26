"""Program forms controllers run that postproc refused or read wrong (issue 28): each test
writes a small program of its own in the form, and the expected positions are worked out
by hand from the controller manual's rule (quoted at the test)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from helpers import TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.effects import parse_effects
from postproc.model.model_io import save_model
from postproc.model.sim import random_truth
from postproc.programs import parse_program

runner = CliRunner()
MARK = b"\xef\xbb\xbf"


@pytest.fixture(scope="module")
def model_path(tmp_path_factory) -> Path:
    """A geometric error model with random (non-zero) parameters: compensation moves targets."""
    path = tmp_path_factory.mktemp("model") / "model.json"
    save_model(path, random_truth(kr160(), TOOL, parse_effects("geometric"), np.random.default_rng(3)))
    return path


def _krl(folder: Path) -> list[Path]:
    src = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "LIN XP1"]
    for k, (x, y) in enumerate([(900, -200), (1000, 0), (1100, 200)]):
        src.append(f"LIN {{X {x}.000, Y {y}.000, Z {400 + 10 * k}.000, A {10 * k}, B 180, C 0}}")
    src.append("END")
    (folder / "part.src").write_text("\r\n".join(src) + "\r\n")
    (folder / "part.dat").write_text("DEFDAT part\r\nDECL E6POS XP1={X 950,Y 100,Z 420,A 0,B 180,C 0}\r\nENDDAT\r\n")
    return [folder / "part.src", folder / "part.dat"]


def _rapid(folder: Path) -> list[Path]:
    lines = ["MODULE Part", "  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];",
             "  TASK PERS wobjdata wTable := [FALSE,TRUE,\"\",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];",
             "  PROC main()", "    ConfL\\Off;"]
    for i in range(4):
        lines.append(f"    MoveL [[{50.0 * i:.3f},{20.0 * i:.3f},150.000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle\\WObj:=wTable;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    (folder / "part.mod").write_text("\n".join(lines))
    return [folder / "part.mod"]


def _gcode(folder: Path) -> list[Path]:
    lines = ["G21 G90 G54", "G43.5 H1"] + [f"G1 X{20 * i} Y{5 * i} Z0 I0 J0 K1 F500" for i in range(4)] + ["G49", "M2", ""]
    (folder / "part.ngc").write_text("\n".join(lines))
    return [folder / "part.ngc"]


GCODE_SETUP = ["--frame", "G54=900,-100,300,0,180,0", "--tool", "H1=0,0,200"]


def _compensate(program: Path, model: Path, out: Path, *options: str):
    return runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--allow-model-mismatch", *options])


@pytest.mark.parametrize("write, options", [(_krl, []), (_rapid, []), (_gcode, GCODE_SETUP)], ids=["krl", "rapid", "gcode"])
def test_byte_order_mark_is_read_past_and_written_back(tmp_path, model_path, write, options):
    """A file saved with a UTF-8 byte order mark compensates to the same numbers as without
    it, and every file written starts with the mark again, byte for byte."""
    plain, marked = tmp_path / "plain", tmp_path / "marked"
    plain.mkdir(), marked.mkdir()
    plain_files, marked_files = write(plain), write(marked)
    for path in marked_files:
        path.write_bytes(MARK + path.read_bytes())
    (plain / "out").mkdir(), (marked / "out").mkdir()
    first = _compensate(plain_files[0], model_path, plain / "out" / plain_files[0].name, *options)
    assert first.exit_code == 0, first.output
    second = _compensate(marked_files[0], model_path, marked / "out" / marked_files[0].name, *options)
    assert second.exit_code == 0, second.output
    for path in plain_files:
        expected = (plain / "out" / path.name).read_bytes()
        assert expected != path.read_bytes()  # the targets moved
        assert (marked / "out" / path.name).read_bytes() == MARK + expected
    back = runner.invoke(app, ["roundtrip", str(marked_files[0])])
    assert back.exit_code == 0 and "IDENTICAL" in back.output


def test_byte_order_mark_error_columns_count_as_an_editor_shows(tmp_path):
    """The mark takes no column: 'x' is the 10th character an editor shows on line 1."""
    path = tmp_path / "bad.mod"
    path.write_bytes(MARK + b"MODULE m x\nENDMODULE\n")
    result = runner.invoke(app, ["inspect", str(path)])
    assert result.exit_code == 2
    assert "bad.mod:1:10:" in result.output and "\xef" not in result.output and "ï»¿" not in result.output


@pytest.mark.parametrize("name, text, where, why", [
    ("empty.src", "", ":1:1:", "the file is empty"),
    ("blank.mod", "\n  \n", ":1:1:", "the file is empty"),
    ("comments.src", "; nothing\r\n&ACCESS RVP\r\n", ":1:1:", "the file is empty"),
    ("nodef.src", "&ACCESS RVP\n; c\nDEFDAT x\nENDDAT\n", ":3:1:", "no DEF"),
    ("nodef_motion.src", "LIN {X 1000,Y 0,Z 1000,A 0,B 90,C 0}\n", ":1:1:", "no DEF"),
    ("nomodule.mod", "! a routine without its module\nPROC main()\n  MoveL [[1000,0,1000],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;\nENDPROC\n", ":2:1:", "no MODULE"),
    ("nomotion.src", "DEF p( )\n  $OV_PRO = 50\nEND\n", ":1:1:", "no motion"),
    ("nomotion.mod", "MODULE m\nENDMODULE\n", ":1:1:", "no motion"),
    ("nomotion.ngc", "(setup only)\nG21 G90\nM2\n", ":2:1:", "no motion"),
])
def test_no_program_is_refused_and_nothing_written(tmp_path, model_path, name, text, where, why):
    """compensate and convert refuse a file that holds no program the controller would run
    (or no motion), exit 2, naming file:line:column, and write nothing."""
    path = tmp_path / name
    path.write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    result = _compensate(path, model_path, out / name)
    assert result.exit_code == 2, result.output
    assert f"{name}{where}" in result.output and why in result.output
    converted = runner.invoke(app, ["convert", str(path), "--to", "krl", "-o", str(out / "c.src")])
    assert converted.exit_code == 2 and why in converted.output
    assert list(out.iterdir()) == []


# ----------------------------------------------------------------------------- G-code words
@pytest.mark.parametrize("block, column, says", [
    ("G999 X40 Y10", 1, "G-code out of range"),
    ("N10 G1.5 X40", 5, "Unknown g code used"),
    ("G12 X40", 1, "Unknown g code used"),
    ("G5 X40 Y10 I5 J5 P1 Q1", 1, "G5 cubic spline"),
    ("G7 X40", 1, "G7 lathe diameter mode"),
])
def test_unknown_or_unmodelled_g_words_are_refused_at_their_column(tmp_path, block, column, says):
    """LinuxCNC refuses a G code it does not know ('G999 X40 Y10' was read as a move to
    (40, 10), exit 0); one it knows but postproc does not model is refused too."""
    from postproc.errors import ParseError

    path = tmp_path / "g.ngc"
    path.write_text(f"G21 G90\nG0 X0 Y0 Z0\n{block}\nM2\n")
    with pytest.raises(ParseError, match=rf"g\.ngc:3:{column}: .*{says}"):
        parse_program(path)


def test_codes_the_reader_follows_still_read(tmp_path):
    path = tmp_path / "ok.ngc"
    path.write_text("G21 G90 G17 G40 G49 G80 G94 G8 G97 S1000\nG61\nG64 P0.01\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10\nM2\n")
    assert len(parse_program(path)) == 3


RS274_REFUSES = {"G999 X40 Y10": "G-code out of range", "G1.5 X40": "Unknown g code used", "G12 X40": "Unknown g code used"}


@pytest.mark.skipif(__import__("shutil").which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
def test_rs274_refuses_the_same_words(tmp_path):
    """rs274's own messages for the refused words (the ones quoted in the refusal), and it runs
    G8 / G61 / G64 blocks, which the reader takes."""
    from test_real_corpus import run_rs274

    for block, says in RS274_REFUSES.items():
        path = tmp_path / "g.ngc"
        path.write_text(f"G21 G90\nG0 X0 Y0 Z0\n{block}\nM2\n")
        accepted, _, err = run_rs274(path)
        assert not accepted and says in err, err
    path.write_text("G21 G90 G17 G40 G49 G80 G94 G8 G97 S1000\nG61\nG64 P0.01\nG0 X0 Y0 Z5\nG1 Z0 F100\nG1 X10\nM2\n")
    assert run_rs274(path)[0]


# Other words rs274 refuses (each probed with rs274 -g on "G21 G90 / G0 X0 Y0 Z0 / F100 / <block> /
# M2"; its message is the one quoted): read past before, the block's move kept, exit 0.
WORD_REFUSALS = [
    ("G1 X5 E2", 7, "E word with no G70, G76, M66, M67 or M68 to use it"),
    ("G1 X5 Y1e3", 9, "E word with no G70, G76, M66, M67 or M68 to use it"),  # no exponents: Y1 E3
    ("M1.5", 1, "Non integer value for integer"),
    ("M1000", 1, "M-code greater than 199"),
    ("G1 X5 N5", 7, "Bad character 'n' used"),
]
# M codes LinuxCNC does not build in: rs274 (no configuration) refuses them; a configuration may
# define them (REMAP up to M999, user M100-M199; LinuxCNC's 5-axis demos use M428), so they
# are read with a note quoting rs274.
M_NOTED = [("G1 X5 M10", "Unknown m code used"), ("M47", "Unknown m code used"), ("M150", "Unknown m code used"),
           ("M428", "M-code greater than 199")]


@pytest.mark.parametrize("block, column, says", WORD_REFUSALS)
def test_words_rs274_refuses_are_refused_at_their_column(tmp_path, block, column, says):
    from postproc.errors import ParseError

    path = tmp_path / "w.ngc"
    path.write_text(f"G21 G90\nG0 X0 Y0 Z0\nF100\n{block}\nM2\n")
    with pytest.raises(ParseError, match=rf"w\.ngc:4:{column}: .*{re.escape(says)}"):
        parse_program(path)


@pytest.mark.parametrize("block, says", M_NOTED)
def test_m_codes_a_configuration_must_define_are_read_with_a_note(tmp_path, block, says):
    path = tmp_path / "w.ngc"
    path.write_text(f"G21 G90\nG0 X0 Y0 Z0\nF100\n{block}\nM2\n")
    tp = parse_program(path)
    code = block.split("M")[-1]
    assert any(n.startswith(f"line 4: M{code} is not built into LinuxCNC") and says in n for n in tp.notes), tp.notes


def test_m_codes_linuxcnc_runs_still_read(tmp_path):
    """Every M code rs274 ran in the probe (M0-M9, M19, M30, M48-M53, M60-M73, M98/M99 where
    they need no other word): read without a note."""
    path = tmp_path / "m.ngc"
    path.write_text("G21 G90\nM3 S1000\nM7\nM8\nM9\nM19\nM48\nM49\nM50 P1\nM51 P1\nM52 P1\nM53 P1\nM70\nM71\nM73\n"
                    "G0 X0 Y0 Z0\nG1 X5 F100\nM5\nM30\n")
    tp = parse_program(path)
    assert len(tp) == 2 and not any("M" in n for n in tp.notes), tp.notes


@pytest.mark.skipif(__import__("shutil").which("rs274") is None, reason="LinuxCNC's rs274 is not installed")
def test_rs274_says_the_same_of_these_words(tmp_path):
    from test_real_corpus import run_rs274

    for block, says in [(b, s) for b, _, s in WORD_REFUSALS] + M_NOTED:
        path = tmp_path / "w.ngc"
        path.write_text(f"G21 G90\nG0 X0 Y0 Z0\nF100\n{block}\nM2\n")
        accepted, _, err = run_rs274(path)
        assert not accepted and says in err, (block, err)
    path.write_text("G21 G90\nM3 S1000\nM7\nM8\nM9\nM19\nM48\nM49\nM50 P1\nM51 P1\nM52 P1\nM53 P1\nM70\nM71\nM73\n"
                    "G0 X0 Y0 Z0\nG1 X5 F100\nM5\nM30\n")
    assert run_rs274(path)[0]


# --------------------------------------------------------------------- KRL LIN_REL #TOOL/#BASE
REL = ("DEF rel( )\r\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\r\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\r\n"
       "LIN {X 1000, Y 100, Z 500, A 0, B 90, C 0}\r\nLIN_REL {X -5} C_VEL #TOOL\r\nLIN_REL {Z 100} C_VEL #BASE\r\n"
       "LIN_REL {X 50, Y 20} #BASE\r\nPTP_REL {X 10} #TOOL\r\nEND\r\n")


def test_relative_motions_in_the_tool_and_base_frame(tmp_path):
    """KSS 8.3 'LIN_REL' / 'PTP_REL': #BASE (the default) adds the increment in the base frame,
    #TOOL in the tool frame at the start of the motion. Worked by hand: at A 0, B 90, C 0 the
    tool's X axis is Ry(90) x = (0, 0, -1) in the base, so {X -5} #TOOL goes +5 in Z: (1000, 100,
    505); {Z 100} #BASE: (1000, 100, 605); {X 50, Y 20} #BASE: (1050, 120, 605); PTP_REL {X 10}
    #TOOL: -10 in Z: (1050, 120, 595). The orientation is unchanged throughout."""
    path = tmp_path / "rel.src"
    path.write_bytes(REL.encode())
    tp = parse_program(path)
    np.testing.assert_allclose(tp.position, [[1000, 100, 500], [1000, 100, 505], [1000, 100, 605], [1050, 120, 605], [1050, 120, 595]], atol=1e-9)
    assert tp.resolved.all()
    np.testing.assert_allclose(np.abs(tp.orientation), np.abs(tp.orientation[:1]).repeat(5, axis=0), atol=1e-12)


def test_a_frame_word_after_an_absolute_motion_is_refused(tmp_path):
    from postproc.errors import ParseError

    path = tmp_path / "bad.src"
    path.write_text("DEF bad( )\nLIN {X 1000, Y 0, Z 500, A 0, B 90, C 0} #TOOL\nEND\n")
    with pytest.raises(ParseError, match=r"bad\.src:2:1: #TOOL after LIN"):
        parse_program(path)


def test_base_frame_relative_motions_are_compensated_and_written_back(tmp_path, model_path):
    path = tmp_path / "rel.src"
    path.write_bytes(REL.replace(" #TOOL", " #BASE").encode())
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "rel.src")
    assert result.exit_code == 0, result.output
    before, after = parse_program(path), parse_program(tmp_path / "out" / "rel.src")
    assert "#BASE" in (tmp_path / "out" / "rel.src").read_text()
    assert np.abs(after.position - before.position).max() > 1e-3  # the increments were rewritten


# ---------------------------------------------------------------------------- RAPID forms
RAPID_FORMS = """MODULE Forms
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wTable := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p1 := [[0,0,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    VAR num a := 1;
    IF a <= 2 THEN a := 0; ENDIF
    FOR i FROM 1 TO 3 DO MoveL Offs(p1, i*10, 0, 0), v100, fine, tSpindle\\WObj:=wTable; ENDFOR
    Go p1 \\Fast;
  ENDPROC
  PROC Go(robtarget p \\switch Fast)
    Stay \\Fast?Fast;
  ENDPROC
  PROC Stay(\\switch Fast)
    MoveL Offs(p1, 0, 40, 0), v100, fine, tSpindle\\WObj:=wTable;
  ENDPROC
ENDMODULE
"""


def test_rapid_switch_parameters_compact_blocks_and_conditional_arguments(tmp_path, model_path):
    """RAPID kernel reference: an optional parameter needs no comma before it ('PROC Go(robtarget
    p \\switch Fast)'); statements end with ';', not with the line ('IF a <= 2 THEN a := 0; ENDIF'
    is an IF block on one line); '\\Fast?Fast' passes the switch on where the caller gave it.
    Worked by hand: wTable is at (900, -100, 300) unturned, so Offs(p1, i*10, 0, 0) for i = 1..3
    is (910, -100, 450), (920, ...), (930, ...), and Stay's target (900, -60, 450)."""
    path = tmp_path / "forms.mod"
    path.write_text(RAPID_FORMS)
    tp = parse_program(path)
    np.testing.assert_allclose(tp.base_positions(), [[910, -100, 450], [920, -100, 450], [930, -100, 450], [900, -60, 450]], atol=1e-9)
    assert tp.resolved.all()


# ------------------------------------------------------------------ KRL FRAME arrays and FOR to n
def _frame_array(folder: Path, count: int, set_n: str = "n = {count}") -> Path:
    src = ["DEF gf( )", "DECL INT i", "DECL INT n", "$BASE = {X 0,Y 0,Z 0,A 0,B 0,C 0}", "$TOOL = {X 0,Y 0,Z 200,A 0,B 0,C 0}",
           set_n.format(count=count), "FOR i = 1 TO n", "  LIN gfPoint[i] C_DIS", "ENDFOR", "END"]
    dat = ["DEFDAT gf PUBLIC", f"DECL GLOBAL FRAME gfPoint[{count}]"]
    dat += [f"gfPoint[{i}]={{X {800 + i:.1f},Y {-i:.1f},Z {300 + 0.5 * i:.2f},A 0.0,B 180.0,C 0.0}}" for i in range(1, count + 1)]
    (folder / "gf.src").write_bytes(("\r\n".join(src) + "\r\n").encode())
    (folder / "gf.dat").write_bytes(("\r\n".join(dat + ["ENDDAT"]) + "\r\n").encode())
    return folder / "gf.src"


def test_a_for_to_a_constant_count_reads_every_element(tmp_path):
    """KSS 8 'FOR': the loop runs i = 1 .. n, n evaluated when it starts; 'n = 2000' in the DEF's
    straight-line code is that constant. Element i is (800 + i, -i, 300 + i/2) in the base."""
    tp = parse_program(_frame_array(tmp_path, 2000))
    i = np.arange(1, 2001)
    np.testing.assert_allclose(tp.position, np.stack([800 + i, -i, 300 + 0.5 * i], axis=1), atol=1e-9)
    assert tp.resolved.all() and not tp.notes


def test_a_count_set_in_a_block_stays_unknown(tmp_path):
    tp = parse_program(_frame_array(tmp_path, 5, "IF $IN[1] THEN\r\n  n = {count}\r\nENDIF"))
    assert len(tp) == 1 and any("number of passes of this FOR is not known" in n and "straight-line" in n for n in tp.notes)


# -------------------------------------------------------------------- convert: unknown axes, helices
def test_convert_names_the_unknown_axis_and_how_to_give_it(tmp_path):
    path = tmp_path / "face.ngc"
    path.write_text("G21 G90 G17\nG54 G0 X-30 Y0\nG0 Z2\nG1 X30 F500\nM2\n")
    result = runner.invoke(app, ["convert", str(path), "--to", "krl", "-o", str(tmp_path / "out.src"), "--frame", "G54=900,0,300,0,180,0"])
    assert result.exit_code == 2
    assert "face.ngc:2:1: target position unknown in the input: Z: never set since the program start" in " ".join(result.output.split())
    assert "give Z in this block" in " ".join(result.output.split())
    assert not (tmp_path / "out.src").exists()


def test_convert_splits_a_helix_on_request(tmp_path):
    """--arc-tol: a helix (G3 about (0, 0) from (10, 0, 0) to (-10, 0, -2), half a turn) as
    straight moves whose ends lie on the helix (radius 10, Z linear in the angle) and whose
    chords stay within the tolerance: n = ceil(pi / (2 acos(1 - 0.01 / 10))) = 36 pieces."""
    path = tmp_path / "helix.ngc"
    path.write_text("G21 G90 G17 G54\nG0 X10 Y0 Z0\nG3 X-10 Y0 Z-2 I-10 J0 F300\nM2\n")
    out = tmp_path / "helix.src"
    result = runner.invoke(app, ["convert", str(path), "--to", "krl", "-o", str(out), "--frame", "G54=0,0,0,0,0,0", "--arc-tol", "0.01"])
    assert result.exit_code == 0, result.output
    tp = parse_program(out)
    pts = tp.position[1:]
    assert len(pts) == 36
    angle = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), 10.0, atol=1e-3)
    np.testing.assert_allclose(pts[:, 2], -2.0 * angle / np.pi, atol=1e-3)
    np.testing.assert_allclose(pts[-1], [-10, 0, -2], atol=1e-3)


# --------------------------------------------------------------- KUKA inline forms with $config.dat
def test_inline_forms_take_their_frames_from_config_dat_beside_the_program(tmp_path):
    """A smartPAD program as written (INI fold with BAS(#INITMOV,0), then inline forms): FDAT
    TOOL_NO 1 / BASE_NO 2 are TOOL_DATA[1] / BASE_DATA[2] of the $config.dat beside it
    (BAS.SRC FRAMES()). BASE_DATA[2] = {X 0, Y 2000, A 90}: XP1 (100, 0, 500) turned 90 deg about
    Z is (0, 100, 500), + (0, 2000, 0) = (0, 2100, 500)."""
    from test_krl_inline_forms import CONFIG, INI, fold, placed, program

    tp = program(tmp_path, INI + fold("PTP", "P1", "FP1", ""))
    np.testing.assert_allclose(placed(tp), [[0, 2100, 500]], atol=1e-9)
    alone = tmp_path / "alone"
    alone.mkdir()
    missing = program(alone, INI + fold("PTP", "P1", "FP1", ""), config=None)  # no $config.dat: flagged, never guessed
    assert np.isnan(placed(missing)).all() and "BASE_DATA[2]" in " ".join(missing.frame_names)
    assert "BASE_DATA[2]={X 0,Y 2000" in CONFIG


def test_tool_frame_steps_are_compensated_and_written_back_in_the_tool_frame(tmp_path, model_path):
    """A #TOOL step's increments stay in the tool frame: the written program, read back by the
    KSS rule above, puts every target where the compensation put it (within the 0.5 um the
    numbers are written to), and the steps keep their #TOOL / #BASE words."""
    from postproc.jobs.compensate import compensate
    from postproc.model.model_io import load_model

    path = tmp_path / "rel.src"
    path.write_bytes(REL.encode())
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "rel.src")
    assert result.exit_code == 0, result.output
    text = (tmp_path / "out" / "rel.src").read_text()
    assert text.count("#TOOL") == 2 and text.count("#BASE") == 2
    model, _ = load_model(model_path)
    expected, _ = compensate(parse_program(path), model)
    back = parse_program(tmp_path / "out" / "rel.src")
    assert np.abs(back.position - expected.position).max() < 1e-3
    assert np.abs(back.position - parse_program(path).position).max() > 0.1  # the model moved them


# ------------------------------------------------------------------ RAPID runtime assignments
RAPID_UPDATES = """MODULE m
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wobj1 := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR robtarget p1 := [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\\Off;
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1.trans := [100, 50, 120];
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    p1.trans.z := 130;
    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;
    wobj1.oframe.trans := [100, 50, 0];
    MoveL [[0,0,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tSpindle\\WObj:=wobj1;
  ENDPROC
ENDMODULE
"""


def test_rapid_constant_assignments_in_straight_line_code_are_followed(tmp_path):
    """RAPID runs a routine's statements in order: the move before 'p1.trans := [100, 50, 120]'
    goes to the declared p1, the one after to the new one. Worked by hand: wobj1's uframe is at
    (900, -100, 300), unturned: p1 (10, 20, 150) -> (910, -80, 450); (100, 50, 120) -> (1000,
    -50, 420); z := 130 -> (1000, -50, 430); after 'wobj1.oframe.trans := [100, 50, 0]' the
    literal (0, 0, 150) is at 900 + 100, -100 + 50, 300 + 150 = (1000, -50, 450)."""
    path = tmp_path / "upd.mod"
    path.write_text(RAPID_UPDATES)
    tp = parse_program(path)
    np.testing.assert_allclose(tp.base_positions(), [[910, -80, 450], [1000, -50, 420], [1000, -50, 430], [1000, -50, 450]], atol=1e-9)
    assert tp.resolved.all() and not tp.notes


def test_rapid_assignment_in_a_block_still_leaves_the_targets_unresolved(tmp_path):
    path = tmp_path / "upd.mod"
    path.write_text(RAPID_UPDATES.replace("    p1.trans := [100, 50, 120];", "    IF DInput(di1) = 1 THEN p1.trans := [100, 50, 120]; ENDIF"))
    tp = parse_program(path)
    assert not tp.resolved[:3].any() and any("p1 is assigned" in n for n in tp.notes)


def test_rapid_followed_assignments_are_compensated_into_their_own_numbers(tmp_path, model_path):
    """The target after 'p1.trans := [...]' has its numbers in the assignment: the compensation
    is written there, the declaration keeps the first move's."""
    path = tmp_path / "upd.mod"
    path.write_text(RAPID_UPDATES.replace("    p1.trans.z := 130;\n    MoveL p1, v100, fine, tSpindle\\WObj:=wobj1;\n", ""))
    (tmp_path / "out").mkdir()
    result = _compensate(path, model_path, tmp_path / "out" / "upd.mod")
    assert result.exit_code == 0, result.output
    text = (tmp_path / "out" / "upd.mod").read_text()
    assert "p1.trans := [100, 50, 120];" not in text and "p1.trans := [" in text
    back = parse_program(tmp_path / "out" / "upd.mod")
    assert back.resolved.all() and np.abs(back.base_positions() - parse_program(path).base_positions()).max() > 1e-3


def test_rapid_assignment_of_a_target_also_passed_to_a_routine_is_not_followed(tmp_path):
    path = tmp_path / "upd.mod"
    text = RAPID_UPDATES.replace("    wobj1.oframe.trans", "    shift p1;\n    wobj1.oframe.trans").replace(
        "ENDMODULE", "  PROC shift(INOUT robtarget p)\n    p := Offs(p, 0, 0, 10);\n  ENDPROC\nENDMODULE")
    path.write_text(text)
    tp = parse_program(path)
    assert not tp.resolved[:3].any() and tp.resolved[3]


def test_rapid_assignment_of_a_target_searchl_writes_is_not_followed(tmp_path):
    """SearchL writes where the signal came into its search point (instruction SearchL): a
    robtarget it writes is not known after it, constant assignments or not."""
    path = tmp_path / "upd.mod"
    path.write_text(RAPID_UPDATES.replace("    wobj1.oframe.trans", "    SearchL \\Stop, di1, p1, [[0,0,100],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v20, tSpindle\\WObj:=wobj1;\n    wobj1.oframe.trans"))
    tp = parse_program(path)
    named = np.array([str(n).upper() == "P1" for n in tp.target_name])
    assert not tp.resolved[named].any()


def test_a_tool_frame_step_before_any_target_is_unknown(tmp_path):
    """The first motion starts where the robot is, which the text does not give: a #TOOL step
    from there is not placed (it was never stepped from the origin)."""
    path = tmp_path / "first.src"
    path.write_text("DEF first( )\nLIN_REL {X 5} #TOOL\nLIN {X 1000,Y 0,Z 500,A 0,B 90,C 0}\nEND\n")
    tp = parse_program(path)
    assert tp.resolved.tolist() == [False, True] and np.isnan(tp.position[0]).all()
