"""A FreeCAD job posted for a robot: FreeCAD's Profile operation, compensated, run on the true robot.

The path commands are the ones FreeCAD 0.20.2 handed the postproc post for
examples/freecad/part.FCStd (recorded by examples/freecad/dump_commands.py), so this runs
without FreeCAD; in FreeCAD the same request comes from the installed post (README
"Use from FreeCAD"). A simulated KR160 is measured, a model fitted, the job posted as KRL
with the options a FreeCAD user gives, and the CAM path compared with where the true robot's
TCP goes for the program as CAM wrote it and for the compensated program.
Run: .venv/bin/python examples/freecad_post.py [output folder, default out/]
"""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import postproc
from postproc.cam.freecad import planned_targets, run
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.model_io import save_model
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.programs import parse_program
from postproc.robot import kinematics as kin

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
out.mkdir(parents=True, exist_ok=True)
robot = postproc.load_robot("kr160_r1570")
tool = np.array([0.0, 0.0, 200.0])
rng = np.random.default_rng(7)
effects = parse_effects("geometric,base_frame,tool_offset,joint_compliance")
truth = random_truth(robot, tool, effects, rng)
result = fit(robot, tool, effects, simulate(truth, sample_poses(robot, tool, 300, Cylinder(), rng), rng), cv_folds=0)
save_model(out / "model.json", result.model, result)
print(f"1. model fitted on 300 simulated poses: {result.before.rms_mm:.3f} -> {result.after.rms_mm:.4f} mm RMS")

recorded = json.loads((Path(__file__).parent / "freecad" / "part_commands.json").read_text())
request = {"argstring": f"--model {out / 'model.json'} --to krl --frame G54=900,-100,350 --tool 1=0,0,200 --initial-tool 1 --start 40,25,60",
           "filename": str(out / "part.src"), "objects": recorded["sections"][0]}
answer = run(request)
n_commands = sum(len(o["commands"]) for o in request["objects"])
print(f"2. {n_commands} FreeCAD commands ({', '.join(o['label'] for o in request['objects'])}) -> {', '.join(answer['files'])}")


def true_tcp(tp):
    """Where the true robot's TCP goes: the controller's nominal IK along the path, then the true robot."""
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, _, _ = kin.select_path(robot, kin.ik(robot, flange), np.zeros(6))
    m = replace(truth, tool_mm=tp.tools[tp.tool[0]][:3, 3])
    return m.predict_prepared(m.prepare(q_deg=q))


cam = planned_targets(request)  # the CAM path in the robot base frame
goal = cam.base_positions()
for label, program in (("as CAM wrote it", cam), ("compensated", parse_program(out / "part.src"))):
    err = np.linalg.norm(true_tcp(program) - goal, axis=1)
    print(f"3. {len(goal)} targets {label}: true TCP error RMS {np.sqrt(np.mean(err**2)):.4f} mm, max {err.max():.4f} mm")
