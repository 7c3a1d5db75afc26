"""Placement that tells the truth (issue 28): feasible cells, the reasons of the others, the
best placement, the current one and the reduction, on the face-milling block, before and after.

Run: .venv/bin/python benchmarks/place.py [--before DIR] [--reference] [--search X0:X1:DX,Y0:Y1:DY,T0:T1:DT]

Each case is ``postproc place`` (grid + refinement) in a subprocess, its --json read back.
``--before DIR``: the same commands on another checkout's code (e.g. ``git archive 7c595ad |
tar -x -C DIR``), which predates the reasons and the configuration modes.
``--reference``: the brute-force reference (tests/placement_reference.py, one candidate and
one target at a time) counts the feasible cells of each case and compares every cell's reason
with the product's; slow (about a minute per 4,000 cells re-derived, ten times that kept),
it prints a line every 10 s; kept data are checked on every 7th cell (ten times slower).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from placement_reference import reference_cell  # noqa: E402  (tests/, put on the path above)

from postproc import placement as pl  # noqa: E402
from postproc.process.place_program import problem_from_program  # noqa: E402
from postproc.process.placement_branch import REASONS, reason_counts  # noqa: E402
from postproc.programs import parse_program  # noqa: E402
from postproc.robot.robots import load_robot  # noqa: E402

CASES = [  # (program, extra options, what it is)
    ("examples/data/block_face.mod", [], "RAPID, confdata on every target, re-derived (default)"),
    ("examples/data/block_face.mod", ["--keep-conf"], "RAPID, confdata kept as written"),
    ("examples/data/block_face.src", [], "KRL, no Status/Turn"),
]
COMMON = ["--robot", "irb6660_205_190", "--force", "200,100,300", "--z", "1170", "--json"]


def run_place(program: str, extra: list[str], search: str, code: Path | None):
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    if code is not None:
        env["PYTHONPATH"] = str(code)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "postproc.cli", "place", str(ROOT / program), "--search", search, *COMMON, *extra],
                          capture_output=True, text=True, env=env, cwd=code or ROOT)  # python -m puts its cwd first on the path
    wall = time.perf_counter() - t0
    if proc.returncode not in (0, 1) or not proc.stdout.strip():
        return None, wall, proc.stderr.strip().splitlines()[-1:] or ["no output"]
    return json.loads(proc.stdout), wall, []


def describe(doc: dict | None, wall: float, errors: list[str]) -> str:
    if doc is None:
        return f"  refused: {errors[0]}"
    lines = [f"  {doc.get('feasible')} of {doc.get('grid')} grid cells feasible ({doc['evaluated']} evaluated, {wall:.1f} s wall)"]
    if "infeasible" in doc:
        lines.append("  infeasible: " + (", ".join(f"{k} {v}" for k, v in doc["infeasible"].items()) or "none"))
    else:
        lines.append("  infeasible: (no reasons given)")
    b, cur = doc.get("best"), doc.get("current")
    if b:
        lines.append(f"  best x {b['x']:.1f}, y {b['y']:.1f}, theta {b['theta']:.2f}: {b['mean_normal_error_mm'] * 1000:.2f} um")
    if cur:
        now = "infeasible" if cur["mean_normal_error_mm"] is None else f"{cur['mean_normal_error_mm'] * 1000:.2f} um"
        why = f" ({cur['reason']})" if cur.get("reason") else ""
        red = "" if doc.get("reduction_percent") is None else f"; reduction {doc['reduction_percent']:.1f} %"
        lines.append(f"  current x {cur['x']:.1f}, y {cur['y']:.1f}, theta {cur['theta']:.2f}: {now}{why}{red}")
    return "\n".join(lines)


def reference_counts(program: str, extra: list[str], search: str) -> str:
    mode = "keep" if "--keep-conf" in extra else "rederive"
    problem = problem_from_program(parse_program(ROOT / program), load_robot("irb6660_205_190"), force_tool=(200.0, 100.0, 300.0), conf_mode=mode)
    axes = [pl.grid_axis(tuple(float(v) for v in part.split(":")), name) for part, name in zip(search.split(","), "xyt")]
    cand = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    stride = 1 if mode == "rederive" else 7  # the kept-data reference tries every turn of every branch: 10x slower
    frames = pl.placement_frames(cand[::stride], 1170.0)
    product = pl.evaluate(problem, frames).reason
    ref = np.zeros(len(frames), dtype=int)
    t0 = last = time.monotonic()
    for k, frame in enumerate(frames):
        ref[k] = reference_cell(problem, frame)[0]
        if time.monotonic() - last >= 10.0:
            last = time.monotonic()
            print(f"    reference: {k + 1} of {len(frames)} cells ({last - t0:.0f} s)", file=sys.stderr, flush=True)
    differ = int((ref != product).sum())
    counts = ", ".join(f"{k} {v}" for k, v in reason_counts(ref).items()) or "no infeasible cell"
    sampled = "" if stride == 1 else f" (every {stride}th cell)"
    return (f"  reference{sampled}: {(ref == 0).sum()} of {len(ref)} feasible ({time.monotonic() - t0:.0f} s); {counts}; "
            f"cells whose reason differs from the product's: {differ}" + ("" if not differ else f" (first: {REASONS[ref[np.nonzero(ref != product)[0][0]]]})"))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--search", default="300:1500:50,-600:600:50,0:90:15", help="grid (4,375 cells by default)")
    parser.add_argument("--before", type=Path, help="another checkout whose postproc to run the same cases on")
    parser.add_argument("--reference", action="store_true", help="count with the brute-force reference too (slow)")
    args = parser.parse_args()
    print(f"postproc place {' '.join(COMMON)} --search {args.search}; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
    for program, extra, what in CASES:
        print(f"\n{program} {' '.join(extra)}: {what}")
        if args.before is not None:
            if extra:
                print(f"  before ({args.before}): option {' '.join(extra)} did not exist")
            else:
                print(f"  before ({args.before}):")
                print(describe(*run_place(program, extra, args.search, args.before)))
            print("  after:")
        print(describe(*run_place(program, extra, args.search, None)))
        if args.reference:
            print(reference_counts(program, extra, args.search), flush=True)


if __name__ == "__main__":
    main()
