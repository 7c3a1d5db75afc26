"""Kinematics throughput (poses/s) for N = 10^6, against per-pose loops on the same machine.

Run: .venv/bin/python benchmarks/kinematics.py [--n 1000000] [--robot kr160_r1570]
Targets (issue 2): FK >= 2e6 poses/s, IK >= 5e5 poses/s on 2 cores.
The per-pose baselines (pinocchio FK, scipy least-squares IK) run on a subsample and are
reported as poses/s, so the ratio compares like with like.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from scipy.optimize import least_squares

import postproc
from postproc.robot import pin_model


def best_of(repeats, func):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--robot", default="kr160_r1570")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    robot = postproc.load_robot(args.robot)
    rng = np.random.default_rng(0)
    q = rng.uniform(np.maximum(robot.lower_deg, -170), np.minimum(robot.upper_deg, 170), size=(args.n, 6))
    poses = postproc.fk(robot, q)

    t_fk = best_of(args.repeats, lambda: postproc.fk(robot, q))
    t_jac = best_of(args.repeats, lambda: postproc.jacobian(robot, q))
    t_ik = best_of(args.repeats, lambda: postproc.ik(robot, poses))

    # Per-pose baselines on subsamples.
    model = pin_model.build_model(robot)
    data = model.createData()
    n_pin = 20_000
    t_pin = best_of(1, lambda: [pin_model.flange_pose(model, data, qi) for qi in q[:n_pin]])

    def scipy_ik_one(target, seed):
        def residual(x):
            t = postproc.fk(robot, x[None])[0]
            return np.concatenate([t[:3, 3] - target[:3, 3], 100.0 * (t[:3, :3] - target[:3, :3]).ravel()])

        return least_squares(residual, seed, xtol=1e-12, ftol=1e-12).x

    n_scipy = 200
    seeds = q[:n_scipy] + rng.uniform(-5, 5, size=(n_scipy, 6))
    t_scipy = best_of(1, lambda: [scipy_ik_one(poses[i], seeds[i]) for i in range(n_scipy)])

    rate = lambda n, t: n / t  # noqa: E731
    rows = [
        ("FK (flange pose)", rate(args.n, t_fk), "pinocchio loop", rate(n_pin, t_pin), 2e6),
        ("Jacobian (6x6)", rate(args.n, t_jac), "pinocchio FK loop", rate(n_pin, t_pin), None),
        ("IK (all 8 branches)", rate(args.n, t_ik), "scipy least_squares loop", rate(n_scipy, t_scipy), 5e5),
    ]
    print(f"robot {robot.name}, N = {args.n:,}, {os.cpu_count()} CPU(s), best of {args.repeats}")
    print(f"{'kernel':<22}{'poses/s':>14}   {'baseline':<26}{'poses/s':>12}{'ratio':>10}   target")
    for name, ours, base_name, base, target in rows:
        verdict = "-" if target is None else (f">= {target:.0e} " + ("met" if ours >= target else "MISSED"))
        print(f"{name:<22}{ours:>14,.0f}   {base_name:<26}{base:>12,.0f}{ours / base:>9.0f}x   {verdict}")


if __name__ == "__main__":
    main()
