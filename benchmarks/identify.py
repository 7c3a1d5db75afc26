"""Identification time for 1,000 poses with every effect of the catalog (target: <= 10 s).

Run: .venv/bin/python benchmarks/identify.py [--n 1000]
Times one fit with explicit harmonic terms and one where the fit chooses them, each with
and without 5-fold cross-validation, on a simulated KR160 that has all the effects.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

EVERYTHING = "geometric,base_frame,tool_offset,joint_compliance,external_load,{harmonics},backlash,thermal"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    args = parser.parse_args()
    robot = postproc.load_robot("kr160_r1570")
    tool = [0.0, 0.0, 200.0]
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects(EVERYTHING.format(harmonics="joint_harmonics[joints=2,3;orders=1,2]")), rng)
    data = simulate(truth, sample_poses(robot, tool, args.n, Cylinder(), rng), rng)
    print(f"{args.n} poses, KR160 with every catalog effect")
    print(f"{'harmonic terms':<34}{'CV folds':>9}{'seconds':>9}{'params':>8}{'RMS mm':>9}   target <= 10 s")
    for harmonics in ("joint_harmonics[joints=1,2,3,4,5,6;orders=1,2]", "joint_harmonics"):
        for folds in (0, 5):
            effects = parse_effects(EVERYTHING.format(harmonics=harmonics))
            t0 = time.perf_counter()
            result = fit(robot, tool, effects, data, cv_folds=folds)
            seconds = time.perf_counter() - t0
            label = "explicit (12 terms, 24 coeffs)" if "[" in harmonics else "chosen by the fit"
            verdict = "met" if seconds <= 10 else "MISSED"
            print(f"{label:<34}{folds:>9}{seconds:>9.2f}{len(result.model.params):>8}{result.after.rms_mm:>9.4f}   {verdict}")


if __name__ == "__main__":
    main()
