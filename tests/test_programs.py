"""Parsers and emitters on the program corpus: lossless round trip, edits, frames, errors."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import EmitError, InputError, ParseError
from postproc.programs import emit_texts, parse_program

CORPUS = Path(__file__).parent / "corpus"
# The first three languages' corpus; real/: test_real_corpus.py, fivex/: test_fivex_*.py, and each later
# language's folder (real programs, licences, refusals among them) its own test_<language>_corpus.py.
HOME_MADE = [p for p in CORPUS.rglob("*") if p.is_file() and p.suffix != ".md" and p.relative_to(CORPUS).parts[0] in ("gcode", "krl", "rapid")]
PROGRAMS = sorted(p for p in HOME_MADE if p.suffix.lower() != ".dat")
runner = CliRunner()


def test_corpus_is_large_and_varied():
    assert len(PROGRAMS) >= 30
    texts = [p.read_bytes() for p in HOME_MADE]
    assert any(b"\r\n" in t for t in texts) and any(b"\r\n" not in t for t in texts)
    assert any(re.search(rb"[\xe0-\xff]", t) for t in texts)  # Latin-1 comments (ä, ü, é ...)
    assert {parse_program(p).dialect for p in PROGRAMS} >= {"rapid", "krl", "gcode"}


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_round_trip_is_byte_identical(path):
    tp = parse_program(path)
    texts = emit_texts(tp, tp)
    for text, doc in zip(texts, tp.sources):
        assert text.encode("latin-1") == Path(doc.path).read_bytes()


def _reparse(tp, texts, tmp_path):
    """Parse the emitted program again (KRL: written next to its emitted .dat)."""
    if tp.dialect == "krl":
        for text, doc in zip(texts, tp.sources):
            (tmp_path / Path(doc.path).name).write_bytes(text.encode("latin-1"))
        return parse_program(tmp_path / Path(tp.sources[0].path).name)
    return parse_program(tp.sources[0].path, tp.dialect, texts[0].encode("latin-1"))


def _editable(tp):
    """Targets whose every position number is in the text as a plain number (or inherited)."""
    present = ~np.isnan(tp.values[:, :3])
    plain = tp.spans[:, :3, 1] >= 0
    # G-code canned-cycle moves and polar ends have no words of their own and nowhere to put one
    writable = tp.insert_at[:, 1] >= 0 if tp.dialect == "gcode" else np.ones(len(tp), bool)
    return (~present | plain).all(axis=1) & ~np.isnan(tp.position).any(axis=1) & writable


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_modify_emit_parse_gives_the_modified_ir(path, tmp_path):
    tp = parse_program(path)
    ok = _editable(tp)
    if not ok.any():
        pytest.skip("no editable target")  # data-only modules (sys_module.sys)
    rng = np.random.default_rng(len(str(path)))
    new = tp.position.copy()
    new[ok] += rng.normal(0.0, 0.3, (ok.sum(), 3))
    fixed_rows = ~ok
    new[fixed_rows] = tp.position[fixed_rows]
    try:
        texts = emit_texts(tp, tp.with_positions(new))
    except EmitError as exc:
        # A target shared by lines asked to move differently, or a non-editable number: the
        # emitter must refuse with a clear error rather than write something else -- and
        # only where the program really has such a target.
        _assert_refusal_is_justified(tp, ok, exc)
        return
    back = _reparse(tp, texts, tmp_path)
    assert len(back) == len(tp)
    assert not np.isnan(back.position[ok]).any(), "an edited target lost its position"
    np.testing.assert_allclose(back.position[ok], new[ok], atol=5.01e-4)


def _assert_refusal_is_justified(tp, moved, exc):
    if "used by lines" in str(exc):
        names = [tp.target_name[i] for i in np.nonzero(moved)[0] if tp.target_name[i]]
        assert len(set(names)) < len(names), "refused as shared, but no point is used twice"
    elif "cannot be compensated" in str(exc):
        assert (tp.insert_at[:, 1] < 0).any(), "refused as a controller-made move, but the program has none"
        assert re.match(r".+:\d+:\d+: ", str(exc)), "the refusal must name file:line:column"
    else:
        assert "cannot be changed" in str(exc), str(exc)
        expression = ~np.isnan(tp.values[:, :3]) & (tp.spans[:, :3, 1] < 0)
        assert expression.any(), "refused as not a plain number, but every coordinate is one"


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_a_uniform_shift_changes_only_numbers(path, tmp_path):
    tp = parse_program(path)
    new = tp.position + 0.0137  # every known coordinate moves alike: no inherited value changes
    try:
        texts = emit_texts(tp, tp.with_positions(new))
    except EmitError as exc:
        _assert_refusal_is_justified(tp, ~np.isnan(tp.position).any(axis=1), exc)  # a coordinate written as an expression
        pytest.skip("the program has a coordinate written as an expression")
    number = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
    for text, doc in zip(texts, tp.sources):
        assert number.sub("#", text) == number.sub("#", doc.text), "only numbers may change"


def test_inspect_resolves_work_objects_and_frames():
    result = runner.invoke(app, ["inspect", str(CORPUS / "rapid" / "milling_wobj.mod"), "--json"])
    assert result.exit_code == 0, result.output
    import json

    doc = json.loads(result.stdout)
    assert doc["dialect"] == "rapid"
    first = doc["moves"][0]
    # uframe (1200, -300, 400) turned 90 deg about z, oframe (10, 20, 0), target (0, 0, 50).
    assert first["xyz"] == pytest.approx([1180.0, -290.0, 450.0], abs=1e-6)
    assert first["line"] == 12 and first["kind"] == "joint" and first["frame"] == "wTable"
    krl = json.loads(runner.invoke(app, ["inspect", str(CORPUS / "krl" / "frame_ops.src"), "--json"]).stdout)
    # BASE_DATA[1] (600, 0, 200) composed with {X 100, Y 50, A 90}: the target (50, 0, 100) -> (700, 100, 300).
    assert krl["moves"][1]["xyz"] == pytest.approx([700.0, 100.0, 300.0], abs=1e-6)
    g = json.loads(runner.invoke(app, ["inspect", str(CORPUS / "gcode" / "work_offsets.ngc"), "--json"]).stdout)
    assert g["moves"][3]["xyz"] == pytest.approx([300.0, 50.0, 10.0])  # G55 set by G10 L2 P2
    inch = json.loads(runner.invoke(app, ["inspect", str(CORPUS / "gcode" / "inch_program.nc"), "--json"]).stdout)
    assert inch["moves"][2]["xyz"] == pytest.approx([25.4, 6.35, -1.27])


def test_krl_partial_aggregates_and_relative_moves():
    tp = parse_program(CORPUS / "krl" / "relative_moves.src")
    np.testing.assert_allclose(tp.position[:4], [[900, 0, 400], [900, 0, 380], [910, 5, 380], [910, 5, 400]])
    tp = parse_program(CORPUS / "krl" / "no_dat.src")
    np.testing.assert_allclose(tp.position[1:], [[700, 0, 500], [700, 100, 500], [700, 100, 450]])


def test_krl_undeclared_point_is_flagged_not_guessed():
    tp = parse_program(CORPUS / "krl" / "ptp_lin_basic.src")
    assert tp.target_name[0] == "XHOME" and tp.kind[0] == 4  # E6AXIS from the .dat: a joint target
    np.testing.assert_allclose(tp.joints[0], [0, -90, 90, 0, 0, 0])
    assert tp.frame_names[tp.frame[1]] == "BASE_DATA[1]" and tp.resolved[1] and not tp.placed()[1]  # BASE_DATA is in $config.dat
    assert not tp.placed()[1:4].any()  # every Cartesian target sits in that undefined base


def test_shared_point_with_conflicting_edits_is_refused():
    tp = parse_program(CORPUS / "rapid" / "control_flow.mod")
    new = tp.position.copy()
    new[0, 0] += 1.0  # pA used on several lines: only one of them moves
    with pytest.raises(EmitError, match="used by lines"):
        emit_texts(tp, tp.with_positions(new))


MALFORMED = [
    ("rapid", "MODULE M\n  PROC main()\n    MoveL p10 v100, z1, tool0;\n  ENDPROC\nENDMODULE\n", 3, "unexpected"),
    ("rapid", "MODULE M\n  PROC main()\n    MoveL p10, v100, z1, tool0;\n  ENDPROC\n", 1, "never closed"),
    ("rapid", "MODULE M\n  PROC main()\n    MoveL p10, v100, z1, tool0\n  ENDPROC\nENDMODULE\n", 3, "missing ';'"),
    ("rapid", "MODULE M\n  PROC main()\n    x := 3 $ 4;\n  ENDPROC\nENDMODULE\n", 3, "unexpected"),
    ("rapid", "MODULE M\n  PROC main()\n  ENDIF\n  ENDPROC\nENDMODULE\n", 3, "does not close"),
    ("krl", "DEF p( )\nLIN {X 10, Y }\nEND\n", 2, "unexpected"),
    ("krl", "DEF p( )\nIF $IN[1] THEN\nLIN {X 1}\nEND\n", 2, "never closed"),
    ("krl", "DEF p( )\nLIN {X 1} C_DIS\nENDFOR\nEND\n", 3, "without its opening"),
    ("krl", "DEF p( )\nPTP {A1 0 @}\nEND\n", 2, "unexpected"),
    ("gcode", "G21 G90\nG1 X10 Y[3 +\nM2\n", 2, "unexpected"),
    ("gcode", "G21\nG1 X10 Y$5\n", 2, "unexpected"),
    ("gcode", "o100 sub\nG1 X1\n", 1, "never closed"),
    ("gcode", "G1 X1\no100 endsub\n", 2, "does not close"),
]


@pytest.mark.parametrize(("dialect", "text", "line", "message"), MALFORMED)
def test_malformed_input_is_a_parse_error_with_position(tmp_path, dialect, text, line, message):
    suffix = {"rapid": ".mod", "krl": ".src", "gcode": ".ngc"}[dialect]
    path = tmp_path / f"bad{suffix}"
    path.write_text(text)
    with pytest.raises(ParseError) as info:
        parse_program(path)
    err = info.value
    assert err.line == line and err.column >= 1 and message in str(err)
    assert str(path) in str(err) and err.excerpt
    result = runner.invoke(app, ["inspect", str(path)])
    assert result.exit_code == 2 and f":{line}:" in result.stderr


def test_truncated_programs_are_parse_errors(tmp_path):
    """A program cut in half is refused with its file and line, or (G-code, which has no
    closing block) reads as exactly the targets before the cut: nothing is invented."""
    for path in PROGRAMS:
        whole = parse_program(path)
        data = path.read_bytes()
        cut = tmp_path / path.name
        cut.write_bytes(data[: len(data) // 2])
        if whole.dialect != "gcode":
            # RAPID loses its ENDMODULE, KRL its END: the open block is named.
            with pytest.raises(ParseError) as info:
                parse_program(cut, whole.dialect)
            assert str(cut) in str(info.value) and info.value.line >= 1, path
            continue
        try:
            part = parse_program(cut, whole.dialect)
        except ParseError as exc:
            assert str(cut) in str(exc) and exc.line >= 1, path
            continue
        complete = part.line < part.line.max(initial=0)  # the last line may be cut mid-word
        assert len(part) <= len(whole), path
        np.testing.assert_array_equal(part.position[complete], whole.position[: len(part)][complete], err_msg=str(path))
        assert (part.line[complete] == whole.line[: len(part)][complete]).all(), path


def test_roundtrip_cli_exit_codes(tmp_path):
    good = [str(p) for p in PROGRAMS[:3]]
    assert runner.invoke(app, ["roundtrip", *good]).exit_code == 0
    bad = tmp_path / "bad.ngc"
    bad.write_text("G1 X[1 +\n")
    result = runner.invoke(app, ["roundtrip", good[0], str(bad)])
    assert result.exit_code == 2 and "ERROR" in result.stdout


def test_dialect_sniffing_and_override(tmp_path):
    text = (CORPUS / "gcode" / "face_mill.nc").read_bytes()
    odd = tmp_path / "program.xyz"
    odd.write_bytes(text)
    assert parse_program(odd).dialect == "gcode"
    with pytest.raises(InputError, match="--dialect"):
        parse_program(odd, "no-such")
    rapid = tmp_path / "program.txt"
    rapid.write_bytes((CORPUS / "rapid" / "circles.mod").read_bytes())
    assert parse_program(rapid).dialect == "rapid"


def test_take_keeps_the_chosen_targets_only(tmp_path):
    path = tmp_path / "p.src"
    path.write_text("DEF p( )\nLIN {X 1, Y 2, Z 3, A 0, B 90, C 0}\nLIN {X 4, Y 5, Z 6, A 0, B 90, C 0}\nPTP XP1\nEND\n")
    tp = parse_program(path)
    one = tp.take([1])
    assert len(one) == 1 and one.position.tolist() == [[4.0, 5.0, 6.0]] and one.line.tolist() == [3]
    assert one.offset is None and one.sources == tp.sources
    masked = tp.take(np.array([True, False, True]))
    assert masked.target_name == (tp.target_name[0], tp.target_name[2]) and masked.line.tolist() == [2, 4]
