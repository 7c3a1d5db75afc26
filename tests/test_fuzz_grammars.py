"""Fuzzing the parsers with hypothesis (issue 12): generated and mutated programs in RAPID, KRL
and G-code never crash a parser; every accepted program round-trips byte-identically and
every refused one names file, line and column. tests/fuzzing.py has the strategies and the
judge; benchmarks/fuzz.py runs 10^5 of them (result in benchmarks/results/fuzz.txt), this
file 150 per dialect (about 30 s in all), from a fixed seed.
"""

from __future__ import annotations

import fuzzing
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, note, seed, settings

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

SEEDS = {d: [p.read_bytes() for p in fuzzing.seed_files(d)] for d in fuzzing.DIALECTS}
EXAMPLES = {"rapid": 150, "krl": 150, "gcode": 150}

def _fuzz(dialect: str, data: bytes) -> None:
    note(f"input: {data!r}")
    fuzzing.judge(dialect, data)


@pytest.mark.parametrize("dialect", fuzzing.DIALECTS)
def test_generated_and_mutated_programs_are_read_exactly_or_refused_with_a_line(dialect):
    @seed(20261123)
    @settings(max_examples=EXAMPLES[dialect], deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(fuzzing.programs(dialect, SEEDS[dialect]))
    def run(data):
        _fuzz(dialect, data)

    run()


@pytest.mark.parametrize("dialect", fuzzing.DIALECTS)
def test_unmutated_generated_programs_are_accepted(dialect):
    """The generators write programs each parser reads (so the mutations start from valid text)."""
    import random

    rng = random.Random(f"valid-{dialect}")
    verdicts = []
    for _ in range(30):
        data = fuzzing.GENERATED[dialect](rng)
        verdicts.append(fuzzing.judge(dialect, data))
    assert verdicts.count("accepted") >= 0.75 * len(verdicts) and len(verdicts) >= 15


def test_the_judge_catches_a_changed_text(monkeypatch):
    """A parser whose emit drops a byte is caught (the judge is not vacuous)."""

    def lossy(tp, new):
        return [t[:-1] for t in emit_texts(tp, new)]

    monkeypatch.setattr(fuzzing, "emit_texts", lossy)
    with pytest.raises(AssertionError, match="changed the text"):
        fuzzing.judge("gcode", b"G1 X1\nM2\n")


@pytest.mark.parametrize("text", [b"DEF a( )\nLIN_REL {Z -20}\nEND\n", b"DEF a( )\nPTP_REL {A1 5}\nEND\n"])
def test_krl_relative_move_from_an_unknown_start_round_trips(text):
    tp = parse_program("fuzz.src", "krl", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


def test_krl_circ_with_an_unknown_auxiliary_point_round_trips():
    text = b"DEF fuzz( )\nPTP {Y 9E+09, A 1972.0, C -667, Z 521, S 6, T 27} C_DIS\nCIRC XHOME, {B -2494.7810, Z -2819, A -2187.85014, S 6, T 27} C_DIS\nEND\n"
    tp = parse_program("fuzz.src", "krl", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


def test_krl_partial_target_after_an_axis_ptp_round_trips():
    text = b"DEF a( )\nLIN {X 700, Y 0, Z 500, A 0, B 90, C 0}\nPTP {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}\nLIN {X 700, Y 100}\nEND\n"
    tp = parse_program("fuzz.src", "krl", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


def test_gcode_g53_without_a_motion_mode_round_trips_or_is_refused():
    text = b"g53 x1 y1\ng0 a1\n"
    try:
        tp = parse_program("fuzz.ngc", "gcode", text)
    except ParseError:
        return
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


def test_krl_relative_move_to_a_declared_point_keeps_its_numbers():
    text = (b"DEF fuzz( )\r\nDECL E6POS XP1 = {Z 0.0, A -227, C -554, Y 2082, X -1789.293770, S 6, T 27}\r\n"
            b"LIN {A 1831.2505, B -367.247271, X 447.221493, Z 1310.35, C 00012, Y -1627, S 6, T 27}\r\n"
            b"PTP {C 486.456979} C_PTP\r\nLIN {Z 2205.55002, S 6, T 27}\r\nLIN_REL XP1\r\nEND\r\n")
    tp = parse_program("fuzz.src", "krl", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


@pytest.mark.parametrize("text", [
    b"G21 G90 G17\nG0 X0 Y0 Z0\nG92 X10\nG91\nG0 A5\nG1 X-20 F100\nM2\n",
    b"G21 G90 G17\nG0 X0 Y0 Z0\nG91\no30 repeat [2]\nG92 X-7.5\no30 endrepeat\nG0 B7\nG2 X-20 Y0 I-10 J0 F100\nM2\n",
])
def test_gcode_increment_after_g92_keeps_its_number(text):
    """Found by benchmarks/fuzz.py: after G92, an unchanged emit rewrote an incremental X
    (-2168 -> -2922.199): the previous target was taken in the old offset. The increment is
    the number in the text (LinuxCNC manual, "G91": relative to the current point)."""
    tp = parse_program("fuzz.ngc", "gcode", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


@pytest.mark.parametrize("text", [
    b'&ACCESS RVP\n&REL 1\nDEF fuzz( )\nDECL E6POS XP1 = {B 2375, Z 860.7986, C 1441.68, X 1058}\nCIRC {Z 2051.080, Y 0, B 87, X 00012, S 6, T 27}, {A 1125, Y 2762.0472, C 0.0, Z .5, X 1e308, B 2085.148005, S 6, T 27}\nLIN_REL {B 1311.250, X 419, Z -973.976250, Y -290} C_VEL\n$TOOL = TOOL_DATA[1]\nPTP {Z 802, B -2577, C -2371.5, X -761.990371, Y 1579.0, S 6, T 27} C_DIS\nEND\n',
    b'DEF fuzz( )\nDECL E6POS XP1 = {B -1401.15, C 103, Y 1177.59817, A 2451.66, Z 1e308, X 0.0, S 6, T 27}\nDECL FRAME F1 = {Y -2658.23433, X -2251, Z 907, A .5, C 1478, B -766.749087, S 6, T 27}\nLOOP\nPTP_REL {B 1353.436060, X 2282, C -2013, A -0, Y -516.51437} C_VEL\n$OUT[3] = TRUE\n$TOOL = TOOL_DATA[1]\nEXIT\nENDLOOP\nXP1.X = XP1.X + -1624.1169\nREPEAT\nWAIT SEC 0.5\nXP1.X = XP1.X + 324.069615\nCIRC {A -1577, X 1275, C -1708, B 1264}, {Y 1128.151, X 1696, B -292.149624, C -2820.3, S 6, T 27} C_VEL\nUNTIL N > 3\n;FOLD moves\nLIN {C -2125, S 6, T 27}\nCIRC XP2, {Y -913, X 1695} C_ORI\nLIN {Y -2245, A -1770.89, B 2759.50584, Z 9E9, C -2773, S 6, T 27} C_PTP\nLIN_REL {Y 384, C 2010, X -695, Z -1155.970447, A 1554.9143} C_PTP\n;ENDFOLD\nEND\n',
])
def test_krl_relative_move_after_huge_coordinates_keeps_its_numbers(text):
    """Found by benchmarks/fuzz.py: after a coordinate of 1e308 or 9E9 the absolute value
    absorbs the increment (1e308 + 419 == 1e308), and an unchanged emit must still write
    the text's increment back as it was, not the difference of two absolute values."""
    tp = parse_program("fuzz.src", "krl", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


@pytest.mark.parametrize("text", [
    b"G83 R0.05 Z-0.7 Q0.15 X0 Y-6 F#102\nG83 R0.05 Z-0.7 X1\nM2\n",  # Q sticky from a block not read: was KeyError 'Q'
    b"G83 R1 Z-5 Q1 X0 Y0 F10\nG83 R1 Z-5 Q2 X1 Y1 F#102\nG83 X2 Y2\nM2\n",  # was pecked with the stale Q1, flagged resolved
])
def test_gcode_cycle_after_a_cycle_block_not_read_is_flagged(text):
    """Found by benchmarks/fuzz.py (a window of a real drilling program with F#102 unset):
    a G83 block with a word unknown at post time is listed once, flagged; the next G83
    blocks take its sticky R, bottom and Q (LinuxCNC manual, "Canned cycles", "Sticky
    numbers"), so their holes are not known either, until a new cycle is read."""
    tp = parse_program("fuzz.ngc", "gcode", text)
    later = tp.line >= 2
    assert not tp.resolved[later].any() and np.isnan(tp.position[later & (tp.line == tp.line.max())]).all()
    assert emit_texts(tp, tp)[0].encode("latin-1") == text


def test_rapid_offs_with_a_zero_term_round_trips():
    """Found by benchmarks/fuzz.py (the 10^5 run after the RAPID loop work): `Offs(p, -2475.3-0, ...)`
    raised ZeroDivisionError: the expression evaluator built every operation's result, a / b
    included, for any operator."""
    text = b"MODULE Fuzz\n  PROC main()\n    MoveL Offs(p1,-2475.29847-0,+1,-658.4), v500, fine, tool0;\n    MoveL Offs(p1,3*0,0,0), v500, fine, tool0;\n  ENDPROC\nENDMODULE\n"
    tp = parse_program("fuzz.mod", "rapid", text)
    assert emit_texts(tp, tp)[0].encode("latin-1") == text
