"""Fuzzing the three parsers: 10^5 generated and mutated programs (issue 12, "Must show").

Run: .venv/bin/python benchmarks/fuzz.py [--examples 100000] [--jobs 3] [--out benchmarks/results/fuzz.txt] [--dialects gcode]
The examples are split evenly over RAPID, KRL and G-code, in chunks of 1,000 with their own
fixed seeds, run by --jobs processes; the report is rewritten after every chunk. Each
is a program generated from the grammar's constructs or a real/own corpus file (a window of
40 lines), then 0-4 mutations (tests/fuzzing.py). Counts: accepted (and round-tripped
byte-identically), refused with file:line:column (ParseError), refused naming the file
(InputError), crashed (any other exception, or an accepted text that does not come back
identical) - must be 0. Each chunk has a fixed hypothesis seed: a rerun gives the same counts.
The real corpus is read from $POSTPROC_SHARED/corpus/real (default ../shared).
"""

from __future__ import annotations

import argparse
import collections
import datetime
import json
import multiprocessing
import os
import subprocess
import sys
import time
import traceback
import zlib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def run_chunk(job: tuple[str, int, int]) -> dict:
    """Child process: ``n`` hypothesis examples of ``dialect``; counts and the first crashes."""
    import fuzzing
    from hypothesis import HealthCheck, Phase, given, seed, settings

    dialect, n, part = job
    cpu0 = time.process_time()
    seeds = [p.read_bytes() for p in fuzzing.seed_files(dialect)]
    counts: collections.Counter = collections.Counter()
    crashes: list[dict] = []
    slow: list[float] = []  # CPU seconds of each program over SLOW_S (where the time of a run goes)
    slow_inputs: list[dict] = []  # the first few of them, to reproduce

    @seed(zlib.crc32(f"fuzz-{dialect}-{part}".encode()))  # the same examples on every run
    @settings(max_examples=n, deadline=None, database=None, phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(fuzzing.programs(dialect, seeds))
    def one(data: bytes) -> None:
        start = time.process_time()
        try:
            counts[fuzzing.judge(dialect, data)] += 1
        except Exception as exc:  # noqa: BLE001 - every other exception is what we count
            counts["crashed"] += 1
            if len(crashes) < 20:
                crashes.append({"error": "".join(traceback.format_exception_only(exc)).strip()[:400], "data": data.decode("latin-1")})
        finally:
            if (spent := time.process_time() - start) > SLOW_S:
                slow.append(spent)
                if len(slow_inputs) < 5:
                    slow_inputs.append({"cpu_s": round(spent, 2), "chunk": part, "data": data.decode("latin-1")})

    try:  # loads the grammar and the compiled scanner, so that a first program is not counted slow for it
        fuzzing.judge(dialect, b"")
    except Exception:  # noqa: BLE001 - only a warm-up
        pass
    one()
    return {"dialect": dialect, "seeds": len(seeds), "counts": dict(counts), "crashes": crashes, "cpu_s": time.process_time() - cpu0, "slow": slow,
            "slow_inputs": slow_inputs}


CHUNK = 1000  # examples per task: progress and partial results are written after each
SLOW_S = 0.5  # a program taking more CPU seconds than this is counted apart in the report


def header() -> list[str]:
    """How the run was made: command, commit, start time and the machine's load (timings depend on it)."""
    root = Path(__file__).resolve().parents[1]
    git = lambda *a: subprocess.run(["git", *a], cwd=root, capture_output=True, text=True).stdout.strip()  # noqa: E731
    dirty = " (with uncommitted changes)" if git("status", "--porcelain", "--untracked-files=no") else ""
    shared = os.environ.get("POSTPROC_SHARED", "")
    return [f"# {'POSTPROC_SHARED=' + shared + ' ' if shared else ''}{' '.join([Path(sys.executable).name, *sys.argv])}",
            f"# commit {git('rev-parse', '--short', 'HEAD')}{dirty} on branch {git('rev-parse', '--abbrev-ref', 'HEAD')}; "
            f"started {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC on {os.cpu_count()} cores; "
            f"load average at start {' '.join(f'{x:.1f}' for x in os.getloadavg())}"]


def report(results: list[dict], elapsed: float, jobs: int, wanted: int, head: list[str] = (), dialects=("rapid", "krl", "gcode")) -> str:
    lines = [*head, f"{'dialect':<8}{'generated':>11}{'accepted+round-tripped':>24}{'refused with line':>19}{'refused (file)':>16}{'crashed':>9}   seeds"]
    total: collections.Counter = collections.Counter()
    for d in dialects:
        c: collections.Counter = collections.Counter()
        for r in results:
            if r["dialect"] == d:
                c.update(r["counts"])
        seeds = next((r["seeds"] for r in results if r["dialect"] == d), 0)
        total.update(c)
        lines.append(f"{d:<8}{sum(c.values()):>11,}{c['accepted']:>24,}{c['refused']:>19,}{c['refused-file']:>16,}{c['crashed']:>9,}   {seeds} files")
    done = sum(total.values())
    lines.append(f"{'all':<8}{done:>11,}{total['accepted']:>24,}{total['refused']:>19,}{total['refused-file']:>16,}{total['crashed']:>9,}")
    cpu = sum(r.get("cpu_s", 0.0) for r in results)
    lines.append(f"time {elapsed:.0f} s with {jobs} processes ({done / max(elapsed, 1e-9):,.1f} programs/s); {done:,} of {wanted:,} done; crashed must be 0")
    lines.append(f"CPU {cpu:.0f} s in the workers ({1000 * cpu / max(done, 1):.2f} ms a program); load average now "
                 f"{' '.join(f'{x:.1f}' for x in os.getloadavg())} (the wall time depends on it, the CPU time much less)")
    slow = [t for r in results for t in r.get("slow", [])]
    lines.append(f"{len(slow)} programs over {SLOW_S} s CPU each, {sum(slow):.0f} s in all" + (f" (slowest {max(slow):.1f} s)" if slow else ""))
    for d in dialects:
        mine = [t for r in results if r["dialect"] == d for t in r.get("slow", [])]
        if mine:
            lines.append(f"  {d}: {len(mine)} over {SLOW_S} s, slowest {max(mine):.1f} s")
    crashes = [dict(dialect=r["dialect"], **c) for r in results for c in r["crashes"]]
    for c in crashes[:10]:
        lines.append(f"crash ({c['dialect']}): {c['error'].splitlines()[0]}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=100_000)
    parser.add_argument("--jobs", type=int, default=3)
    parser.add_argument("--out", type=Path, help="also write the report here (after every chunk)")
    parser.add_argument("--crashes", type=Path, help="write the crashing inputs (JSON) here; keep it out of the repository: "
                        "an input may be a window of a third-party corpus file")
    parser.add_argument("--dialects", nargs="+", choices=("rapid", "krl", "gcode"), default=["rapid", "krl", "gcode"],
                        help="only these (the examples are split over them; chunk k of a dialect is the same on every run)")
    args = parser.parse_args()
    dialects = tuple(args.dialects)
    per_dialect = args.examples // len(dialects)
    # chunks interleaved over the dialects, so a run cut short has sampled all three alike
    jobs = [(d, min(CHUNK, per_dialect - k * CHUNK), k) for k in range(-(-per_dialect // CHUNK)) for d in dialects]
    results: list[dict] = []
    head = header()
    t0 = time.perf_counter()
    with multiprocessing.Pool(args.jobs) as pool:
        for result in pool.imap_unordered(run_chunk, jobs):
            results.append(result)
            text = report(results, time.perf_counter() - t0, args.jobs, per_dialect * len(dialects), head, dialects)
            if args.out:
                args.out.parent.mkdir(parents=True, exist_ok=True)
                args.out.write_text(text + "\n", encoding="utf-8")
            if args.crashes:
                crashes = [dict(dialect=r["dialect"], **c) for r in results for c in r["crashes"]]
                args.crashes.write_text(json.dumps(crashes, indent=1), encoding="utf-8")
                slow = [dict(dialect=r["dialect"], **c) for r in results for c in r.get("slow_inputs", [])]
                args.crashes.with_suffix(".slow.json").write_text(json.dumps(slow, indent=1), encoding="utf-8")
    print(text)
    sys.exit(1 if any(r["counts"].get("crashed") for r in results) else 0)


if __name__ == "__main__":
    main()
