"""Which reducer harmonics does the fit choose? Simulated KR160s with harmonics 2:4 and 3:3
(joint:order), 120 poses to fit and 300 to validate, noise 0.02 mm per axis; the model
asks for ``joint_harmonics`` without options, so the fit chooses the terms
(postproc.model.term_selection: best subset over all 24 joint/order terms, cross-validated size,
selection frequency over resamples).

Run: .venv/bin/python examples/term_selection.py [seed ...]   (default seeds 4 5 7 9)
"""

from __future__ import annotations

import sys

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.identify import Stats, fit, residuals
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

MODEL = "geometric,base_frame,tool_offset,joint_compliance"
TOOL = np.array([0.0, 0.0, 200.0])
FLOOR = 0.02 * np.sqrt(3)

robot = postproc.load_robot("kr160_r1570")
seeds = [int(s) for s in sys.argv[1:]] or [4, 5, 7, 9]
print(f"true terms 2:4, 3:3; noise floor {FLOOR:.4f} mm (3-D RMS)")
for seed in seeds:
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, parse_effects(MODEL + ",joint_harmonics[terms=2:4,3:3]"), rng)
    train = simulate(truth, sample_poses(robot, TOOL, 120, Cylinder(), rng), rng, noise_mm=0.02)
    val = simulate(truth, sample_poses(robot, TOOL, 300, Cylinder(), rng), rng, noise_mm=0.02)
    result = fit(robot, TOOL, parse_effects(MODEL + ",joint_harmonics"), train, cv_folds=0)
    rms = Stats.of(residuals(result.model, val)).rms_mm
    print(f"seed {seed}: validation RMS {rms:.4f} mm ({rms / FLOOR:.2f} x floor)")
    for note in result.notes:
        print(f"  {note}")
