"""Fuzzing the Klartext reader: mutated copies of its test programs (issue 30, "fuzz").

Run: .venv/bin/python benchmarks/fuzz_heidenhain.py [--examples 20000] [--seed 30]
Each example is one of tests/corpus/heidenhain/*.h with 1-3 random edits (a character or a
Klartext word inserted, 0-3 characters removed). Counts: accepted (and round-tripped
byte-identically), refused with file:line:column (ParseError), crashed (any other
exception, or an accepted text that does not come back identical) - must be 0.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
import traceback
from pathlib import Path

import numpy as np

from postproc.errors import InputError, ParseError
from postproc.fivex.machine import load_machine
from postproc.programs import dialects, emit_texts, parse_program

CORPUS = Path(__file__).resolve().parents[1] / "tests" / "corpus" / "heidenhain"
ALPHABET = list("LXYZACR+-.0123456789 QF=()PDM;~\n") + ["FMAX", "LBL 1", "CALL LBL 1 REP 2", "CC X+1 Y+1", "C X+2 Y+0 DR+", "IX", "PA+",
                                                       "FN 18: SYSREAD Q1 = ID270 NR1 IDX1", "CYCL DEF 7.1 X+", "RL", "M128", "Q1 = ", "LP PR+5 PA+",
                                                       "PLANE RESET STAY", "SEQ-", "TURN", "STAY", "MOVE", "Q120", "LN", "NX+", "M140 MB"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=30)
    parser.add_argument("--machine", help="also place each program read on this machine (tilted planes, LN under M128)")
    args = parser.parse_args()
    machine = load_machine(args.machine) if args.machine else None
    rng = np.random.default_rng(args.seed)
    texts = [p.read_text(encoding="latin-1") for p in sorted(CORPUS.glob("*.h"))]
    counts = {"accepted": 0, "refused with line": 0, "crashed": 0}
    t0 = last = time.perf_counter()
    for k in range(args.examples):
        text = texts[rng.integers(len(texts))]
        for _ in range(rng.integers(1, 4)):
            at = int(rng.integers(len(text)))
            text = text[:at] + ALPHABET[rng.integers(len(ALPHABET))] + text[at + int(rng.integers(0, 4)):]
        try:
            tp = parse_program(Path("fuzz.h"), data=text.encode("latin-1"))
            ok = emit_texts(tp, tp)[0] == text
            counts["accepted" if ok else "crashed"] += 1
            if ok and machine is not None:
                _place(tp, machine, counts)
        except ParseError as exc:
            counts["refused with line" if exc.line >= 1 and exc.column >= 1 else "crashed"] += 1
        except Exception:  # noqa: BLE001  a crash is what this run looks for
            counts["crashed"] += 1
            print(traceback.format_exc().splitlines()[-1], file=sys.stderr)
        if time.perf_counter() - last > 10:  # progress: a plain line every ~10 s
            print(f"{k + 1}/{args.examples} examples, {counts}", file=sys.stderr)
            last = time.perf_counter()
    print(f"{args.examples} examples in {time.perf_counter() - t0:.1f} s: {counts}")


def _place(tp, machine, counts: dict) -> None:
    """Place ``tp`` on ``machine``: placed, refused with the file and line (InputError), or a crash."""
    try:
        dialects.of(tp).for_machine(tp.with_frames({"PRESET": np.eye(4)}, None), machine)
        counts["placed"] = counts.get("placed", 0) + 1
    except InputError as exc:
        key = "placement refused with line" if re.match(r"fuzz\.h:\d+", str(exc)) else "crashed"
        counts[key] = counts.get(key, 0) + 1


if __name__ == "__main__":
    main()
