"""An INFORM job compensated end to end: a true robot, a model fitted from its simulated
measurements, the job compensated and run on the true robot (the controller takes the
IK solution its ///RCONF form names for the MOVJ, the MOVL lines keep that posture)."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, kr160, truth_and_fit

from postproc.jobs.compensate import compensate
from postproc.programs import emit_texts, parse_program
from postproc.programs.dialects.inform.form import form_of_joints
from postproc.robot import kinematics as kin

TOOL_0 = np.eye(4)
TOOL_0[:3, 3] = [0.0, 0.0, 200.0]  # tool file 0 of the controller: given, as the job cannot hold it


def run_on(truth, tp, q):
    """Where the true robot's TCP goes at joints q (the nominal controller's IK of the job's targets)."""
    m = replace(truth, tool_mm=tp.tools[tp.tool[0]][:3, 3])
    return m.predict_prepared(m.prepare(q_deg=q))


def controller_joints(robot, tp):
    """Joints the nominal controller drives to: the MOVJ's form picks its solution, every MOVL
    then stays on that branch (the nearest solution to the previous target)."""
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    sols = kin.ik(robot, flange)
    q = np.zeros((len(tp), 6))
    from postproc.programs.dialects.inform.form import select_by_form

    q[:1] = select_by_form(robot, sols[:1], tp.conf[:1])[0]
    for i in range(1, len(tp)):
        q[i] = kin.select_nearest(robot, sols[i : i + 1], q[i - 1])[0][0]
    return q


def inform_job(tmp_path, robot):
    xs = np.linspace(850, 1150, 16)
    pts = [(x, y, 450.0 + 0.1 * k) for k, x in enumerate(xs) for y in (-250.0, 250.0)]
    first = np.eye(4)
    first[:3, :3] = np.diag([-1.0, 1.0, -1.0])  # Rx 180, Rz 180: the tool points down, A6 near 0
    first[:3, 3] = pts[0]
    q0, _ = kin.select_nearest(robot, kin.ik(robot, (first @ np.linalg.inv(TOOL_0))[None]), np.array([0.0, -90.0, 90.0, 0.0, -90.0, 0.0]))
    flip, arm, side, turns = form_of_joints(robot, q0)[0].astype(int)
    rconf = f"{flip},{arm},{side},{turns & 1},{turns >> 1 & 1},{turns >> 2 & 1},0,0"
    pos = [f"C{i:05d}={x:.3f},{y:.3f},{z:.3f},180.0000,0.0000,180.0000" for i, (x, y, z) in enumerate(pts)]
    inst = ["MOVJ C00000 VJ=20.00"] + [f"MOVL C{i:05d} V=50.0 PL=0" for i in range(1, len(pts))]
    lines = ["/JOB", "//NAME PART", "//POS", f"///NPOS {len(pts)},0,0,0,0,0", "///TOOL 0", "///POSTYPE ROBOT", "///RECTAN",
             f"///RCONF {rconf}", *pos, "//INST", "///ATTR SC,RW", "///GROUP1 RB1", "NOP", *inst, "END", ""]
    path = tmp_path / "PART.JBI"
    path.write_bytes("\r\n".join(lines).encode())
    return path


@pytest.fixture(scope="module")
def truth_and_model():
    return truth_and_fit(kr160(), FRAME_AND_COMPLIANCE, seed=21, cv_folds=0)


def test_compensated_job_lands_on_the_true_robot(tmp_path, truth_and_model):
    truth, model = truth_and_model
    path = inform_job(tmp_path, model.robot)
    tp = parse_program(path)
    tools = {"TOOL#(0)": TOOL_0}
    new, report = compensate(tp, model, tools=tools)
    assert not report.failed.any(), report.failures()
    old_placed, new_placed = tp.with_frames(tools=tools), new.with_frames(tools=tools)
    goal = old_placed.base_positions()
    before = np.linalg.norm(run_on(truth, old_placed, controller_joints(truth.robot, old_placed)) - goal, axis=1)
    after = np.linalg.norm(run_on(truth, new_placed, controller_joints(truth.robot, new_placed)) - goal, axis=1)
    assert np.sqrt(np.mean(before**2)) > 1.0
    assert np.sqrt(np.mean(after**2)) <= 0.05 and after.max() <= 0.05
    # Only numbers change, written with the file's own decimals (0.001 mm), and they read back.
    text = emit_texts(tp, new)[0]
    number = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
    assert number.sub("#", text) == number.sub("#", tp.sources[0].text)
    assert all(len(m.split(".")[1]) == 3 for m in re.findall(r"(?<=[=,])-?\d+\.\d+(?=,.*,.*,.*,)", text))
    back = parse_program(path, data=text.encode("latin-1"))
    np.testing.assert_allclose(back.position, new.position, atol=6e-4)
