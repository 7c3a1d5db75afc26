"""Fuzzing the VAL3 reader: N mutated applications (the demo's program, called program or
data file, 1-3 mutations each: tests/test_val3_fuzz.py), each judged: accepted and written
back byte for byte, refused with file:line:column (ParseError) or naming a file (InputError),
or crashed (any other exception, or an accepted text that does not come back) - must be 0.

Run: .venv/bin/python benchmarks/fuzz_val3.py [--examples 3000] [--seed 0]
Example k is drawn from random.Random(seed + k): a rerun gives the same counts.
"""

from __future__ import annotations

import argparse
import collections
import random
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_val3_fuzz as fuzz  # noqa: E402  (the test folder is put on the path just above)

from postproc.progress import ProgressLine  # noqa: E402


def run(examples: int, seed: int, progress) -> collections.Counter:
    counts: collections.Counter = collections.Counter()
    for k in range(examples):
        rng = random.Random(seed + k)
        target = rng.choice(("start.pgx", "cut.pgx", "demo.dtx"))
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            for name in fuzz.FILES:
                (folder / name).write_bytes((fuzz.DEMO / name).read_bytes())
            text = fuzz._mutate(rng, (fuzz.DEMO / target).read_text(encoding="latin-1"))
            (folder / target).write_bytes(text.encode("latin-1"))
            try:
                counts[fuzz.judge(folder)] += 1
            except Exception as exc:  # noqa: BLE001  (a crash is what this counts)
                counts["crashed"] += 1
                print(f"crash in example {k} ({target}): {exc!r}", file=sys.stderr)
        progress("fuzzing VAL3 applications", k + 1, examples)
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    with ProgressLine("fuzzing VAL3 applications") as progress:
        counts = run(args.examples, args.seed, progress)
    print(f"{args.examples} examples in {time.perf_counter() - started:.0f} s: accepted {counts['accepted']}, refused with a place "
          f"{counts['refused']}, refused naming a file {counts['refused-file']}, crashed {counts['crashed']}")


if __name__ == "__main__":
    main()
