"""Fuzzing the VAL3 reader: an application (the demo's program, called program and data)
with its program or data file mutated never crashes the reader; every accepted application
writes back byte for byte, every refused one names the file, a line of it and a column (or,
for a missing file, the file). 200 examples from a fixed seed (a few seconds)."""

from __future__ import annotations

import random
import sys
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, Phase, given, note, seed, settings
from hypothesis import strategies as st

from postproc.errors import InputError, ParseError
from postproc.programs import emit_texts, parse_program

DEMO = Path(__file__).parent / "data" / "val3_demo"
FILES = ("start.pgx", "cut.pgx", "demo.dtx", "demo.pjx")
TOKENS = ["movej(", "movel(", "movec(", "appro(", "call cut()", "call ", "for i = 0 to 3", "endFor", "while true", "endWhile",
          "if x", "endIf", "do", "until x", "switch n", "case 1", "endSwitch", "taskCreate ", "link(", "pA[0].x = 1", "pA[9]",
          "pA[i]", "{0,0,-50,0,0,0}", "{1,2}", ",", "(", ")", "[", "]", "//", '"', "\n", "\r\n", "<Value key=\"7\" x=\"1\" />",
          "<Data name=\"pZ\" type=\"pointRx\">", "</Data>", "fatherId=\"fPart[0]\"", "fatherId=\"pA[1]\"", "fatherId=\"x\"",
          'shoulder="sfree"', 'elbow="x"', 'blend="joint"', 'blend="x"', 'x="1e5e3"', 'x="-"', 'key="a,b"', "]]>",
          "<![CDATA[", "<Program name=\"cut\">", "1e308", "-0", "\t", "<!--", "-->"]


def _mutate(rng: random.Random, text: str) -> str:
    lines = text.split("\n")
    for _ in range(rng.randint(1, 3)):
        op = rng.randrange(6)
        i = rng.randrange(len(lines))
        if op == 0 and len(lines) > 1:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[i])
        elif op == 2:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 3 and lines[i]:
            k = rng.randrange(len(lines[i]))
            lines[i] = lines[i][:k] + chr(rng.choice([32, 34, 44, 46, 48, 60, 62, 91, 93, 101, 120, 123, 233])) + lines[i][k + 1:]
        elif op == 4:
            k = rng.randrange(len(lines[i]) + 1)
            lines[i] = lines[i][:k] + rng.choice(TOKENS) + lines[i][k:]
        else:
            lines = lines[: i + 1]
            lines[-1] = lines[-1][: rng.randrange(len(lines[-1]) + 1)]
    return "\n".join(lines)


def judge(folder: Path) -> str:
    """'accepted' (and written back unchanged), 'refused' (ParseError with a place) or
    'refused-file' (InputError naming a file); anything else propagates."""
    program = folder / "start.pgx"
    try:
        tp = parse_program(program)
    except ParseError as exc:
        path = Path(exc.path)
        assert path.parent == folder and path.name in FILES, f"refused in an unknown file: {exc!r}"
        n_lines = path.read_bytes().count(b"\n") + 1
        assert 1 <= exc.line <= n_lines and exc.column >= 1, f"refused without a usable position: {exc!r}"
        assert str(exc).startswith(f"{exc.path}:{exc.line}:{exc.column}: "), str(exc)
        return "refused"
    except InputError as exc:
        assert any(name in str(exc) for name in FILES), f"a refusal that names no file: {exc}"
        return "refused-file"
    texts = emit_texts(tp, tp)
    assert [t.encode("latin-1") for t in texts] == [Path(s.path).read_bytes() for s in tp.sources], "accepted, but parse + emit changed a text"
    return "accepted"


@seed(20261127)
@settings(max_examples=200, deadline=None, database=None, phases=[Phase.generate], suppress_health_check=list(HealthCheck))
@given(st.randoms(use_true_random=False), st.sampled_from(("start.pgx", "cut.pgx", "demo.dtx")))
def test_mutated_applications_are_read_exactly_or_refused_with_a_place(rng, target):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in FILES:
            (folder / name).write_bytes((DEMO / name).read_bytes())
        text = _mutate(rng, (DEMO / target).read_text(encoding="latin-1"))
        (folder / target).write_bytes(text.encode("latin-1"))
        note(f"{target}: {text!r}")
        judge(folder)


def test_the_judge_accepts_the_demo_and_catches_a_changed_text(tmp_path, monkeypatch):
    for name in FILES:
        (tmp_path / name).write_bytes((DEMO / name).read_bytes())
    assert judge(tmp_path) == "accepted"
    real = emit_texts
    monkeypatch.setattr(sys.modules[__name__], "emit_texts", lambda tp, new: [t[:-1] for t in real(tp, new)])
    try:
        judge(tmp_path)
    except AssertionError as exc:
        assert "changed a text" in str(exc)
    else:
        raise AssertionError("the judge let a changed text through")
