"""Fuzzing the Fanuc TP reader (tests/fanuc_fuzzing.py): generated and mutated programs never
crash it; every accepted one round-trips byte-identically, every refused one names file,
line and column. 300 programs from a fixed seed here; benchmarks/fuzz_fanuc.py runs more."""

from __future__ import annotations

import random

import fanuc_fuzzing as ff
import fuzzing
import pytest

from postproc.programs import emit_texts


def test_generated_and_mutated_programs_are_read_exactly_or_refused_with_a_line():
    rng = random.Random(20261127)
    seeds = ff.seeds()
    verdicts = [ff.judge(ff.make_program(rng, seeds)) for _ in range(300)]
    assert verdicts.count("refused") >= 30 and verdicts.count("accepted") >= 30  # both sides are exercised


def test_unmutated_generated_programs_are_accepted():
    rng = random.Random("valid-fanuc")
    assert [ff.judge(ff.program(rng)) for _ in range(40)] == ["accepted"] * 40


def test_the_judge_catches_a_changed_text(monkeypatch):
    monkeypatch.setattr(fuzzing, "emit_texts", lambda tp, new: [t[:-1] for t in emit_texts(tp, new)])
    with pytest.raises(AssertionError, match="changed the text"):
        ff.judge(ff.program(random.Random(1)))
