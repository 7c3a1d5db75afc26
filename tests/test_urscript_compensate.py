"""A compensated URScript program run on a simulated true UR10e (issue 29).

The program: set_tcp, a movej to joint values, then movel targets along a short joint-space
path. The controller is modelled here, independently of postproc.robot.posture, as the URScript
manual states it ("movel": the inverse kinematics nearest the current joints): each movel
target on the IK solution nearest the previous joints, a per-point loop as a controller steps.
Started in each of two configurations (the movej sets it: joint values, or get_inverse_kin with
qnear as PolyScope writes a MoveJ waypoint), the compensated program lands
within 0.05 mm of the programmed TCP positions.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL, nearest_walk, true_tcp, truth_and_fit
from scipy.spatial.transform import Rotation

import postproc
from postproc.jobs.compensate import compensate
from postproc.model.sim import Cylinder
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind
from postproc.robot import kinematics as kin

Q_START = np.array([180.0, -100.0, 100.0, -90.0, -90.0, 0.0])  # arm towards +x, tool down, elbow up
STEP = np.array([0.5, 0.3, -0.3, 0.4, 0.2, 0.5])
N_LIN = 20


@pytest.fixture(scope="module")
def robot():
    return postproc.load_robot("ur10e")


def _in_every_configuration(robot, q, rng):
    """The same TCP poses, each on a random one of its IK solutions (a model serving every
    configuration is measured in every one)."""
    sols = kin.ik(robot, kin.fk(robot, q))
    valid = ~np.isnan(sols).any(axis=2) & kin.within_limits(robot, np.nan_to_num(sols).reshape(-1, 6)).reshape(len(q), 8)
    pick = np.array([rng.choice(np.nonzero(v)[0]) for v in valid])
    return sols[np.arange(len(q)), pick]


@pytest.fixture(scope="module")
def truth_and_model(robot):
    return truth_and_fit(robot, FRAME_AND_COMPLIANCE, seed=7, n=400, cv_folds=0, region=Cylinder(radius_mm=(450.0, 900.0), z_mm=(100.0, 500.0)),
                         poses=lambda q, rng: _in_every_configuration(robot, q, rng))


def _pose(t):
    x, y, z = t[:3, 3] / 1000.0
    r = Rotation.from_matrix(t[:3, :3]).as_rotvec()
    return f"p[{x:.6f}, {y:.6f}, {z:.6f}, {r[0]:.6f}, {r[1]:.6f}, {r[2]:.6f}]"


def _program(robot, q_start, path, polyscope=False):
    """set_tcp, a movej that sets the posture, movel to the TCP poses of a joint-space path (m,
    rotation vectors). The movej: to joint values q_start (radians); or, as PolyScope writes a
    MoveJ waypoint inside its ``while (True):`` loop, movej(get_inverse_kin(Waypoint_1_p,
    qnear=Waypoint_1_q)) with Waypoint_1_q = q_start (the solution nearest it)."""
    q_path = q_start + np.arange(1, N_LIN + 1)[:, None] * STEP
    tcp = kin.fk(robot, q_path, tool=TOOL)
    q_text = "[" + ", ".join(f"{v:.6f}" for v in np.radians(q_start)) + "]"
    lines = ["def pocket():", f"  set_tcp(p[0, 0, {TOOL[2] / 1000:g}, 0, 0, 0])"]
    if polyscope:
        lines += [f"  global Waypoint_1_p={_pose(kin.fk(robot, q_start[None], tool=TOOL)[0])}", f"  global Waypoint_1_q={q_text}", "  while (True):",
                  '    $ 1 "Robot Program"', "    movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), a=1.3962634015954636, v=1.0471975511965976)"]
    else:
        lines.append(f"  movej({q_text}, a=1.4, v=1.05)")
    lines += [f"    movel({_pose(t)}, a=1.2, v=0.1)" for t in tcp]
    path.write_text("\n".join(lines + (["  end"] if polyscope else []) + ["end"]) + "\n")
    return path


def _run_on_true_robot(robot, truth, tp):
    """The controller: the movej's joints (or the solution of its pose nearest qnear), then each
    movel on the IK solution nearest the previous joints."""
    if tp.kind[0] == Kind.ABSJ:
        q_prev = tp.joints[0]
    else:
        q_prev = kin.select_nearest(robot, kin.ik(robot, tp.flange_poses()[:1]), tp.extras["urscript.qnear_deg"][:1])[0][0]
    flange = tp.base_poses()[1:] @ np.linalg.inv(tp.tools[tp.tool[1:]])
    return true_tcp(truth, tp, nearest_walk(robot, flange, q_prev), rows=np.arange(1, len(tp)))


@pytest.mark.parametrize("branch, polyscope", [(4, False), (5, False), (0, True)])
def test_the_compensated_program_lands_on_the_true_robot(robot, truth_and_model, tmp_path, branch, polyscope):
    """Branch 4 is Q_START itself, 5 its pose with the elbow down (the posture nearest all-zero
    joints), 0 with the wrist flipped as well: only the rule that the movej's qnear selects
    the solution finds the joints the controller takes there."""
    truth, model = truth_and_model
    q_start = kin.ik(robot, kin.fk(robot, Q_START[None]))[0, branch]
    assert not np.isnan(q_start).any()
    tp = parse_program(_program(robot, q_start, tmp_path / "pocket.script", polyscope))
    assert tp.placed().all()
    goal = tp.base_poses()[1:, :3, 3]
    as_written = np.sqrt(np.mean(np.sum((_run_on_true_robot(robot, truth, tp) - goal) ** 2, axis=1)))
    new, report = compensate(tp, model)
    assert not report.failed.any(), report.failures()
    out = tmp_path / "out.script"
    out.write_text(emit_texts(tp, new)[0], encoding="latin-1")
    written = parse_program(out)
    rms = float(np.sqrt(np.mean(np.sum((_run_on_true_robot(robot, truth, written) - goal) ** 2, axis=1))))
    print(f"branch {branch}{' (PolyScope qnear)' if polyscope else ''}: true TCP RMS {as_written:.4f} mm as written, {rms:.4f} mm compensated")
    assert as_written > 0.3 and rms <= 0.05, f"true RMS {as_written:.4f} mm as written, {rms:.4f} mm compensated"
    # only numbers changed: the same lines, in metres and radians
    assert [line.split("[")[0] for line in out.read_text().splitlines()] == [line.split("[")[0] for line in tp.sources[0].text.splitlines()]


def test_before_any_joint_target_the_start_joints_must_be_given(robot, truth_and_model, tmp_path):
    """movel takes the solution nearest the current joints: before the program's first joint
    target those are the robot's at the start, which the program does not state. Compensation
    refuses those targets, and takes them with the start joints given (--start-joints)."""
    _, model = truth_and_model
    path = _program(robot, Q_START, tmp_path / "pocket.script")
    lines = path.read_text().splitlines()
    path.write_text("\n".join(line for line in lines if "movej" not in line) + "\n")
    tp = parse_program(path)
    _, report = compensate(tp, model)
    assert report.failed.all() and all("--start-joints" in why for _, why in report.failures())
    _, report = compensate(tp, model, start_joints=Q_START)
    assert not report.failed.any(), report.failures()
