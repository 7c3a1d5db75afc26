"""Property tests on generated programs, and fuzzing: no input may crash a parser."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.errors import InputError, ParseError
from postproc.programs import emit_texts, parse_program

CORPUS = Path(__file__).parent / "corpus"

coord = st.floats(min_value=-2000, max_value=2000, allow_nan=False, allow_infinity=False)
decimals = st.integers(min_value=0, max_value=4)


def fmt(value: float, d: int, plus: bool = False) -> str:
    text = f"{value:.{d}f}"
    if text in ("-0", "-0.0", "-0.00", "-0.000", "-0.0000"):
        text = text[1:]
    return ("+" + text) if plus and not text.startswith("-") else text


points = st.lists(st.tuples(coord, coord, coord, decimals), min_size=1, max_size=25)
settings_ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@settings_
@given(points, st.booleans(), st.booleans())
def test_krl_generated_programs(pts, crlf, slow_path):
    nl = "\r\n" if crlf else "\n"
    # slow_path: a WITH clause keeps each move out of the bulk fast path (lark parses it).
    tail = " WITH $VEL.CP = 0.2" if slow_path else " C_DIS"
    lines = ["DEF gen( )"] + [f"LIN {{X {fmt(x, d)}, Y {fmt(y, d)}, Z {fmt(z, d)}, A 0, B 90, C 0}}{tail}" for x, y, z, d in pts] + ["END", ""]
    data = nl.join(lines).encode("latin-1")
    tp = parse_program("gen.src", "krl", data)
    expected = np.array([[float(fmt(x, d)), float(fmt(y, d)), float(fmt(z, d))] for x, y, z, d in pts])
    np.testing.assert_array_equal(tp.position, expected)
    assert emit_texts(tp, tp)[0].encode("latin-1") == data


@settings_
@given(points, st.booleans(), st.booleans())
def test_rapid_generated_programs(pts, crlf, split_lines):
    nl = "\r\n" if crlf else "\n"
    moves = []
    for x, y, z, d in pts:
        target = f"[[{fmt(x, d)},{fmt(y, d)},{fmt(z, d)}],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
        # split_lines: a statement over two lines is not a bulk line (lark parses it).
        moves.append(f"    MoveL {target},{nl}      v100, z1, tool0;" if split_lines else f"    MoveL {target}, v100, z1, tool0;")
    data = nl.join(["MODULE Gen", "  PROC main()", *moves, "  ENDPROC", "ENDMODULE", ""]).encode("latin-1")
    tp = parse_program("gen.mod", "rapid", data)
    expected = np.array([[float(fmt(x, d)), float(fmt(y, d)), float(fmt(z, d))] for x, y, z, d in pts])
    np.testing.assert_array_equal(tp.position, expected)
    assert emit_texts(tp, tp)[0].encode("latin-1") == data


@settings_
@given(points, st.booleans(), st.booleans(), st.booleans())
def test_gcode_generated_programs(pts, compact, plus, slow_path):
    sep = "" if compact else " "
    extra = " M8" if slow_path else ""  # an M word keeps the block out of the fast path
    lines = ["G21 G90"] + [f"G1{sep}X{fmt(x, d, plus)}{sep}Y{fmt(y, d, plus)}{sep}Z{fmt(z, d, plus)}{extra}" for x, y, z, d in pts] + ["M2", ""]
    data = "\n".join(lines).encode("latin-1")
    tp = parse_program("gen.ngc", "gcode", data)
    expected = np.array([[float(fmt(x, d)), float(fmt(y, d)), float(fmt(z, d))] for x, y, z, d in pts])
    np.testing.assert_array_equal(tp.position, expected)
    assert emit_texts(tp, tp)[0].encode("latin-1") == data


@settings_
@given(points, st.floats(min_value=-5, max_value=5, allow_nan=False))
def test_edits_round_trip_through_text(pts, delta):
    lines = ["G21 G90"] + [f"G1 X{fmt(x, d)} Y{fmt(y, d)} Z{fmt(z, d)}" for x, y, z, d in pts] + ["M2", ""]
    data = "\n".join(lines).encode("latin-1")
    tp = parse_program("gen.ngc", "gcode", data)
    new = tp.position + delta
    text = emit_texts(tp, tp.with_positions(new))[0]
    back = parse_program("gen.ngc", "gcode", text.encode("latin-1"))
    np.testing.assert_allclose(back.position, new, atol=5.01e-4)


# ---------------------------------------------------------------- fuzzing

FUZZ_SEEDS = {
    "rapid": [CORPUS / "rapid" / n for n in ("simple_pick.mod", "control_flow.mod", "circles.mod", "functions.mod")],
    "krl": [CORPUS / "krl" / n for n in ("no_dat.src", "control_loops.src", "frame_ops.src", "spline_block.src")],
    "gcode": [CORPUS / "gcode" / n for n in ("arcs_ijk.ngc", "params_and_subs.ngc", "work_offsets.ngc", "face_mill.nc")],
}
ALPHABET = b" \t\r\n;,.:=+-*/()[]{}<>#!'\"\\$%&0123456789ABCDEFGIJKLMNOPRSTXYZabcdefxyz\xe4\xff\x00"


def mutate(data: bytes, rng: random.Random) -> bytes:
    buf = bytearray(data)
    for _ in range(rng.randint(1, 6)):
        op = rng.random()
        pos = rng.randrange(len(buf) + 1)
        if op < 0.35 and buf:
            del buf[min(pos, len(buf) - 1) : min(pos + rng.randint(1, 8), len(buf))]
        elif op < 0.7:
            buf[pos:pos] = bytes(rng.choice(ALPHABET) for _ in range(rng.randint(1, 4)))
        elif buf:
            buf[min(pos, len(buf) - 1)] = rng.choice(ALPHABET)
    if rng.random() < 0.2:
        buf = buf[: rng.randrange(len(buf) + 1)]  # truncated
    return bytes(buf)


@pytest.mark.slow
@pytest.mark.parametrize("dialect", sorted(FUZZ_SEEDS))
def test_ten_thousand_fuzzed_inputs_never_crash(dialect):
    rng = random.Random(f"fuzz-{dialect}")
    seeds = [p.read_bytes() for p in FUZZ_SEEDS[dialect]]
    name = {"rapid": "fuzz.mod", "krl": "fuzz.src", "gcode": "fuzz.ngc"}[dialect]
    parsed = rejected = 0
    for _ in range(10_000):
        data = mutate(rng.choice(seeds), rng)
        try:
            tp = parse_program(name, dialect, data)
        except ParseError as exc:
            assert exc.line >= 1 and exc.column >= 1 and name in str(exc)  # refused with where
            rejected += 1
            continue
        except InputError as exc:
            assert name in str(exc), str(exc)  # any other refusal names the file
            rejected += 1
            continue
        parsed += 1
        assert emit_texts(tp, tp)[0].encode("latin-1") == data
    assert parsed + rejected == 10_000 and rejected > 0 and parsed > 0
