"""Compensation on the posture the controller really takes (issue 13).

A KRL pocket starts with an axis-specific PTP into each of the robot's configurations
(shoulder, elbow, wrist flipped or not); the LIN targets after it keep that posture
(KSS: LIN ignores S and T). The compensated program is then run on a true robot by an
independent controller model written here: nominal IK, each LIN target on the solution
nearest the previous joints (a per-point loop, as a controller steps). Compensated on
any other branch the true error is tenths of a millimetre; on the right one it reaches
the model's accuracy.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL, nearest_walk, true_tcp, truth_and_fit

from postproc.jobs.compensate import compensate
from postproc.model.sim import JointBox
from postproc.programs import emit_texts, parse_program
from postproc.robot import kinematics as kin

# A pose whose IK solutions include every configuration the KR160's limits allow away from
# singularities: four (wrist flipped or not, elbow up or down); the other four need joint
# values outside the limits (or lie within 15 deg / 300 mm of a singularity) for any pose.
Q_CENTRE = np.array([-104.0, -6.0, 53.0, 161.0, -59.0, 169.0])
STEP = np.array([0.2, 0.04, -0.04, 0.2, 0.2, 0.2])
N_LIN = 20


@pytest.fixture(scope="module")
def truth_and_model(robot):
    # Measured over the joint ranges, so in every configuration and around the pocket (the
    # default cylinder holds only the elbow-up ones, 1 m below it).
    return truth_and_fit(robot, FRAME_AND_COMPLIANCE, seed=5, n=400, cv_folds=0, region=JointBox(),
                         poses=lambda q, rng: _in_every_configuration(robot, q, rng))


def _in_every_configuration(robot, q, rng):
    """The same TCP poses, each on a random one of its IK configurations inside the limits:
    a model that is to serve every configuration is measured in every one (parameters that
    one configuration family cannot separate differ between families)."""
    sols = kin.ik(robot, kin.fk(robot, q))
    valid = ~np.isnan(sols).any(axis=2) & kin.within_limits(robot, np.nan_to_num(sols).reshape(-1, 6)).reshape(len(q), 8)
    pick = np.array([rng.choice(np.nonzero(v)[0]) for v in valid])
    return sols[np.arange(len(q)), pick]


def _configurations(robot):
    """Every IK solution of the centre pose that lies inside the joint limits."""
    sols = kin.ik(robot, kin.fk(robot, Q_CENTRE[None]))[0]
    return [s for s in sols if not np.isnan(s).any() and kin.within_limits(robot, s[None])[0]]


def _pocket(robot, q_start, path):
    """PTP to q_start (axis values), then LIN to the TCP poses of a short joint-space path."""
    branch = kin.select_nearest(robot, kin.ik(robot, kin.fk(robot, Q_CENTRE[None])), q_start)[1][0]
    flange_path = kin.fk(robot, Q_CENTRE + (np.arange(N_LIN) - N_LIN // 2)[:, None] * STEP)
    q_path = kin.ik(robot, flange_path)[:, branch]
    tcp = kin.fk(robot, q_path, tool=TOOL)
    lines = ["DEF pocket( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", f"$TOOL = {{X 0, Y 0, Z {TOOL[2]:g}, A 0, B 0, C 0}}",
             "PTP {" + ", ".join(f"A{i + 1} {v:.4f}" for i, v in enumerate(q_start)) + "}"]
    from postproc.robot.frames import matrix_to_abc

    for pose in tcp:
        a, b, c = matrix_to_abc(pose[None, :3, :3])[0]
        x, y, z = pose[:3, 3]
        lines.append(f"LIN {{X {x:.4f}, Y {y:.4f}, Z {z:.4f}, A {a:.5f}, B {b:.5f}, C {c:.5f}}}")
    lines.append("END")
    path.write_text("\n".join(lines) + "\n")
    return path


def _run_on_true_robot(robot, truth, tp, joints=False):
    """The controller: the PTP's axis values, then each LIN on the IK solution nearest the
    previous joints. Returns the true TCP of the LIN targets and their intended positions."""
    flange = tp.base_poses()[1:] @ np.linalg.inv(tp.tools[tp.tool[1:]])
    reached = nearest_walk(robot, flange, tp.joints[0])
    tcp = true_tcp(truth, tp, reached, rows=np.arange(1, len(tp)))
    return (tcp, reached) if joints else tcp


def test_the_centre_pose_has_four_configurations(robot):
    assert len(_configurations(robot)) == 4


@pytest.mark.parametrize("config", range(4))
def test_every_start_configuration_reaches_model_accuracy(robot, truth_and_model, tmp_path, config):
    configs = _configurations(robot)
    truth, model = truth_and_model
    program = _pocket(robot, configs[config], tmp_path / "pocket.src")
    tp = parse_program(program)
    goal = tp.base_poses()[1:, :3, 3]
    as_written = np.linalg.norm(_run_on_true_robot(robot, truth, tp) - goal, axis=1)
    new, report = compensate(tp, model)
    assert not report.failed.any(), report.failures()
    (tmp_path / "out.src").write_text(emit_texts(tp, new)[0], encoding="latin-1")
    written = parse_program(tmp_path / "out.src")
    reached, q = _run_on_true_robot(robot, truth, written, joints=True)
    rms = float(np.sqrt(np.mean(np.sum((reached - goal) ** 2, axis=1))))
    # The model's own error at the joints the controller takes: what compensation can reach.
    m = replace(model, tool_mm=TOOL)
    t = replace(truth, tool_mm=TOOL)
    model_rms = float(np.sqrt(np.mean(np.sum((m.predict_prepared(m.prepare(q_deg=q)) - t.predict_prepared(t.prepare(q_deg=q))) ** 2, axis=1))))
    assert np.sqrt(np.mean(as_written**2)) > 0.3  # the robot really is off before compensation
    assert rms <= 0.05 and model_rms <= 0.01, (
        f"configuration {config} ({configs[config].round(1)}): true RMS {rms:.4f} mm after compensation, model error there {model_rms:.4f} mm")
    # the report's predicted error is the one on the controller's posture
    assert np.nanmax(report.after_mm) < 0.011


def test_krl_lin_ignores_status_and_turn_ptp_follows_them(tmp_path):
    from postproc.programs import dialects

    src = tmp_path / "p.src"
    src.write_text("DEF p( )\nPTP {X 1000, Y 0, Z 1200, A 0, B 90, C 0, S 2, T 10}\nLIN {X 1000, Y 50, Z 1200, A 0, B 90, C 0, S 6, T 2}\n"
                   "PTP {X 1000, Y 80, Z 1200, A 0, B 90, C 0}\nEND\n")
    tp = parse_program(src)
    assert dialects.of(tp).controller.conf_applies(tp).tolist() == [True, False, False]


def test_compensation_asks_the_controller_it_is_given(robot, tmp_path):
    """The KRC takes the PTP's Status/Turn; a user's controller that takes no configuration data
    leaves the robot in the posture it starts from (the same program, another posture)."""
    from postproc.jobs.compensate import reference_postures
    from postproc.model.effects import EffectSum
    from postproc.model.errormodel import ErrorModel
    from postproc.programs.controller import Controller

    class KeepsThePosture(Controller):
        def conf_applies(self, tp):
            return np.zeros(len(tp.kind), dtype=bool)

    from postproc.robot.frames import matrix_to_abc

    start = np.array([0.0, -90.0, 90.0, 0.0, 30.0, 0.0])
    flipped = start * np.array([1, 1, 1, 1, -1, 1]) + np.array([0, 0, 0, 180, 0, 180])  # the same pose, the wrist flipped
    pose = kin.fk(robot, flipped[None])[0]
    status, turn = kin.kuka_status_turn(robot, flipped[None])
    x, y, z = pose[:3, 3]
    a, b, c = matrix_to_abc(pose[None, :3, :3])[0]
    src = tmp_path / "p.src"
    src.write_text(f"DEF p( )\nPTP {{X {x:.4f}, Y {y:.4f}, Z {z:.4f}, A {a:.4f}, B {b:.4f}, C {c:.4f}, S {int(status[0])}, T {int(turn[0])}}}\nEND\n")
    tp = parse_program(src)
    model = ErrorModel.create(robot, np.zeros(3), EffectSum())
    by_status = reference_postures(tp, model, start_joints=start)
    kept = reference_postures(tp, model, start_joints=start, controller=KeepsThePosture())
    assert np.allclose(by_status.q[0], flipped, atol=1e-3)  # Status and Turn name the flipped wrist
    assert np.allclose(kept.q[0], start, atol=1e-3)  # the user's controller stays where it is


def test_rapid_confl_off_lets_the_robot_choose(tmp_path):
    from postproc.programs import dialects

    target = "[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    mod = tmp_path / "p.mod"
    mod.write_text("MODULE P\n  PROC main()\n"
                   f"    MoveL {target}, v100, z1, tool0;\n    ConfL\\Off;\n    MoveL {target}, v100, z1, tool0;\n"
                   f"    MoveJ {target}, v100, z1, tool0;\n    ConfJ \\Off;\n    MoveJ {target}, v100, z1, tool0;\n"
                   f"    ConfL\\On;\n    MoveL {target}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    tp = parse_program(mod)
    assert dialects.of(tp).controller.conf_applies(tp).tolist() == [True, False, True, False, True]


def test_a_straight_move_through_the_wrist_singularity_is_refused(robot, truth_and_model, tmp_path):
    """Both targets are reachable on the carried posture (A5 = +8 and -8 deg on the axis-PTP's
    branch is A5 = +8 then a flipped wrist); the LIN between them passes A5 = 0: refused."""
    truth, model = truth_and_model
    q_a = np.array([0.0, -60.0, 40.0, 30.0, 8.0, 0.0])
    q_b = np.array([0.0, -60.0, 40.0, 30.0, -8.0, 0.0])
    from postproc.robot.frames import matrix_to_abc

    lines = ["DEF p( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", f"$TOOL = {{X 0, Y 0, Z {TOOL[2]:g}, A 0, B 0, C 0}}",
             "PTP {" + ", ".join(f"A{i + 1} {v:.4f}" for i, v in enumerate(q_a)) + "}"]
    for pose in kin.fk(robot, np.vstack([q_a, q_b]), tool=TOOL):
        a, b, c = matrix_to_abc(pose[None, :3, :3])[0]
        lines.append(f"LIN {{X {pose[0, 3]:.4f}, Y {pose[1, 3]:.4f}, Z {pose[2, 3]:.4f}, A {a:.5f}, B {b:.5f}, C {c:.5f}}}")
    (tmp_path / "p.src").write_text("\n".join(lines + ["END"]) + "\n")
    tp = parse_program(tmp_path / "p.src")
    _, report = compensate(tp, model)
    reasons = dict(report.failures())
    assert 6 in reasons and "singularity" in reasons[6], reasons
