"""Where the CPU of a streamed program goes, stage by stage (issue 17).

Run: .venv/bin/python benchmarks/stream_stages.py [--dialect krl|gcode] [--moves 1000000]
The raster of benchmarks/stream.py is compensated in one process (``workers=0``, so every
stage runs here and is timed: CPU seconds of this process, all threads, per stage). Where
the output check re-parses a chunk (only where ``emit.readback`` does not apply: increments,
offsets, inherited axes, arcs), that re-parse is counted under parse and under check. In the pipeline (benchmarks/stream.py)
the main process reads, cuts and parses; the postures and everything after run in the workers.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import stream as bench  # noqa: E402  (benchmarks/stream.py: the program and the model)


def timed(owner, name: str, label: str, totals: dict) -> None:
    """Wrap ``owner.name`` to add its CPU seconds to ``totals[label]``."""
    inner = getattr(owner, name)

    def wrapper(*args, **kwargs):
        start = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            totals[label] = totals.get(label, 0.0) + time.process_time() - start

    setattr(owner, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dialect", default="krl", choices=("krl", "gcode"))
    parser.add_argument("--moves", type=int, default=1_000_000)
    args = parser.parse_args()
    import postproc.jobs.stream as stream
    import postproc.programs as programs
    from postproc.programs import dialects

    totals: dict[str, float] = {}
    lang = type(dialects.get(args.dialect))
    timed(stream, "_is_body", "cut check (body regex)", totals)
    timed(lang, "parse_sources", "parse (chunks and re-parse check)", totals)
    timed(stream, "reference_postures", "postures as written (IK, branch carry)", totals)
    timed(stream, "compensate", "compensate (solve, report, path check)", totals)
    timed(lang, "emit_texts", "emit", totals)
    timed(programs, "check_texts", "check (its re-parse included)", totals)
    suffix = ".src" if args.dialect == "krl" else ".ngc"
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / f"p{suffix}"
        bench.make_program(src, args.moves, args.dialect)
        model = bench.model()
        c0 = time.process_time()
        stream.compensate_streamed(src, model, Path(tmp) / f"out{suffix}", workers=0, tune_malloc=True, **bench.options(args.dialect))
        cpu = time.process_time() - c0
    print(f"{args.dialect} raster, {args.moves:,} moves, one process: {cpu:.1f} CPU s, {args.moves / cpu:,.0f} points per CPU s, "
          f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2:.2f} GB")
    for label, seconds in totals.items():
        print(f"  {label:<42}{seconds:7.2f} s  {1e6 * seconds / args.moves:5.1f} us/point")


if __name__ == "__main__":
    main()
