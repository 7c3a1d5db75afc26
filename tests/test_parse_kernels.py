"""The compiled parse kernels agree with their definitions: numbers with Python's float,
line shapes with the regular expressions run line by line, name lookup with a dict."""

from __future__ import annotations

import random
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.programs.dialects.gcode import parse as gcode
from postproc.programs.dialects.krl import parse as krl
from postproc.programs.dialects.rapid import parse as rapid
from postproc.programs.parse.common import LineIndex, scan_numbers
from postproc.programs.parse.line_shapes import LineShapes, factorize_spans
from postproc.programs.parse.name_table import NameTable

NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _random_decimal(rng: random.Random) -> str:
    digits = "".join(rng.choice("0123456789") for _ in range(rng.randint(1, 22)))
    cut = rng.randint(0, len(digits))
    text = digits[:cut] + "." + digits[cut:] if rng.random() < 0.8 else digits
    if rng.random() < 0.4:
        text += rng.choice("eE") + rng.choice(["", "-", "+"]) + str(rng.randint(0, 330))
    return ("-" if rng.random() < 0.5 else "") + text


def test_values_are_pythons_float_bit_for_bit():
    """Fast path and fallback together round every decimal exactly as float() does,
    including 16-22 digit mantissas, exponents past 1e22, subnormals and -0."""
    rng = random.Random(7)
    tokens = [_random_decimal(rng) for _ in range(50_000)] + ["-0", "0.0", "1e-320", "9E9", "1.7976931348623157e308", "4.9e-324", "123456789012345678901"]
    got = scan_numbers(" ".join(tokens))
    want = np.array([float(t) for t in tokens])
    assert len(got.value) == len(tokens)
    np.testing.assert_array_equal(got.value, want)
    np.testing.assert_array_equal(np.signbit(got.value), np.signbit(want))


@pytest.mark.parametrize(
    "text, letter_prefix, expected",
    [
        ("p10 tool0 E1 0.5", False, [0.5]),
        ("X-10.5Y.5", True, [-10.5, 0.5]),
        ("a-3 (4)-2 -7", False, [3.0, 4.0, 2.0, -7.0]),
        ("1e5e3 1.2.3 .e1 7", False, [np.nan, np.nan, np.nan, 7.0]),
        ("2E+ 3e-2", False, [2.0, 0.03]),
    ],
)
def test_number_runs_and_signs(text, letter_prefix, expected):
    np.testing.assert_array_equal(scan_numbers(text, letter_prefix).value, expected)


def test_spans_cover_the_number_text():
    text = "LIN {X -1.5, Y +2, Z 3e2} ; 4.0\n"
    nums = scan_numbers(text)
    assert [text[a:b] for a, b in zip(nums.start, nums.end)] == ["-1.5", "+2", "3e2", "4.0"]


# ----------------------------------------------------------------- line shapes
_WORDS = ["LIN", "PTP", "SLIN", "MoveL", "MoveJ", "DECL", "E6POS", "XP", "p", "v", "z", "tool", "C_DIS", "A", "B", "E", "S", "T", "G", "X", "Y", "N", "wobj", "\\WObj:="]
_PUNCT = [" ", " ", ",", "{", "}", "[", "]", "=", ":=", ";", "(", ")", "\t", "\r", "-", "."]


def _line(rng: random.Random) -> str:
    parts = []
    for _ in range(rng.randint(0, 14)):
        r = rng.random()
        if r < 0.35:
            parts.append(str(rng.choice([rng.randint(0, 9), rng.randint(10, 99999)])) + rng.choice(["", ".", "." + str(rng.randint(0, 999))]))
        elif r < 0.65:
            parts.append(rng.choice(_WORDS))
        else:
            parts.append(rng.choice(_PUNCT))
    return "".join(parts)


_TEMPLATES = [
    "LIN {{X {a}, Y {b}, Z {c}, A 0, B 180, C 0}} C_DIS",
    "PTP XP{i} C_PTP",
    "DECL E6POS XP{i}={{X {a},Y {b},Z {c},A 0.0,B 90,C 0,S 2,T 10}}",
    "path[{i}]={{X {a},Y {b},Z {c}}}",
    "    MoveL [[{a},{b},{c}],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v{i}, z1, tool0\\WObj:=wobj{i};",
    "    MoveJ p{i}, v100, fine, tool{i};",
    "CONST robtarget p{i} := [[{a},{b},{c}],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "N{i} G{g} X{a} Y{b} Z{c} F{i}",
    "G{g}X{a}Y{b}(cut {i})",
]


def _program(rng: random.Random, n: int) -> str:
    lines = []
    for _ in range(n):
        if rng.random() < 0.3:
            lines.append(_line(rng))
        else:
            value = lambda: rng.choice(["", "-", "+"]) + str(rng.randint(0, 2000)) + rng.choice(["", ".", ".5", ".125"])  # noqa: E731
            lines.append(rng.choice(_TEMPLATES).format(a=value(), b=value(), c=value(), i=rng.randint(0, 10**rng.randint(0, 6)), g=rng.choice(["0", "1", "01", "2", "03", "4", "17", "1.5"])))
    return "\n".join(lines) + rng.choice(["", "\n"])


def _reference(regex: re.Pattern, text: str):
    return [(m.start(), {g: m.span(g) for g in regex.groupindex}) for m in regex.finditer(text)]


@pytest.mark.parametrize("seed", range(8))
def test_line_shapes_match_exactly_what_the_regex_matches(seed):
    rng = random.Random(seed)
    text = _program(rng, 400)
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    shapes = LineShapes(text, raw, LineIndex(text).starts)
    for regex in (krl.RE_MOVE, krl.RE_DECL, krl.RE_ELEM, rapid.RE_MOVE_LIT, rapid.RE_MOVE_NAME, rapid.RE_DECL, gcode.RE_BULK):
        got = shapes.match(regex)
        want = _reference(regex, text)
        assert got.start.tolist() == [w[0] for w in want], regex.pattern[:40]
        for g in regex.groupindex:
            assert [tuple(s) for s in got.spans[g].tolist()] == [w[1][g] for w in want], g


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(alphabet="LINPTX {},=0123456789.-;\t", max_size=30), max_size=12))
def test_line_shapes_on_arbitrary_lines(lines):
    text = "\n".join(lines)
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    shapes = LineShapes(text, raw, LineIndex(text).starts)
    for regex in (krl.RE_MOVE, krl.RE_ELEM):
        got = shapes.match(regex)
        want = _reference(regex, text)
        assert got.start.tolist() == [w[0] for w in want]
        for g in regex.groupindex:
            assert [tuple(s) for s in got.spans[g].tolist()] == [w[1][g] for w in want]


def test_factorize_folds_case_and_blanks_and_keeps_absent_apart():
    text = "tool0 TOOL0 to ol0 tool1 x"
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    spans = np.array([[0, 5], [6, 11], [12, 18], [19, 24], [-1, -1], [25, 26]])
    codes, texts = factorize_spans(text, raw, spans)
    assert codes[0] == codes[1] == codes[2] != codes[3]
    assert texts[codes[4]] is None and codes[4] not in (codes[0], codes[3], codes[5])
    assert texts[codes[0]] == "tool0" and texts[codes[5]] == "x"


# ------------------------------------------------------------------ name table
def test_name_table_agrees_with_a_dict_and_the_last_declaration_wins():
    rng = random.Random(3)
    names = [rng.choice(["XP", "xp", "P", "base_data"]) + (f"[{rng.randint(0, 50)}]" if rng.random() < 0.5 else str(rng.randint(0, 300))) for _ in range(3000)]
    table = NameTable()
    table.add(names[:1000])
    table.add(names[1000:])
    key = lambda n: n.upper().replace(" ", "")  # noqa: E731
    want = {key(n): i for i, n in enumerate(names)}
    queries = names[::7] + ["XP[ 3 ]", "nothing", "xp 12", ""]
    got = table.rows(queries)
    assert got.tolist() == [want.get(key(q), len(names)) for q in queries]


def test_name_table_survives_a_hash_collision(monkeypatch):
    """Force every name to the same hash: lookups must still compare the names."""
    from postproc.programs.parse import name_table

    monkeypatch.setattr(name_table, "_span_hashes", lambda raw, spans, prime, offset: np.zeros(len(spans), np.uint64))
    table = NameTable()
    table.add(["a1", "b2", "A1", "c3"])
    assert table.rows(["a1", "B2", "c3", "d4"]).tolist() == [2, 1, 3, 4]


def test_line_shapes_survive_a_hash_collision(monkeypatch):
    """Every line hashed alike: lines that differ from their representative are matched one by one."""
    from postproc.programs.parse import line_shapes

    real = line_shapes._shapes

    def colliding(*args):
        hashes, *rest = real(*args)
        return (np.zeros_like(hashes), *rest)

    monkeypatch.setattr(line_shapes, "_shapes", colliding)
    text = _program(random.Random(11), 300)
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    shapes = LineShapes(text, raw, LineIndex(text).starts)
    assert not shapes.exact.all()
    for regex in (krl.RE_MOVE, rapid.RE_MOVE_LIT, gcode.RE_BULK):
        got = shapes.match(regex)
        want = _reference(regex, text)
        assert got.start.tolist() == [w[0] for w in want]
        for g in regex.groupindex:
            assert [tuple(s) for s in got.spans[g].tolist()] == [w[1][g] for w in want]
