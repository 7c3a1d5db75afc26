"""Fuzzing the URScript reader (issue 29): generated and mutated programs never crash it; every
accepted program round-trips byte-identically and every refused one names file, line and
column. The same judge as tests/fuzzing.py (kept apart so that each language's fuzzing is
its own file); 300 examples from a fixed seed here, benchmarks/fuzz_urscript.py runs more."""

from __future__ import annotations

import random
from pathlib import Path

import fuzzing
import pytest
from hypothesis import HealthCheck, Phase, given, note, seed, settings
from hypothesis import strategies as st

NAME = "fuzz.script"
CORPUS = Path(__file__).parent / "corpus" / "urscript"
SEEDS = [p.read_bytes() for p in sorted(CORPUS.rglob("*script"))]
TOKENS = ["movel(", "movej(", "movep(", "movec(", "servoj(", "set_tcp(", "p[", "[", "]", "(", ")", ",", "=", "a=", "v=", "r=",
          "t=", "qnear=", "get_inverse_kin(", "pose_trans(", "pose_add(", "def f():", "thread t():", "end", "if x:", "elif y:",
          "else:", "while True:", "i = 0\n", "while i < 3:", "i = i + 1\n", "break", "global ", "local ", "#", '"', "'", "$ 1 \"x\"", "\n", "\r\n", "\t", "-", ".", "0", "1e308", "{", "}"]
NUMBERS = ["0", "-0", "0.0", ".5", "-.5", "1e-3", "1E+2", "3.1416", "-1.5708", "0.25", "12"]


def judge(data: bytes) -> str:
    return fuzzing.judge_file(NAME, "urscript", data)


def _numbers(rng, n):
    return ", ".join(rng.choice(NUMBERS) for _ in range(n))


def _statement(rng) -> str:
    pose = f"p[{_numbers(rng, 6)}]"
    return rng.choice([
        f"movel({pose}, a=1.2, v=0.25)", f"movej([{_numbers(rng, 6)}], a=1.4, v=1.05, r=0.01)", f"movej({pose})",
        f"movep({pose}, a=1.2, v=0.1, r=0.002)", f"movec({pose}, p[{_numbers(rng, 6)}], a=1.2, v=0.1, r=0, mode=0)",
        f"servoj([{_numbers(rng, 6)}], t=0.008)", f"set_tcp({pose})", f"global w{rng.randint(1, 3)} = {pose}",
        f"movel(pose_trans(w{rng.randint(1, 3)}, {pose}))", f"movel(w{rng.randint(1, 3)}, v=0.1)",
        f"movej(get_inverse_kin({pose}, qnear=[{_numbers(rng, 6)}]))", f"movel(pose_add(p[{_numbers(rng, 3)}, 0, 0, 0], {pose}))",
        "textmsg(\"movel(p[1, 2, 3, 0, 0, 0])\")  # movej(", "sleep(0.5)", "$ 3 \"MoveL\"",
    ])


def _program(rng) -> bytes:
    lines, depth = ["def prog():"], 1
    for _ in range(rng.randint(1, 15)):
        roll = rng.random()
        if roll < 0.1 and depth < 4:
            lines.append("  " * depth + rng.choice(["while True:", "if digital_in(0):", "def sub():"]))
            depth += 1
        elif roll < 0.18 and depth > 1:
            depth -= 1
            lines.append("  " * depth + "end")
        else:
            lines.append("  " * depth + _statement(rng))
    lines += ["  " * d + "end" for d in range(depth - 1, -1, -1)]
    return (rng.choice(["\n", "\r\n"]).join(lines) + "\n").encode("latin-1")


def _mutate(rng, data: bytes) -> bytes:
    return fuzzing.mutate_with(rng, data, TOKENS)


def _example(rng) -> bytes:
    if rng.random() < 0.3 and SEEDS:
        lines = rng.choice(SEEDS).splitlines(keepends=True)
        start = rng.randrange(max(len(lines) - 30, 1))
        return _mutate(rng, b"".join(lines[start:start + 30]))
    return _mutate(rng, _program(rng))


def test_generated_and_mutated_programs_are_read_exactly_or_refused_with_a_line():
    @seed(20261127)
    @settings(max_examples=300, deadline=None, database=None, phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(st.randoms(use_true_random=True).map(_example))
    def run(data):
        note(f"input: {data!r}")
        judge(data)

    run()


def test_unmutated_generated_programs_are_accepted():
    rng = random.Random("valid-urscript")
    verdicts = [judge(_program(rng)) for _ in range(40)]
    assert verdicts.count("accepted") >= 30


@pytest.mark.parametrize("data", [b"movel(p[1, 2, 3, 0, 0, 0]", b"def p():\n  movel(", b"end\n", b"movel(p[1,2,3,0,0,0], x=1)\n", b"{{X}}\n"])
def test_known_refusals_have_a_place(data):
    assert judge(data) == "refused"
