"""Every evaluation protocol on the real UR10 data, each row one `postproc validate` command.

Run: .venv/bin/python benchmarks/ur10_protocols.py [path/to/ur10_ipa] [--skip-hybrid]
     [--jobs N] [--output FILE]
Writes benchmarks/results/ur10_protocols.txt (or FILE: the table, the command behind each row
and its wall time). Imports Series A and B with `postproc import-ur10` into a temporary folder
first. The hybrid rows (physics + GPR; local experts on ~9,500 poses of A) and the rows whose
fit chooses cyclic terms (`joint_harmonics[max_order=60]`) take most of the time (about 1-5 min
each on a shared 2-core machine); --skip-hybrid leaves the hybrid rows out. --jobs runs that
many rows at once (each one single-threaded), for a machine with the cores.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ur10_series import data_folder, imported

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "ur10_protocols.txt"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
# Joints 1 and 2 are where a GPR on the joint angles, fitted on B's training half, puts its
# short length scales (about 4 deg: docs/guide/explain.md); orders 1-12 are the effect's whole range.
SHOULDER = "joint_harmonics[joints=1,2;orders=1,2,3,4,5,6,7,8,9,10,11,12]"
# Per-joint cyclic errors, the terms chosen by the fit among orders 1-60 of every joint
# (forward selection, CV holding out whole commanded positions: docs/guide/validate.md).
CYCLIC = PHYSICS + ",joint_harmonics[max_order=60]"
UR10 = ["--robot", "ur10", "--tool", "0,0,109", "--effects"]


def rows(a: str, b: str, hybrid: bool) -> list[tuple[str, str, list[str]]]:
    """(label, goal, validate arguments) per table row; the hybrid rows only with ``hybrid``."""
    gpr = ["--predictor", "gpr"]
    posture = [*gpr, "--gp-features", "tcp+joints"]  # the learner sees the joint angles too
    history = [*gpr, "--gp-features", "tcp+joints+travel"]  # and the TCP travel of the last three moves
    table = [
        ("A: random 20 % of poses held out, physics", "", [a, "--protocol", "random", *UR10, PHYSICS]),
        ("A: random 20 % of poses held out, hybrid", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *gpr]),
        ("A: the same, hybrid with --gp-features tcp+joints", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *posture]),
        ("A: the same, hybrid with --gp-features tcp+joints+travel", "<= 0.06", [a, "--protocol", "random", *UR10, PHYSICS, *history]),
        ("A: every 5th grid point held out, physics", "", [a, "--protocol", "points", *UR10, PHYSICS]),
        ("A: every 5th grid point held out, hybrid", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *gpr]),
        ("A: the same, hybrid with --gp-features tcp+joints", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *posture]),
        ("A: the same, hybrid with --gp-features tcp+joints+travel", "<= 0.20", [a, "--protocol", "points", *UR10, PHYSICS, *history]),
        ("A: each session held out, physics", "", [a, "--protocol", "sessions", *UR10, PHYSICS]),
        ("B: half of the commanded positions held out, physics", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS]),
        ("B: the same, + joint_harmonics (terms chosen by the fit)", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS + ",joint_harmonics"]),
        ("B: the same, + joint_harmonics[joints=1,2;orders=1-12]", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS + "," + SHOULDER]),
        ("B: the same, hybrid", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *gpr]),
        ("B: the same, hybrid with --gp-features tcp+joints", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *posture]),
        ("B: the same, hybrid with --gp-features tcp+joints+travel", "", [b, "--protocol", "points", "--every", "2", *UR10, PHYSICS, *history]),
        ("A -> B: re-registered on half of B, physics", "vs ceiling", [a, "--protocol", "series", "--other", b, *UR10, PHYSICS]),
        ("A: random 20 % held out, physics + cyclic terms", "", [a, "--protocol", "random", *UR10, CYCLIC]),
        ("A: the same, hybrid with --gp-features tcp+joints", "<= 0.06", [a, "--protocol", "random", *UR10, CYCLIC, *posture]),
        ("A: the same, hybrid with --gp-features tcp+joints+travel", "<= 0.06", [a, "--protocol", "random", *UR10, CYCLIC, *history]),
        ("A: the same, with --session-offsets", "<= 0.06", [a, "--protocol", "random", *UR10, CYCLIC, *history, "--session-offsets"]),
        ("A: every 5th grid point held out, physics + cyclic terms", "<= 0.20", [a, "--protocol", "points", *UR10, CYCLIC]),
        ("A: the same, hybrid", "<= 0.20", [a, "--protocol", "points", *UR10, CYCLIC, *gpr]),
        ("A: the same, with --session-offsets", "<= 0.20", [a, "--protocol", "points", *UR10, CYCLIC, *gpr, "--session-offsets"]),
        ("B: half of the commanded positions held out, physics + cyclic terms", "< 0.30", [b, "--protocol", "points", "--every", "2", *UR10, CYCLIC]),
        ("A -> B: re-registered on half of B, physics + cyclic terms", "vs ceiling", [a, "--protocol", "series", "--other", b, *UR10, CYCLIC]),
    ]
    return [row for row in table if hybrid or "--predictor" not in row[2]]


def run(args: list[str]) -> tuple[dict, float]:
    start = time.monotonic()
    # One thread per row: rows run side by side with --jobs, and BLAS threads would fight.
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "postproc", "validate", *args, "--json"], capture_output=True, text=True, cwd=ROOT, env=env)
    if proc.returncode != 0:
        raise SystemExit(f"postproc validate {' '.join(args)} failed:\n{proc.stderr}")
    return json.loads(proc.stdout), time.monotonic() - start


def slowness(args: list[str]) -> int:
    """A rough rank of a row's run time: a GPR and a cyclic term search each add to it, Series A more than B."""
    text = " ".join(args)
    return ("--predictor" in args) + ("max_order" in text) + ("A.csv" in args[0]) + ("series" in args)


def environment(jobs: int) -> str:
    """What the figures were computed with: the GPR rows move by a few thousandths of a mm between library versions."""
    versions = []
    for name in ("numpy", "scipy", "torch", "sklearn"):
        try:
            versions.append(f"{name} {__import__(name).__version__}")
        except ImportError:
            versions.append(f"{name} missing")
    return f"Python {platform.python_version()}, {', '.join(versions)}; {os.cpu_count()} CPUs, {jobs} rows at a time"


def options() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", help="the ur10_ipa folder (default: the shared data's)")
    parser.add_argument("--skip-hybrid", action="store_true", help="leave out the rows with a GPR")
    parser.add_argument("--jobs", type=int, default=1, help="rows run at once (default 1)")
    parser.add_argument("--output", type=Path, default=RESULT, help=f"result file (default {RESULT.relative_to(ROOT)})")
    return parser.parse_args()


def row_lines(label: str, goal: str, args: list[str], doc: dict, wall: float, tmp: str) -> tuple[str, list[str]]:
    """The table line and the command lines of one protocol's result."""
    e, d = doc["error"], doc["distance"]
    ceiling = f"{doc['ceiling']['mean_mm']:.3f}" if doc["ceiling"] else ""
    line = (f"| {label} | {goal} | {e['n']} | **{e['mean_mm']:.3f}** | {e['median_mm']:.3f} | {e['p95_mm']:.3f} | {e['max_mm']:.3f} "
            f"| {d['median_rad']:.3f} / {d['max_rad']:.3f} | {ceiling} |")
    shown = " ".join(x.replace(tmp + "/", "") for x in args)
    commands = [f"- {label}: `postproc validate {shown}` ({wall:.0f} s)"]
    moved = [s for s in doc["sessions"] if s["moves_as_whole"]]
    commands += [f"  - session {s['session']} ({s['n']} poses) moves as a whole: rigid offset {s['offset_mm']:.3f} mm, "
                 f"mean {s['mean_mm']:.3f} -> {s['mean_after_mm']:.3f} mm without it" for s in moved]
    return line, commands


def main() -> None:
    opts = options()
    data = data_folder(opts.data)
    with tempfile.TemporaryDirectory() as tmp:
        a, b = (str(imported(data, series, Path(tmp) / f"{series}.csv")) for series in ("A", "B"))
        table = rows(a, b, not opts.skip_hybrid)
        done = [0]

        def one(row):
            doc, wall = run(row[2])
            done[0] += 1
            print(f"[{done[0]}/{len(table)}] {row[0]} ({wall:.0f} s)", file=sys.stderr, flush=True)
            return row_lines(*row, doc, wall, tmp)

        # The slow rows (a GPR, or cyclic terms to choose) start first, so --jobs keeps every core busy to the end.
        order = sorted(range(len(table)), key=lambda k: -slowness(table[k][2]))
        with ThreadPoolExecutor(max_workers=max(1, opts.jobs)) as pool:
            ran = dict(zip(order, pool.map(one, [table[k] for k in order])))
        results = [ran[k] for k in range(len(table))]
    lines = ["| protocol | goal | n | mean | median | p95 | max | nearest training pose, median / max rad | ceiling mean |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |", *(line for line, _ in results)]
    commands = [c for _, cs in results for c in cs]
    text = "\n".join(["UR10 protocols (mm; A.csv, B.csv from postproc import-ur10)", environment(opts.jobs), "", *lines, "", *commands, ""])
    opts.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
