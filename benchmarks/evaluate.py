"""Time of one model prediction and one identification Jacobian (1,000 poses, every effect).

Run: .venv/bin/python benchmarks/evaluate.py [--n 1000]
The Jacobian is what every least-squares iteration of ``fit`` computes; best of 7 x 10 calls.
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

EVERYTHING = "geometric,base_frame,tool_offset,joint_compliance,external_load,joint_harmonics[joints=1,2,3,4,5,6;orders=1,2],backlash,thermal,link_bending"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000)
    args = parser.parse_args()
    robot = postproc.load_robot("kr160_r1570")
    tool = [0.0, 0.0, 200.0]
    rng = np.random.default_rng(0)
    truth = random_truth(robot, tool, parse_effects(EVERYTHING), rng)
    prep = truth.prepare(simulate(truth, sample_poses(robot, tool, args.n, Cylinder(), rng), rng))
    jac = min(timeit.repeat(lambda: truth.evaluate(prep), number=10, repeat=7)) / 10
    pred = min(timeit.repeat(lambda: truth.predict_prepared(prep), number=10, repeat=7)) / 10
    print(f"{args.n} poses, {len(truth.params)} parameters: predict {1e3 * pred:.1f} ms, predict + Jacobian {1e3 * jac:.1f} ms")


if __name__ == "__main__":
    main()
