"""Fuzzing the Fanuc TP reader: N generated and mutated .ls programs (tests/fanuc_fuzzing.py).

Run: .venv/bin/python benchmarks/fuzz_fanuc.py [--examples 20000] [--seed 29] [--out benchmarks/results/fuzz_fanuc.txt]
Counts: accepted (and round-tripped byte-identically), refused with file:line:column, crashed
(any other exception, or an accepted text that does not come back identical): must be 0.
A line on stderr every 10 s shows the progress. A fixed seed: a rerun gives the same counts.
"""

from __future__ import annotations

import argparse
import collections
import random
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import fanuc_fuzzing as ff  # noqa: E402  (tests/ on the path first)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=29)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    seeds = ff.seeds()
    counts: collections.Counter = collections.Counter()
    crashes = []
    start = last = time.perf_counter()
    for i in range(args.examples):
        data = ff.make_program(rng, seeds)
        try:
            counts[ff.judge(data)] += 1
        except Exception as exc:  # a crash or a wrong refusal: counted with its input, never stops the run
            counts["crashed"] += 1
            if len(crashes) < 5:
                crashes.append(f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=3)}input: {data[:400]!r}")
        if time.perf_counter() - last > 10:
            last = time.perf_counter()
            print(f"{i + 1}/{args.examples} programs, {dict(counts)}", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - start
    lines = [f"fuzz_fanuc: {args.examples} programs (seed {args.seed}) in {elapsed:.1f} s: "
             + ", ".join(f"{k} {counts[k]}" for k in ("accepted", "refused", "crashed")), *crashes]
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
