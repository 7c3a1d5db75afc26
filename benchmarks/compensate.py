"""A 10^6-point KRL program end to end: parse, compensate with a physics model, emit (target <= 20 s).

Run: .venv/bin/python benchmarks/compensate.py [--points 1000000]
The model (geometric, base_frame, tool_offset, joint_compliance) is fitted once from a
simulated KR160 before timing. A per-point loop (the same library calls on one target at
a time) runs on a subsample and is reported as points/s, for the ratio.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import postproc
from postproc.jobs.compensate import compensate
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.programs import emit_texts, parse_program, write_texts


def make_program(path: Path, n: int) -> None:
    side = int(np.ceil(np.sqrt(n)))
    with open(path, "w", encoding="latin-1") as fh:
        fh.write("DEF raster( )\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n$APO.CDIS = 0.2\n")
        for i in range(n):
            x = 850.0 + 300.0 * (i // side) / side
            y = -250.0 + 500.0 * (i % side) / side
            fh.write(f"LIN {{X {x:.3f}, Y {y:.3f}, Z 450.000, A 0, B 180, C 0}} C_DIS\n")
        fh.write("END\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    args = parser.parse_args()
    robot = postproc.load_robot("kr160_r1570")
    tool = np.array([0.0, 0.0, 200.0])
    rng = np.random.default_rng(0)
    effects = parse_effects("geometric,base_frame,tool_offset,joint_compliance")
    truth = random_truth(robot, tool, effects, rng)
    model = fit(robot, tool, effects, simulate(truth, sample_poses(robot, tool, 300, Cylinder(), rng), rng)).model
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "raster.src"
        make_program(src, args.points)
        times = {}
        t0 = time.perf_counter()
        tp = parse_program(src)
        times["parse"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        new, report = compensate(tp, model)
        times["compensate"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        texts = emit_texts(tp, new)
        times["emit"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        write_texts(texts, [Path(tmp) / "out.src"])
        times["write"] = time.perf_counter() - t0
        total = sum(times.values())
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        # Per-point loop on a subsample: the same calls, one target at a time.
        sub = 200
        small = Path(tmp) / "one.src"
        make_program(small, sub)
        tps = parse_program(small)
        t0 = time.perf_counter()
        for i in range(sub):
            compensate(tps.take([i]), model)
        loop_rate = sub / (time.perf_counter() - t0)
    s = report.summary()
    rate = args.points / total
    print(f"{args.points:,} KRL targets, KR160, model {effects.spec()}")
    for k, v in times.items():
        print(f"  {k:<11}{v:7.2f} s")
    print(f"  {'total':<11}{total:7.2f} s  ({rate:,.0f} points/s; target <= 20 s: {'met' if total <= 20 else 'MISSED'})")
    print(f"  per-point loop: {loop_rate:,.0f} points/s -> vectorised is {rate / loop_rate:,.0f}x faster")
    print(f"  predicted error RMS {s['predicted_before']['rms_mm']:.3f} -> {s['predicted_after']['rms_mm']:.5f} mm; iterations median {s['iterations_median']:.0f}, max {s['iterations_max']}; failed {s['failed']}")
    print(f"  peak memory {peak:,.0f} MB")


if __name__ == "__main__":
    main()
