"""The whole chain: measurements -> fitted model -> compensated program -> the true robot cuts where asked.

A simulated KUKA KR160 (its true errors: DH geometry, base and tool frames, joint
compliance under gravity) is measured at 300 poses with 0.02 mm noise; a model is fitted;
a KRL milling program is compensated and both programs are "run" on the true robot
(nominal IK of the commanded targets, then the true forward model).
Run: .venv/bin/python examples/compensate_chain.py [output folder, default out/]
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import postproc
from postproc.jobs.compensate import compensate
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.measurements import write_measurements
from postproc.model.model_io import save_model
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.programs import emit_texts, parse_program
from postproc.robot import kinematics as kin

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
out.mkdir(parents=True, exist_ok=True)
robot = postproc.load_robot("kr160_r1570")
tool = np.array([0.0, 0.0, 200.0])
rng = np.random.default_rng(7)
effects = parse_effects("geometric,base_frame,tool_offset,joint_compliance")

# 1. Measure the robot (here: a simulated one whose true errors we know).
truth = random_truth(robot, tool, effects, rng)
measurements = simulate(truth, sample_poses(robot, tool, 300, Cylinder(), rng), rng)
write_measurements(out / "measurements.csv", measurements)

# 2. Fit the error model.
result = fit(robot, tool, effects, measurements)
save_model(out / "model.json", result.model, result, measurements=str(out / "measurements.csv"))
print(f"1. fitted {effects.spec()} on 300 poses: {result.before.rms_mm:.3f} -> {result.after.rms_mm:.4f} mm RMS (cross-validated {result.cv_rms_mm:.4f} mm)")

# 3. A milling program: a pocket outline at 2 mm depth, tool pointing down.
lines = ["DEF pocket( )", "; pocket outline, depth 2 mm", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$VEL.CP = 0.05", "$APO.CDIS = 0.2"]
corners = [(900, -200), (1150, -200), (1150, 200), (900, 200), (900, -200)]
for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:]):
    for t in np.linspace(0, 1, 26)[:-1]:
        lines.append(f"LIN {{X {x0 + t * (x1 - x0):.3f}, Y {y0 + t * (y1 - y0):.3f}, Z 448.000, A 0, B 180, C 0}} C_DIS")
lines.append("END")
(out / "pocket.src").write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")

# 4. Compensate it and write the corrected program (only its numbers change).
program = parse_program(out / "pocket.src")
corrected, report = compensate(program, result.model)
if report.failed.any():  # e.g. targets outside the region the model was measured in: nothing to run
    sys.exit(f"{int(report.failed.sum())} target(s) cannot be compensated: {report.failures()[:3]}")
(out / "pocket_compensated.src").write_bytes(emit_texts(program, corrected)[0].encode("latin-1"))
s = report.summary()
print(f"2. compensated {s['compensated']} targets: predicted error {s['predicted_before']['rms_mm']:.3f} -> {s['predicted_after']['rms_mm']:.5f} mm RMS, "
      f"{s['iterations_median']:.0f} iterations (median), largest correction {s['max_correction_mm']:.3f} mm")

# 5. Run both programs on the true robot.
def true_tcp(tp):
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, _ = kin.select_nearest(robot, kin.ik(robot, flange), np.array([0.0, 0.0, 0.0, 0.0, -90.0, 0.0]))
    m = replace(truth, tool_mm=tool)
    return m.predict_prepared(m.prepare(q_deg=q))


goal = program.base_positions()
before = np.linalg.norm(true_tcp(program) - goal, axis=1)
after = np.linalg.norm(true_tcp(parse_program(out / "pocket_compensated.src")) - goal, axis=1)
print(f"3. on the true robot: TCP error RMS {np.sqrt(np.mean(before**2)):.3f} mm (max {before.max():.3f}) as written, "
      f"{np.sqrt(np.mean(after**2)):.4f} mm (max {after.max():.4f}) compensated")
print(f"   files in {out}/: measurements.csv, model.json, pocket.src, pocket_compensated.src")
print("   first changed line:")
original_lines = (out / "pocket.src").read_text(encoding="latin-1").splitlines()
new_lines = (out / "pocket_compensated.src").read_text(encoding="latin-1").splitlines()
first = next(i for i, (a, b) in enumerate(zip(original_lines, new_lines)) if a != b)
print(f"     - {original_lines[first]}\n     + {new_lines[first]}")
