"""diagnose on 1,000 poses with every candidate effect (target: <= 60 s).

Run: .venv/bin/python benchmarks/diagnose.py [--n 1000]
The model has geometry only (geometric, base_frame, tool_offset); the data carry every
optional column, so all five other catalog effects are candidates, each refitted with
5-fold cross-validation.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import postproc
from postproc.diagnose import diagnose
from postproc.effects import parse_effects
from postproc.identify import fit
from postproc.sim import Cylinder, random_truth, sample_poses, simulate


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    args = parser.parse_args()
    robot = postproc.load_robot("kr160_r1570")
    tool = [0.0, 0.0, 200.0]
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects("geometric,base_frame,tool_offset,joint_compliance,external_load,backlash"), rng)
    data = simulate(truth, sample_poses(robot, tool, args.n, Cylinder(), rng), rng)
    model = fit(robot, tool, parse_effects("geometric,base_frame,tool_offset"), data, cv_folds=0).model
    t0 = time.perf_counter()
    result = diagnose(model, data)
    seconds = time.perf_counter() - t0
    print(f"diagnose, {args.n} poses, {len(result.candidates)} candidates, 5-fold CV: {seconds:.1f} s (target <= 60 s: {'met' if seconds <= 60 else 'MISSED'})")
    for c in result.candidates:
        print(f"  {c.effect:<40} explained {100 * c.explained:5.1f}%  CV RMS if added {c.rms_if_added_mm:.4f} mm  {'significant' if c.significant else ''}")


if __name__ == "__main__":
    main()
