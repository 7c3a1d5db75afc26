"""A model whose predictor reads the path (--gp-features tcp+joints+travel) records the TCP
travels it was measured with, and compensate refuses targets whose moves are unlike them
(a predictor asked about moves it never saw extrapolates), unless --allow-extrapolation.

The measured set: places around one posture, each measured after a long move (tens to
hundreds of mm) and again after a turn of joint 6 that leaves the TCP where it is (0 mm):
the UR10's Series A has the same two groups of moves (0-1.7 mm and 84-1301 mm)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import TOOL
from test_path_history import measured_twice

from postproc.errors import ModelFileError
from postproc.jobs.compensate import compensate
from postproc.model.coverage import TRAVEL_TOLERANCE_LOG1P, Coverage, outside_poses
from postproc.model.effects import parse_effects
from postproc.model.identify import fit, fit_predictor
from postproc.model.model_io import load_model, save_model
from postproc.model.path_history import path_travel_mm, previous_targets
from postproc.programs import parse_program
from postproc.robot import kinematics as kin
from postproc.robot.frames import matrix_to_abc

HOME = np.array([0.0, -5.0, -5.0, 10.0, -90.0, 40.0])


@pytest.fixture(scope="module")
def data(robot):
    places = HOME + np.random.default_rng(8).uniform(-8.0, 8.0, (70, 6))
    return measured_twice(robot, places, 9)


@pytest.fixture(scope="module")
def hybrid(robot, data):
    nominal = fit(robot, TOOL, parse_effects("none"), data, cv_folds=0).model
    return fit_predictor(nominal, data, "gpr", gp_options={"features": "tcp+joints+travel"})


def test_the_nearest_measured_travel_decides():
    region = Coverage(1, np.zeros(6), np.ones(6), (0.0, 1.0), (0.0, 1.0), None).with_travels(np.array([[0.1, 0.1], [100.0, 0.1]]))
    assert len(region.travel_log1p) == 2 and region.travel_log1p[1].size == 1  # per step back along the path, distinct values
    excess = region.travel_excess(np.array([[0.2, 0.0], [10.0, 0.0], [90.0, 0.0], [0.0, 100.0]]))
    assert excess[0] < 0.2 and excess[2] < 0.2  # near 0.1 mm, near 100 mm
    assert excess[1] > TRAVEL_TOLERANCE_LOG1P  # 10 mm: between the two groups
    assert excess[3] > TRAVEL_TOLERANCE_LOG1P  # the move before the last: only 0.1 mm were measured there
    assert region.travel_ranges_mm() == "0.1, 98.5 mm"  # rounded to 0.05 in log(1 + mm)
    assert Coverage(1, np.zeros(6), np.ones(6), (0.0, 1.0), (0.0, 1.0), None).travel_excess(np.ones((2, 3))).tolist() == [0.0, 0.0]


def test_the_fitted_model_records_the_measured_travels(robot, data, hybrid, tmp_path):
    travels = path_travel_mm(robot, TOOL, data.q_deg, previous_targets(data.q_deg))
    assert travels[1::2, 0].max() < 0.01 and travels[2::2, 0].min() > 15.0  # the turn of joint 6; the long moves
    assert hybrid.coverage.travel_log1p is not None and len(hybrid.coverage.travel_log1p) == 3
    assert not outside_poses(hybrid, data.q_deg).mask.any()  # its own poses, in their measured order
    no_path = fit_predictor(replace_residual(hybrid), data, "gpr", gp_options={"features": "tcp+joints"})
    assert no_path.coverage.travel_log1p is None
    save_model(tmp_path / "m.json", hybrid)
    back, doc = load_model(tmp_path / "m.json")
    for kept, saved in zip(back.coverage.travel_log1p, hybrid.coverage.travel_log1p):
        np.testing.assert_allclose(kept, saved, atol=1e-4)
    doc["coverage"]["travel_log1p"] = [[1.0, 0.5]]
    with pytest.raises(ModelFileError, match="coverage.travel_log1p"):
        Coverage.from_document(doc["coverage"], "m.json")


def replace_residual(model):
    from dataclasses import replace

    return replace(model, residual=None, coverage=replace(model.coverage, travel_log1p=None))


def _program(robot, tmp_path, steps_mm) -> object:
    """KRL: a joint move to HOME, then LIN targets from HOME's TCP along x by ``steps_mm``."""
    pose = kin.fk(robot, HOME[None], tool=TOOL)[0]
    a, b, c = matrix_to_abc(pose[None, :3, :3])[0]
    xs = pose[0, 3] + np.cumsum([0.0, *steps_mm])
    lines = ["DEF part( )", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}",
             "PTP {" + ", ".join(f"A{j + 1} {v:.4f}" for j, v in enumerate(HOME)) + "}"]
    lines += [f"LIN {{X {x:.4f}, Y {pose[1, 3]:.4f}, Z {pose[2, 3]:.4f}, A {a:.5f}, B {b:.5f}, C {c:.5f}}}" for x in xs]
    (tmp_path / "part.src").write_text("\r\n".join([*lines, "END", ""]))
    return parse_program(tmp_path / "part.src")


def test_compensate_refuses_moves_unlike_the_measured_ones(robot, hybrid, tmp_path):
    tp = _program(robot, tmp_path, [5.0, 5.0])  # 5 mm moves: between the measured 0 mm and the long moves
    _, report = compensate(tp, hybrid)
    failed = dict(report.failures())
    assert report.failed.sum() == 2, report.failures()
    assert all("TCP travels along the path (" in why and "unlike the moves" in why for why in failed.values()), failed
    _, allowed = compensate(tp, hybrid, allow_extrapolation=True)
    assert not allowed.failed.any(), allowed.failures()
    # The same targets reached by moves like the measured ones are compensated.
    _, same = compensate(_program(robot, tmp_path, []), hybrid)
    assert not same.failed.any(), same.failures()
