"""Placement search speed: >= 10,000 candidate workpiece frames x 100 cutter-contact points (target <= 10 s on 2 cores).

Run: .venv/bin/python benchmarks/placement.py [--points 100] [--spacing 10] [--grid 22,23,20] [--box ...] [--repeat 3]
The program is a straight face-milling pass of ``--points`` targets on seed 002's block
(KRL, no Status/Turn: the branch follows the path), the robot the IRB6660-205/1.9, the
force a constant tool-frame force. Timed: the vectorised grid evaluation (IK on the
program's branch, limits, singularity margins, Jacobian, C_tt, normal error, weighted mean)
and the bounded refinement after it. Also timed on a subsample: the same library calls one
candidate at a time, for the ratio. The machine is shared: the wall time is printed with the
process CPU time and the load average so that contention shows.
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from postproc.process import placement as pl
from postproc.process.place_program import problem_from_program
from postproc.programs import parse_program
from postproc.robot.robots import load_robot


def make_program(path: Path, points: int, spacing: float = 10.0) -> None:
    lines = ["DEF pass( )", "$TOOL = {X 0, Y 0, Z 250, A 0, B 0, C 0}", "$BASE = {X 1000, Y 0, Z 1170, A 0, B 0, C 0}",
             "PTP {X 0, Y 50, Z 150, A 0, B 180, C 0}"]
    lines += [f"LIN {{X {spacing * i:.1f}, Y 50, Z 100, A 0, B 180, C 0}}" for i in range(points - 1)]
    lines.append("END")
    path.write_text("\n".join(lines) + "\n")


def make_rapid_program(path: Path, points: int, spacing: float) -> None:
    """The same pass in RAPID, every robtarget with the confdata of its joints at x 1000, y 0, theta 0."""
    from postproc.robot import kinematics as kin

    robot = load_robot("irb6660_205_190")
    local = np.array([[spacing * i, 50.0, 100.0] for i in range(points)])
    tool, poses = np.eye(4), np.repeat(np.eye(4)[None], points, axis=0)
    tool[2, 3] = 250.0
    poses[:, :3, :3], poses[:, :3, 3] = np.diag([1.0, -1.0, -1.0]), local
    frame = pl.placement_frames([[1000.0, 0.0, 0.0]], 1170.0)[0]
    q, _ = kin.select_nearest(robot, kin.ik(robot, frame @ poses @ np.linalg.inv(tool)), np.zeros(6))
    conf = kin.abb_confdata(robot, np.nan_to_num(q))
    lines = ["MODULE Pass", "  PERS tooldata spindle := [TRUE,[[0,0,250],[1,0,0,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];",
             '  TASK PERS wobjdata block := [FALSE,TRUE,"",[[1000,0,1170],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];', "  PROC main()"]
    lines += [f"    MoveL [[{p[0]:g},{p[1]:g},{p[2]:g}],[0,1,0,0],[{c[0]},{c[1]},{c[2]},{c[3]}],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\\WObj:=block;"
              for p, c in zip(local, conf)]
    path.write_text("\n".join(lines + ["  ENDPROC", "ENDMODULE", ""]))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=100)
    parser.add_argument("--spacing", type=float, default=10.0, help="mm between targets (2: a 200 mm pass, most candidates feasible)")
    parser.add_argument("--grid", default="22,23,20", help="candidates along x, y, theta")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--rapid", action="store_true", help="a RAPID program with confdata: the branch follows cf1, cf4, cf6, cfx")
    parser.add_argument("--box", default="0,1800,-1100,1100,0,180",
                        help="x0,x1,y0,y1,t0,t1 of the grid (mm, deg); 700,1300,-300,300,0,90 is all feasible (the slow case)")
    args = parser.parse_args()
    nx, ny, nt = (int(v) for v in args.grid.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        program = Path(tmp) / ("pass.mod" if args.rapid else "pass.src")
        (make_rapid_program if args.rapid else make_program)(program, args.points, args.spacing)
        tp = parse_program(program)
    problem = problem_from_program(tp, load_robot("irb6660_205_190"), force_tool=(200.0, 100.0, 300.0))
    x0, x1, y0, y1, t0, t1 = (float(v) for v in args.box.split(","))
    xs, ys, ts = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny), np.linspace(t0, t1, nt)
    pl.search(problem, xs[:2], ys[:2], ts[:2], 1170.0, refine=False)  # compile / warm up
    print(f"{nx * ny * nt} candidates x {len(problem.local_tcp)} points = {nx * ny * nt * len(problem.local_tcp):,} poses; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} before; box {args.box}")
    for r in range(args.repeat):
        cpu0, t0 = time.process_time(), time.perf_counter()
        res = pl.search(problem, xs, ys, ts, 1170.0, refine=False)
        grid_s, grid_cpu = time.perf_counter() - t0, time.process_time() - cpu0
        t1 = time.perf_counter()
        refined = pl.search(problem, xs, ys, ts, 1170.0, refine=True)
        total_s = time.perf_counter() - t1
        print(f"run {r + 1}: grid {grid_s:.2f} s wall ({grid_cpu:.2f} s CPU), grid + refinement {total_s:.2f} s; "
              f"{np.isfinite(res.grid_mean_mm).sum()} feasible; best {refined.best_mm * 1000:.2f} um at "
              f"x {refined.best[0]:.1f}, y {refined.best[1]:.1f}, theta {refined.best[2]:.2f} ({refined.evaluated} evaluated); "
              f"load average {os.getloadavg()[0]:.1f}")
    sample = np.stack(np.meshgrid(xs[::4], ys[::4], ts[::4], indexing="ij"), -1).reshape(-1, 3)[:50]
    t0 = time.perf_counter()
    for c in sample:
        pl.evaluate(problem, pl.placement_frames(c, 1170.0))
    loop = (time.perf_counter() - t0) / len(sample)
    print(f"one candidate at a time: {loop * 1000:.1f} ms each -> {loop * nx * ny * nt:.0f} s for the grid")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB (chunks of {pl.CHUNK_POSES:,} poses)")


if __name__ == "__main__":
    main()
