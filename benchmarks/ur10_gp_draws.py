"""How much the local GPR's result on Series A's random split depends on its own random draws.

Run: .venv/bin/python benchmarks/ur10_gp_draws.py SEED [DRAWS=3] [SHARED_EXPERTS=4]
Fits the physics (with the cyclic terms) on the split's training poses once, then the GPR
(`--gp-features tcp+joints+travel`) DRAWS times with random_state SEED, SEED + 1000, ...:
the draws differ in which experts share the start, the global sample and the margin poses an
expert takes. Prints each draw's held-out mean 3-D error and that of the draws' averaged
prediction. The first draw is what `postproc validate --seed SEED` computes. A.csv from
`postproc import-ur10` (benchmarks/ur10_series.py). About 2 min for the physics and 1.5 min
per draw on the shared 2-core machine.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from ur10_series import data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.learn.features import features
from postproc.model.learn.gp import GPRPredictor
from postproc.model.measurements import read_measurements
from postproc.model.validate import random_mask, with_order_columns
from postproc.robot.robots import load_robot

EFFECTS = "geometric,base_frame,tool_offset,joint_compliance,joint_harmonics[max_order=60]"
TOOL = np.array([0.0, 0.0, 109.0])


def split_residuals(a_csv: Path, seed: int):
    """GPR inputs and physics residuals of the training and held-out poses of the split."""
    robot = load_robot("ur10")
    meas = with_order_columns(parse_effects(EFFECTS), read_measurements(a_csv))
    test = random_mask(len(meas), 0.2, seed)
    train, held = meas.subset(~test), meas.subset(test)
    physics = fit(robot, TOOL, parse_effects(EFFECTS), train, cv_folds=0, seed=seed).model
    out = []
    for part in (train, held):
        X = features(robot, TOOL, part.q_deg, "tcp+joints+travel", None, part.path_history())
        out += [X, part.measured_mm - physics.predict(part)]
    return out


def main() -> None:
    seed = int(sys.argv[1])
    draws = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    shared = int(sys.argv[3]) if len(sys.argv) > 3 else 4
    with tempfile.TemporaryDirectory() as tmp:
        Xtr, ytr, Xte, yte = split_residuals(imported(data_folder(None), "A", Path(tmp) / "A.csv"), seed)
    predictions = []
    for k in range(draws):
        gp = GPRPredictor(anisotropic=True, random_state=seed + 1000 * k, shared_experts=shared).fit(Xtr, ytr)
        predictions.append(gp.predict(Xte))
        alone = np.linalg.norm(yte - predictions[-1], axis=1).mean()
        averaged = np.linalg.norm(yte - np.mean(predictions, axis=0), axis=1).mean()
        print(f"seed {seed}, draw {k} (random_state {seed + 1000 * k}): mean {alone:.4f} mm; the {k + 1} draws averaged: {averaged:.4f} mm", flush=True)


if __name__ == "__main__":
    main()
