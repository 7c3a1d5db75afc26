"""Run a URScript program and its compensated copy on a simulated true robot and print the TCP errors.

Usage: .venv/bin/python examples/urscript/measure_on_truth.py TRUTH.json PROGRAM.script COMPENSATED.script

TRUTH.json is the true robot ``postproc simulate --truth`` wrote. The controller is modelled as
the URScript manual states it: the first target (a movej to joints, or to get_inverse_kin(pose,
qnear=q): the solution nearest q), then each movel on the inverse-kinematics solution nearest
the previous joints ("movel"). Errors are measured at the movel targets against the program as
written.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import numpy as np

from postproc import kinematics as kin
from postproc.ir import Kind
from postproc.model_io import load_model
from postproc.programs import parse_program


def run(truth, tp) -> np.ndarray:
    """True TCP positions (N-1, 3) of the targets after the first, as the controller drives them."""
    robot = truth.robot
    if tp.kind[0] == Kind.ABSJ:
        q_prev = tp.joints[0]
    else:
        q_prev = kin.select_nearest(robot, kin.ik(robot, tp.flange_poses()[:1]), tp.extras["urscript.qnear_deg"][:1])[0][0]
    reached = []
    for sols in kin.ik(robot, tp.flange_poses()[1:]):
        ok = [s for s in sols if not np.isnan(s).any()]
        steps = [np.abs((s - q_prev + 180.0) % 360.0 - 180.0).sum() for s in ok]
        q_prev = q_prev + ((ok[int(np.argmin(steps))] - q_prev + 180.0) % 360.0 - 180.0)
        reached.append(q_prev)
    true = replace(truth, tool_mm=tp.tools[tp.tool[1]][:3, 3])
    return true.predict_prepared(true.prepare(q_deg=np.array(reached)))


def main() -> None:
    truth = load_model(sys.argv[1])[0]
    written, compensated = parse_program(sys.argv[2]), parse_program(sys.argv[3])
    goal = written.base_poses()[1:, :3, 3]
    for name, tp in (("as written", written), ("compensated", compensated)):
        error = np.linalg.norm(run(truth, tp) - goal, axis=1)
        print(f"{name}: true TCP error RMS {np.sqrt(np.mean(error**2)):.4f} mm, max {error.max():.4f} mm")


if __name__ == "__main__":
    main()
