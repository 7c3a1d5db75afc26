"""The output check's read-back of position numbers (postproc.programs.emit.readback): it answers True
only where a whole re-parse would pass, and every corrupted output still fails the check."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, G54, H1, TOOL

import postproc
from postproc.errors import OutputCheckError, ParseError
from postproc.jobs.compensate import compensate
from postproc.model.effects import parse_effects
from postproc.model.sim import random_truth
from postproc.programs import check_texts, dialects, emit_texts, parse_program
from postproc.programs.emit import readback
from postproc.programs.emit.splice import TOLERANCE
from postproc.programs.ir import F_POS, Kind, SourceDoc

TOL = TOLERANCE[F_POS] * (1 + 1e-6)


@pytest.fixture(scope="module")
def model():
    robot = postproc.load_robot("kr160_r1570")
    return random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE), np.random.default_rng(3))


def _krl(path, n=300):
    lines = ["DEF raster( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$APO.CDIS = 0.2"]
    lines += [f"LIN {{X {900 + i / 3:.3f}, Y {-200 + (i % 40) * 10:.3f}, Z 450.000, A 0, B 180, C 0}} C_DIS" for i in range(n)]
    path.write_text("\n".join(lines + ["END"]) + "\n", encoding="latin-1")
    return path, {}


def _gcode(path, n=300):
    lines = ["%", "G21 G90 G17", "G54", "G43.5 H1"]
    lines += [f"G1 X{i / 3:.3f} Y{-200 + (i % 40) * 10:.3f} Z0 I{np.sin(i / 50) / 6:.6f} J0 K{np.cos(np.sin(i / 50) / 6):.6f} F3000" for i in range(n)]
    path.write_text("\n".join(lines + ["G49", "M30", "%"]) + "\n", encoding="latin-1")
    return path, {"frames": {"G54": G54}, "tools": {"H1": H1}}


def _compensated(tmp_path, model, make, suffix):
    path, options = make(tmp_path / f"p{suffix}")
    tp = parse_program(path)
    new, rep = compensate(tp, model, **options)
    assert rep.compensated.all()
    return tp, new, emit_texts(tp, new), np.nonzero(rep.compensated)[0]


CASES = [(_krl, ".src"), (_gcode, ".ngc")]


@pytest.mark.parametrize("make,suffix", CASES)
def test_a_sound_output_is_read_back_without_a_reparse(tmp_path, model, make, suffix):
    tp, new, texts, rows = _compensated(tmp_path, model, make, suffix)
    assert texts[0] != tp.sources[0].text
    assert readback.positions_read_back(tp, new, texts, rows, TOL)
    check_texts(tp, new, texts, rows)


def _corruptions(tp, text):
    """(what, the text, whether the whole re-parse fails it too): a change that leaves every
    position as it was (blank lines, a space) is still no read-back; the re-parse then decides."""
    at = int(tp.spans[0, 0, 1])  # the first target's X
    head, body = text[:at], text[at:]
    krl = text.startswith("DEF")
    digit = body.index("." if krl else ".") - 1
    yield "a digit", head + body[:digit] + ("7" if body[digit] != "7" else "3") + body[digit + 1 :], True
    yield "the end", text[: text.rindex("\n", 0, len(text) - 1) - 12] + "\n", True
    yield "a word", head + (body.replace("Y ", "X ", 5) if krl else body.replace(" Y", " X", 5)), True
    yield "a sign", head + (body.replace("Y -", "Y ", 1) if krl else body.replace(" Y-", " Y", 1)), True
    yield "a line", text.replace("\n", "\n\n", 7), False
    yield "a space", head + body.replace(", Y", ",  Y", 1) if krl else head + body.replace(" Y", "  Y", 1), False


@pytest.mark.parametrize("make,suffix", CASES)
def test_every_corrupted_output_fails_the_check(tmp_path, model, make, suffix):
    tp, new, texts, rows = _compensated(tmp_path, model, make, suffix)
    for what, bad, harmful in _corruptions(tp, texts[0]):
        assert bad != texts[0], what
        assert not readback.positions_read_back(tp, new, [bad] + texts[1:], rows, TOL), what
        if harmful:
            with pytest.raises((OutputCheckError, ParseError)):  # the whole re-parse's answer, as before
                check_texts(tp, new, [bad] + texts[1:], rows)


def _reparse_passes(tp, modified, texts, rows) -> bool:
    """The whole re-parse's verdict (check_texts without the read-back)."""
    back = dialects.of(tp).parse_sources([SourceDoc(d.path, t, d.role) for d, t in zip(tp.sources, texts)])
    return len(back) == len(modified) and bool((np.abs(back.position[rows] - modified.position[rows]) <= TOL).all())


@pytest.mark.parametrize("make,suffix", CASES)
def test_the_read_back_gives_the_reparse_verdict(tmp_path, model, make, suffix):
    """The text of one compensation checked against other positions: near ones (within the
    writing tolerance for some targets, not for others) and far ones; the same verdict."""
    tp, new, texts, rows = _compensated(tmp_path, model, make, suffix)
    verdicts = []
    for shift in (0.0, 0.0001, 0.0003, 0.0004, 0.002, -0.01):
        moved = new.with_positions(new.position + np.array([0.0, shift, 0.0]))
        verdict = _reparse_passes(tp, moved, texts, rows)
        assert readback.positions_read_back(tp, moved, texts, rows, TOL) == verdict, shift
        verdicts.append(verdict)
        if not verdict:
            with pytest.raises(OutputCheckError):
                check_texts(tp, moved, texts, rows)
    assert verdicts[0] and not verdicts[-1]


def test_what_reads_numbers_in_context_takes_the_whole_reparse(tmp_path, model):
    """Partial aggregates (axes inherited from the target before), G91 increments: no read-back."""
    krl = tmp_path / "partial.src"
    krl.write_text("DEF p( )\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n"
                   "LIN {X 900, Y -200, Z 450, A 0, B 180, C 0}\nLIN {X 910, Y -190}\nEND\n", encoding="latin-1")
    tp = parse_program(krl)
    new, rep = compensate(tp, model)
    texts, rows = emit_texts(tp, new), np.nonzero(rep.compensated)[0]
    assert not readback.positions_read_back(tp, new, texts, rows, TOL)
    check_texts(tp, new, texts, rows)
    ngc = tmp_path / "inc.ngc"
    ngc.write_text("%\nG21 G90 G17\nG54\nG43.5 H1\nG1 X0 Y0 Z0 I0 J0 K1 F3000\nG91\nG1 X10 Y5 I0 J0 K1\nG1 X10 Y5 I0 J0 K1\nG90\nM30\n%\n", encoding="latin-1")
    tp = parse_program(ngc)
    new, rep = compensate(tp, model, frames={"G54": G54}, tools={"H1": H1})
    texts, rows = emit_texts(tp, new), np.nonzero(rep.compensated)[0]
    assert not readback.positions_read_back(tp, new, texts, rows, TOL)
    check_texts(tp, new, texts, rows)


def test_real_programs_read_back_as_they_reparse():
    """The real corpus (tests/corpus/real, placed in the shared folder): every program whose
    targets can be moved and written gets the same verdict from the read-back as from the
    whole re-parse (the read-back may only decline), at moves of 14 µm and 0.3 µm rms."""
    from test_real_corpus import _programs, corpus_file

    answered = 0
    for name in _programs():
        try:
            tp = parse_program(corpus_file(name))
        except Exception:  # noqa: BLE001  (refused files are test_real_corpus's subject, not this one's)
            continue
        rows = np.nonzero((tp.kind != Kind.ABSJ) & ~np.isnan(tp.position).any(axis=1))[0]
        rng = np.random.default_rng(0)
        for shift in (0.0137, 0.0003) if len(rows) else ():
            position = tp.position.copy()
            position[rows] += rng.normal(0.0, shift, (len(rows), 3))
            moved = tp.with_positions(position)
            try:
                texts = emit_texts(tp, moved)
            except Exception:  # noqa: BLE001  (loops, shared points: not writable this way)
                break
            if readback.positions_read_back(tp, moved, texts, rows, TOL):
                answered += 1
                assert _reparse_passes(tp, moved, texts, rows), name
                assert not readback.positions_read_back(tp, tp.with_positions(position + 0.01), texts, rows, TOL), name
    assert answered >= 2  # the corpus has programs the read-back takes
