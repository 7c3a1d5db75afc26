"""Which part of --noise-model settle does what on Series A's random split: the physics fit
with or without the weights, then the gpr with or without the noise ratios, on the same split.

Run: .venv/bin/python benchmarks/ur10_noise_parts.py PHYSICS_NOISE SEED GP_NOISES [GP_OPTIONS]
e.g. `none 0 none,settle` or `none 2 none "{'global_size': 1500}"` (A.csv from
`postproc import-ur10` in /tmp/ur10-noise/, or $UR10_A). Prints the physics fit's notes (the
ratios it estimated), the held-out error by place after the last large move, and the median
over the local experts of their hyperparameters from the 10th on (the length scales of joint
6 and of the three travel inputs, the log noise, then the places' log noise ratios).
About 4 min for the physics and 1.5-6 min per gpr on the shared 2-core machine.
"""

from __future__ import annotations

import ast
import os
import sys
import time
from pathlib import Path

import numpy as np

from postproc.model.effects import parse_effects
from postproc.model.identify import fit, fit_predictor, residuals
from postproc.model.measurements import read_measurements
from postproc.model.noise_model import settle_place
from postproc.model.validate import random_mask, with_order_columns
from postproc.robot.robots import load_robot

EFFECTS = "geometric,base_frame,tool_offset,joint_compliance,joint_harmonics[max_order=60]"
TOOL = np.array([0.0, 0.0, 109.0])


def main() -> None:
    physics_noise, seed, gp_noises = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
    gp_options = ast.literal_eval(sys.argv[4]) if len(sys.argv) > 4 else {}
    robot = load_robot("ur10")
    meas = with_order_columns(parse_effects(EFFECTS), read_measurements(Path(os.environ.get("UR10_A", "/tmp/ur10-noise/A.csv"))))
    test = random_mask(len(meas), 0.2, seed)
    train, held = meas.subset(~test), meas.subset(test)
    place = settle_place(robot, TOOL, held.q_deg, held.path_history())
    start = time.monotonic()
    result = fit(robot, TOOL, parse_effects(EFFECTS), train, cv_folds=0, seed=seed, noise=physics_noise)
    print(f"physics {physics_noise}: {time.monotonic() - start:.0f} s", *[n for n in result.notes if "noise" in n], sep="\n  ")
    err = np.linalg.norm(residuals(result.model, held), axis=1)
    print(f"physics held-out mean {err.mean():.4f} mm; by place 0..3:", " ".join(f"{err[place == k].mean():.4f}" for k in range(4)))
    for gp_noise in gp_noises:
        start = time.monotonic()
        model = fit_predictor(result.model, train, "gpr", seed=seed, gp_options={"features": "tcp+joints+travel", **gp_options}, noise=gp_noise)
        err = np.linalg.norm(residuals(model, held), axis=1)
        thetas = np.array([getattr(e, "theta_full_", e.kernel_.theta) for e in model.residual.estimator.experts_])
        print(f"gpr {gp_noise} {gp_options}: {time.monotonic() - start:.0f} s, mean {err.mean():.4f} median {np.median(err):.4f} mm; by place 0..3:",
              " ".join(f"{err[place == k].mean():.4f}" for k in range(4)))
        print("  experts' median hyperparameters from the 10th on (log):", np.round(np.median(thetas[:, 9:], axis=0), 2))


if __name__ == "__main__":
    main()
