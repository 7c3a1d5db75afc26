"""The gpr predictor's history features (--gp-features tcp+joints+travel): how the arm got to a pose.

Each place is measured twice: first right after a long move from the place before, then
after a move of a fraction of a degree. The first measurement misses by STEP_MM more (as
the first poses after a move to a new grid point do on the UR10's Series A); both have
nearly the same pose and joints, so only the travel into them tells them apart.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from helpers import TOOL
from typer.testing import CliRunner

from postproc.cli import app
from postproc.compensation.core import _Plant, _Problem
from postproc.jobs.compensate import compensate, with_robot
from postproc.jobs.stream import StreamFallback, stream_rules_for
from postproc.model.effects import parse_effects
from postproc.model.identify import fit, fit_predictor, residuals
from postproc.model.learn.features import GP_KINDS, HISTORY_KINDS, features, travel_mm
from postproc.model.measurements import write_measurements
from postproc.model.model_io import load_model, save_model
from postproc.model.path_history import previous_targets
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.model.validate import random_mask, with_order_columns
from postproc.programs import dialects, parse_program
from postproc.programs.ir import Kind
from postproc.robot import kinematics as kin
from postproc.robot.frames import matrix_to_abc

runner = CliRunner()
STEP_MM = 0.3  # the extra error of a pose measured right after a long move
NUDGE_DEG = 0.3  # the second measurement of a place: this much further on joint 6


@pytest.fixture(scope="module")
def twice(robot):
    """Each of 70 places measured after a long move (+STEP_MM in x), then after a nudge of joint 6."""
    rng = np.random.default_rng(5)
    truth = random_truth(robot, TOOL, parse_effects("none"), rng)
    places = sample_poses(robot, TOOL, 70, Cylinder(), rng)
    nudged = places + np.array([0, 0, 0, 0, 0, NUDGE_DEG])
    q = np.stack([places, nudged], axis=1).reshape(-1, 6)  # place, its nudge, next place, ...
    meas = simulate(truth, q, rng, noise_mm=0.01)
    step = np.zeros_like(meas.measured_mm)
    step[0::2, 0] = STEP_MM
    return replace(meas, measured_mm=meas.measured_mm + step)


def rms(model, meas) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals(model, meas) ** 2, axis=1))))


def test_previous_targets_walk_back_along_the_path():
    q = np.arange(4 * 6, dtype=float).reshape(4, 6)
    back = previous_targets(q)
    assert back.shape == (4, 3, 6)
    np.testing.assert_array_equal(back[3], q[[2, 1, 0]])
    np.testing.assert_array_equal(back[1], q[[0, 0, 0]])  # before the first target: the first target, no move
    np.testing.assert_array_equal(back[0], q[[0, 0, 0]])


def test_travel_is_the_tcp_distance_of_each_move(robot):
    q = sample_poses(robot, TOOL, 5, Cylinder(), np.random.default_rng(1))
    poses = kin.fk(robot, q, tool=TOOL)
    travel = travel_mm(robot, TOOL, poses, previous_targets(q))
    steps = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    np.testing.assert_allclose(travel[4], steps[[3, 2, 1]], rtol=1e-9)
    np.testing.assert_allclose(travel[0], 0.0, atol=1e-9)
    assert "tcp+joints+travel" in GP_KINDS and "tcp+joints+travel" in HISTORY_KINDS
    width = features(robot, TOOL, q, "tcp+joints+travel", previous_q_deg=previous_targets(q)).shape
    assert width == (5, 12)
    with pytest.raises(ValueError, match="targets before each pose"):
        features(robot, TOOL, q, "tcp+joints+travel")


def test_the_travel_tells_the_first_pose_after_a_long_move_apart(robot, twice):
    nominal = fit(robot, TOOL, parse_effects("none"), twice, cv_folds=0).model
    without = fit_predictor(nominal, twice, "gpr", gp_options={"features": "tcp+joints"})
    with_travel = fit_predictor(nominal, twice, "gpr", gp_options={"features": "tcp+joints+travel"})
    assert rms(without, twice) > 0.4 * STEP_MM  # the same place, two answers: it can only average
    assert rms(with_travel, twice) < 0.2 * STEP_MM
    # The rows' order is the path: the same rows in another order have another history.
    shuffled = twice.subset(np.random.default_rng(0).permutation(len(twice)))
    assert rms(with_travel, shuffled) > 0.4 * STEP_MM


def test_a_protocol_split_keeps_each_pose_history_in_the_whole_set(robot, twice):
    whole = with_order_columns(parse_effects("none"), twice)
    test = random_mask(len(whole), 0.3, 0)
    np.testing.assert_array_equal(whole.subset(test).previous_q_deg, previous_targets(twice.q_deg)[test])
    np.testing.assert_array_equal(whole.subset(~test).previous_q_deg, previous_targets(twice.q_deg)[~test])


def test_compensation_reads_the_history_from_the_program_order(robot, twice):
    nominal = fit(robot, TOOL, parse_effects("none"), twice, cv_folds=0).model
    hybrid = fit_predictor(nominal, twice, "gpr", gp_options={"features": "tcp+joints+travel"})
    plant = _Plant(hybrid, _tool_frame()[None], np.zeros(len(twice), dtype=int), None, None)
    rows = np.arange(len(twice))
    program_order = plant.actual(twice.q_deg, rows, twice.q_deg)
    np.testing.assert_allclose(program_order, hybrid.predict(twice), atol=1e-9)
    # The first pose after each long move is predicted STEP_MM further in x than its nudge.
    assert np.mean(program_order[0::2, 0] - program_order[1::2, 0]) > 0.7 * STEP_MM
    # Some targets alone (compensation iterates on those not yet converged) keep their
    # history in the program: the nudges, read in their own order, would each follow a long move.
    nudges = plant.actual(twice.q_deg[1::2], rows[1::2], twice.q_deg)
    np.testing.assert_allclose(nudges, program_order[1::2], atol=1e-9)
    # A program that comes to the place by the nudge (no long move into it; a history the
    # data never showed, so the learner is only part of the way back) has a smaller step.
    short_move = twice.q_deg[[3, 2]]
    by_nudge = plant.actual(short_move, np.arange(2), short_move)
    assert program_order[2, 0] - by_nudge[1, 0] > 0.3 * STEP_MM


def _tool_frame() -> np.ndarray:
    frame = np.eye(4)
    frame[:3, 3] = TOOL
    return frame


def test_the_features_survive_the_model_file_and_refuse_streaming(robot, twice, tmp_path):
    nominal = fit(robot, TOOL, parse_effects("none"), twice, cv_folds=0).model
    hybrid = fit_predictor(nominal, twice, "gpr", gp_options={"features": "tcp+joints+travel"})
    save_model(tmp_path / "m.json", hybrid)
    back, doc = load_model(tmp_path / "m.json")
    assert doc["predictor"]["features"] == "tcp+joints+travel"
    np.testing.assert_allclose(back.predict(twice), hybrid.predict(twice), atol=1e-9)
    program = tmp_path / "p.src"
    program.write_text("DEF p( )\r\nLIN {X 900, Y 0, Z 500, A 0, B 180, C 0}\r\nEND\r\n")
    with pytest.raises(StreamFallback, match="gpr predictor \\(--gp-features tcp\\+joints\\+travel\\) depends on the path"):
        stream_rules_for(program, None, back)



def measured_twice(robot, places: np.ndarray, seed: int):
    """Each place measured after a long move (+STEP_MM in x), then after a nudge of joint 6."""
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, parse_effects("none"), rng)
    q = np.stack([places, places + np.array([0, 0, 0, 0, 0, NUDGE_DEG])], axis=1).reshape(-1, 6)
    meas = simulate(truth, q, rng, noise_mm=0.01)
    step = np.zeros_like(meas.measured_mm)
    step[0::2, 0] = STEP_MM
    return replace(meas, measured_mm=meas.measured_mm + step)


def test_a_compensated_program_moves_the_first_target_after_a_long_move_by_the_step(robot, tmp_path):
    # Places around one posture, so that the controller keeps it from target to target.
    home = np.array([0.0, -5.0, -5.0, 10.0, -90.0, 40.0])
    places = home + np.random.default_rng(8).uniform(-8.0, 8.0, (70, 6))
    data = measured_twice(robot, places, 9)
    nominal = fit(robot, TOOL, parse_effects("none"), data, cv_folds=0).model
    hybrid = fit_predictor(nominal, data, "gpr", gp_options={"features": "tcp+joints+travel"})
    q = data.q_deg[:12]
    poses = kin.fk(robot, q, tool=TOOL)
    abc = matrix_to_abc(poses[:, :3, :3])
    lines = ["DEF part( )", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}",
             "PTP {" + ", ".join(f"A{j + 1} {v:.4f}" for j, v in enumerate(q[0])) + "}"]
    lines += [f"PTP {{X {p[0, 3]:.4f}, Y {p[1, 3]:.4f}, Z {p[2, 3]:.4f}, A {a:.5f}, B {b:.5f}, C {c:.5f}}}" for p, (a, b, c) in zip(poses, abc)]
    program = tmp_path / "part.src"
    program.write_text("\r\n".join([*lines, "END", ""]))
    tp = parse_program(program)
    new, report = compensate(tp, hybrid)
    assert not report.failed.any(), report.failures()
    moved = (new.base_positions() - tp.base_positions())[-12:]
    # The model predicts the first pose after each long move STEP_MM further in x than its
    # nudge: its compensated target moves back by that much more.
    assert np.mean(moved[2::2, 0] - moved[3::2, 0]) < -0.7 * STEP_MM


def test_the_cli_fits_and_validates_with_the_travel(twice, tmp_path):
    write_measurements(tmp_path / "m.csv", twice)
    common = ["--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "none", "--predictor", "gpr", "--gp-features", "tcp+joints+travel"]
    fitted = runner.invoke(app, ["fit", str(tmp_path / "m.csv"), "-o", str(tmp_path / "o.json"), "--cv", "0", *common])
    assert fitted.exit_code == 0, fitted.output
    _, doc = load_model(tmp_path / "o.json")
    assert doc["predictor"]["features"] == "tcp+joints+travel"
    validated = runner.invoke(app, ["validate", str(tmp_path / "m.csv"), "--protocol", "random", "--json", *common])
    assert validated.exit_code == 0, validated.output
    # Each held-out pose keeps its history in the file: the step is learned, not averaged.
    assert json.loads(validated.stdout)["error"]["mean_mm"] < 0.5 * STEP_MM


def test_the_program_path_holds_the_joints_of_its_joint_targets(robot, twice, tmp_path):
    # What the targets after a joint target read as their history (and backlash as its approach).
    nominal = fit(robot, TOOL, parse_effects("none"), twice, cv_folds=0).model
    start = np.array([0.0, -5.0, -5.0, 10.0, -90.0, 40.0])
    pose = kin.fk(robot, start[None] + 3.0, tool=TOOL)[0]
    a, b, c = matrix_to_abc(pose[None, :3, :3])[0]
    program = tmp_path / "part.src"
    program.write_text("\r\n".join(["DEF part( )", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}",
                                     "PTP {" + ", ".join(f"A{j + 1} {v:.4f}" for j, v in enumerate(start)) + "}",
                                     f"LIN {{X {pose[0, 3]:.4f}, Y {pose[1, 3]:.4f}, Z {pose[2, 3]:.4f}, A {a:.5f}, B {b:.5f}, C {c:.5f}}}", "END", ""]))
    tp = with_robot(parse_program(program), nominal)
    problem = _Problem.of(tp, nominal, dialects.of(tp).controller, None, None)
    joint_row = int(np.nonzero(tp.kind == Kind.ABSJ)[0][0])
    np.testing.assert_allclose(problem.order_q[joint_row], start, atol=1e-9)
