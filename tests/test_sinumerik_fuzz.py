"""Fuzzing the SINUMERIK reader (as tests/test_fuzz_grammars.py fuzzes RAPID, KRL and G-code):
generated and mutated programs never crash it; every accepted program round-trips
byte-identically, every refused one names file, line and column. Seeds: the Sinumerik corpus
(tests/corpus/sinumerik) and the shared corpus's .MPF / .SPF files. 200 examples from a
fixed seed (a few seconds); the mutations are tests/fuzzing.py's plus Sinumerik tokens.
"""

from __future__ import annotations

import random
from pathlib import Path

import fuzzing
from hypothesis import HealthCheck, Phase, given, note, seed, settings
from hypothesis import strategies as st

NAME = "FUZZ.MPF"
SEEDS = [p.read_bytes() for p in sorted((Path(__file__).parent / "corpus" / "sinumerik").glob("*.mpf"))]
SEEDS += [p.read_bytes() for p in fuzzing.seed_files("gcode") if p.suffix.lower() in (".mpf", ".spf")]
TOKENS = ["TRANS X10", "ATRANS Y5", "ROT Z30", "AROT X10 Y20", "ROT RPL=45", "SCALE X2", "MIRROR", "R1=", "R2=R1*2+SIN(30)",
          "X=R1", "Y=IC(2)", "CR=5", "AR=90", "A3=0", "G500", "G505", "G54", "TRAORI", "TRAFOOF", "G2 X1 Y1 CR=-3", "DEF REAL A",
          "IF R1>2", "ENDIF", "WHILE R1<3", "ENDWHILE", "FOR I=1 TO 3", "ENDFOR", "REPEAT", "UNTIL R1>0", "LABEL1:", "GOTOF LABEL1",
          "CYCLE800(1,\"T\",0,57)", "MIRROR X0", "ASCALE X2 Y2", "AMIRROR Y0", "ORIMKS", "T=\"TOOL\"", "(", ")", "=", " ", "\n", ";", "$AA_IW[X]", "DIV", "MOD", "N10 "]


def generated(rng: random.Random) -> bytes:
    """A program the reader accepts: a header, frames, R parameters and moves."""
    lines = ["N10 G54 G17 G71 G90", "N20 G0 X0 Y0 Z10 A0 C0", f"R1={rng.uniform(-50, 50):.3f}", "TRAORI"]
    for i in range(rng.randint(1, 15)):
        kind = rng.random()
        if kind < 0.15:
            lines.append(rng.choice(["TRANS X=R1 Y2", "ATRANS X1", f"AROT Z{rng.randint(-90, 90)}", "ROT RPL=30", "TRANS"]))
        elif kind < 0.25:
            lines.append(f"G2 X{rng.uniform(-9, 9):.3f} Y{rng.uniform(-9, 9):.3f} CR={rng.uniform(20, 30):.2f}")
        else:
            lines.append(f"G1 X{rng.uniform(-99, 99):.3f} Y=R1+{i} Z{rng.uniform(-9, 9):.2f} A{rng.uniform(-30, 30):.2f} C{rng.uniform(0, 90):.2f} F{rng.randint(100, 999)}")
    lines += ["TRAFOOF", "M30", ""]
    return ("\r\n" if rng.random() < 0.3 else "\n").join(lines).encode("latin-1")


def program(rng: random.Random) -> bytes:
    data = generated(rng) if rng.random() < 0.5 else fuzzing.seeded_program(rng, SEEDS)
    data = fuzzing.mutate(rng, data, "gcode")
    for _ in range(rng.randint(0, 2)):
        at = rng.randint(0, len(data))
        data = data[:at] + rng.choice(TOKENS).encode("latin-1") + data[at:]
    return data


def judge(data: bytes) -> str:
    """tests/fuzzing.py's judge of a Sinumerik file: accepted and round-tripped, or refused with a position."""
    return fuzzing.judge_file(NAME, "sinumerik", data)


@seed(20261127)
@settings(max_examples=200, deadline=None, database=None, phases=[Phase.generate], suppress_health_check=list(HealthCheck))
@given(st.randoms(use_true_random=True).map(program))
def test_mutated_sinumerik_programs_are_read_exactly_or_refused_with_a_position(data):
    note(f"input: {data!r}")
    judge(data)


def test_generated_programs_are_accepted():
    """The generator writes programs the reader takes (so the mutations start from valid text)."""
    rng = random.Random("valid-sinumerik")
    verdicts = [judge(generated(rng)) for _ in range(30)]
    assert verdicts.count("accepted") == len(verdicts)


def test_found_by_fuzzing():
    """Inputs the fuzzer found crashing the reader once (a control character that str.split takes for a blank)."""
    assert judge(b"N10 G54 G17 G71 G0\nR1=37.736\n\x1d RAORI\nG1 X74.173 Y=R1+0 Z-6.56 F276\nM30\n") in ("accepted", "refused")
