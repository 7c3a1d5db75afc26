"""Long programs end to end, streamed in chunks against the whole-program path (issue 17).

Run: .venv/bin/python benchmarks/stream.py [--sizes 100000,1000000] [--huge] [--dialect krl,gcode] [--whole-max 1000000]
     [--paths stream,serial,whole]
Each size and path runs in a fresh process (peak RSS is per process): a raster program of
N moves (KRL ``LIN {X .., Y .., Z .., A 0, B 180, C 0} C_DIS`` or five-axis G-code with
G43.5 tool axis vectors, the stream tests' raster) is compensated with a physics model of
the KR160 (geometric, base_frame, tool_offset, joint_compliance) by
- ``stream``: ``postproc.jobs.stream.compensate_streamed`` with its default worker processes
  (this process reads, cuts and parses; two workers compute each chunk's postures as
  written, handing the end posture on, then compensate, emit, re-parse check it; one
  temporary file renamed at the end);
- ``serial``: the same, all in one process (``workers=0``);
- ``whole``: the whole-program path of ``postproc compensate`` (parse, compensate, emit,
  re-parse check, write), up to --whole-max moves (it needs ~2.6 GB per 10^6);
- ``loop``: the same library calls on one target at a time, on 200 targets (points/s).
--huge adds 10^7 moves (streamed only). Prints the work's wall time and the CPU time of
all its processes (the workers' included), points per wall second and per CPU second, and
the peak RSS of the main process and of the largest worker; the paths' outputs are compared
byte for byte where they ran. ``main+workers`` splits the CPU: on two cores of its own the
pipeline's wall time is bounded below by max(main, (main + workers) / 2).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

G54 = np.array([[1.0, 0, 0, 900.0], [0, -1.0, 0, -100.0], [0, 0, -1.0, 350.0], [0, 0, 0, 1.0]])
H1 = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 200.0], [0, 0, 0, 1.0]])


def make_program(path: Path, n: int, dialect: str) -> None:
    side = int(np.ceil(np.sqrt(n)))
    block = 100_000
    with open(path, "w", encoding="latin-1", newline="\n") as fh:
        if dialect == "krl":
            fh.write("DEF raster( )\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n$APO.CDIS = 0.2\n")
        else:
            fh.write("%\n(raster, tool axis vectors)\nG21 G90 G17 G54\nG43.5 H1\n")
        for start in range(0, n, block):
            i = np.arange(start, min(n, start + block))
            u, v = (i // side) / side, (i % side) / side
            if dialect == "krl":
                x, y = 850.0 + 300.0 * u, -250.0 + 500.0 * v
                fh.writelines(f"LIN {{X {a:.3f}, Y {b:.3f}, Z 450.000, A 0, B 180, C 0}} C_DIS\n" for a, b in zip(x, y))
            else:
                # The stream tests' raster (tests/test_stream.py): 200 x 400 mm, tool axis tilted up to 10 deg.
                x, y, tilt = 200.0 * u, -200.0 + 400.0 * v, np.radians(10.0 * np.sin(i / 500.0))
                fh.writelines(f"G1 X{a:.3f} Y{b:.3f} Z0 I{np.sin(t):.6f} J0 K{np.cos(t):.6f} F3000\n" for a, b, t in zip(x, y, tilt))
        fh.write("END\n" if dialect == "krl" else "G49\nM30\n%\n")


def model():
    import postproc
    from postproc.model.effects import parse_effects
    from postproc.model.sim import random_truth

    robot = postproc.load_robot("kr160_r1570")
    return random_truth(robot, np.array([0.0, 0.0, 200.0]), parse_effects("geometric,base_frame,tool_offset,joint_compliance"), np.random.default_rng(0))


def model_file(out: Path) -> Path:
    """The model as a user has it: a fitted model's file (written before the timing starts,
    read inside it, as `postproc compensate --model` does)."""
    return out.with_name("model.json")


def load(out: Path):
    from postproc.model.model_io import load_model

    return load_model(model_file(out))[0]


def options(dialect: str) -> dict:
    return {} if dialect == "krl" else {"frames": {"G54": G54}, "tools": {"H1": H1}}


def run_stream(src: Path, out: Path, dialect: str, workers: int | None = None) -> None:
    from postproc.jobs.stream import compensate_streamed

    compensate_streamed(src, load(out), out, workers=workers, tune_malloc=True, **options(dialect))


def run_serial(src: Path, out: Path, dialect: str) -> None:
    run_stream(src, out, dialect, workers=0)


def run_whole(src: Path, out: Path, dialect: str) -> None:
    from postproc.jobs.compensate import compensate
    from postproc.programs import check_texts, emit_texts, files_for, parse_program, write_set

    tp = parse_program(src)
    new, rep = compensate(tp, load(out), **options(dialect))
    assert not rep.failures()
    texts = emit_texts(tp, new)
    check_texts(tp, new, texts, np.nonzero(rep.compensated)[0])
    write_set(files_for(tp, texts, out))


def run_loop(src: Path, out: Path, dialect: str) -> None:
    from postproc.jobs.compensate import compensate
    from postproc.programs import emit_texts, parse_program

    small = src.with_name("loop" + src.suffix)
    make_program(small, 200, dialect)
    tp, m = parse_program(small), model()
    t0 = time.perf_counter()
    for i in range(len(tp)):
        one = tp.take([i])
        new, _ = compensate(one, m, **options(dialect))
        emit_texts(one, new)
    print(f"RATE {len(tp) / (time.perf_counter() - t0):.1f}")


def child(path: str, src: Path, out: Path, dialect: str) -> None:
    import postproc.jobs.compensate  # noqa: F401  (imports are start-up, not work)
    import postproc.jobs.stream  # noqa: F401
    from postproc.model.model_io import save_model

    save_model(model_file(out), model())  # setup: the user's job starts from the model file
    t0, (own0, workers0) = time.perf_counter(), cpu_seconds()
    {"stream": run_stream, "serial": run_serial, "whole": run_whole, "loop": run_loop}[path](src, out, dialect)
    own, workers = cpu_seconds()
    print(f"WORK {time.perf_counter() - t0:.3f} {own - own0 + workers - workers0:.3f} {own - own0:.3f} {workers - workers0:.3f}")
    print(f"PEAK {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2:.3f} {resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024**2:.3f}")


def cpu_seconds() -> tuple[float, float]:
    """User + system CPU of this process and of its finished workers (all threads)."""
    own, workers = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, workers.ru_utime + workers.ru_stime


def measure(path: str, src: Path, out: Path, dialect: str) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, __file__, "--child", path, str(src), str(out), dialect], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode:
        return {"error": (proc.stderr or proc.stdout).strip().splitlines()[-1]}
    found = dict(line.split(" ", 1) for line in proc.stdout.splitlines() if line[:4] in ("PEAK", "RATE", "WORK"))
    work, cpu, main_cpu, workers_cpu = (float(v) for v in found["WORK"].split())
    peak, worker_peak = (float(v) for v in found["PEAK"].split())
    return {"wall": wall, "work": work, "cpu": cpu, "main_cpu": main_cpu, "workers_cpu": workers_cpu, "peak": peak, "worker_peak": worker_peak, "rate": float(found.get("RATE", "nan"))}


def digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 24), b""):
            h.update(block)
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="100000,1000000")
    parser.add_argument("--huge", action="store_true", help="add 10^7 moves (streamed only; minutes)")
    parser.add_argument("--dialect", default="krl,gcode", help="krl, gcode or both (comma-separated)")
    parser.add_argument("--whole-max", type=int, default=1_000_000)
    parser.add_argument("--paths", default="stream,serial,whole", help="which of stream, serial, whole to run (comma-separated)")
    parser.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], Path(args.child[1]), Path(args.child[2]), args.child[3])
        return
    sizes = [int(s) for s in args.sizes.split(",") if s] + ([10_000_000] if args.huge else [])
    print(f"load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} (2 cores shared: CPU seconds are the figure to compare)")
    print("each run in a fresh process; work: the job after start-up (imports; the model read from its file inside it, as the CLI does); CPU: all its processes and threads")
    for dialect in args.dialect.split(","):
        bench_dialect(dialect, sizes, args.whole_max, args.paths.split(","))
    print(f"load average at end: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


def bench_dialect(dialect: str, sizes: list[int], whole_max: int, paths: list[str]) -> None:
    suffix = ".src" if dialect == "krl" else ".ngc"
    print(f"\n{dialect} raster, KR160 physics model")
    print(f"{'moves':>11}  {'path':<7}{'work wall':>10}  {'points/s':>9}  {'work CPU':>9}  {'main+workers':>13}  {'points/CPU s':>12}  {'peak RSS':>9}  {'worker RSS':>10}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        loop = measure("loop", tmp / f"p{suffix}", tmp / f"l{suffix}", dialect)
        for n in sizes:
            src = tmp / f"p{suffix}"
            make_program(src, n, dialect)
            outs = {}
            for path in [p for p in paths if p != "whole" or n <= whole_max]:
                outs[path] = tmp / f"{path}{suffix}"
                r = measure(path, src, outs[path], dialect)
                if "error" in r:
                    print(f"{n:>11,}  {path:<7}failed: {r['error']}")
                    outs.pop(path)
                    continue
                worker = f"{r['worker_peak']:>8.2f} GB" if r["worker_peak"] else f"{'-':>10}"
                split = f"{r['main_cpu']:5.1f}+{r['workers_cpu']:5.1f}s"
                print(f"{n:>11,}  {path:<7}{r['work']:9.1f}s  {n / r['work']:>9,.0f}  {r['cpu']:8.1f}s  {split:>13}  {n / r['cpu']:>12,.0f}  {r['peak']:>7.2f} GB  {worker}", flush=True)
            if len(outs) > 1:
                digests = {digest(f) for f in outs.values()}
                print(f"{'':>11}  outputs of {', '.join(outs)} byte-identical: {'yes' if len(digests) == 1 else 'NO'}")
            for f in list(outs.values()) + [src]:
                f.unlink(missing_ok=True)
    if "rate" in loop:
        print(f"per-point loop (the same calls on one target at a time, 200 targets): {loop['rate']:,.0f} points/s")


if __name__ == "__main__":
    main()
