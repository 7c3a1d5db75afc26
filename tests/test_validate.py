"""Evaluation protocols (postproc validate) on a small simulated UR10 with grid points and sessions."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.errors import InputError, MeasurementError
from postproc.model.effects import parse_effects
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.measurements import write_measurements
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate
from postproc.model.validate import FitSpec, run_points, run_random, run_series, run_sessions, session_ids, with_order_columns

runner = CliRunner()
EFFECTS = "geometric,base_frame,tool_offset,joint_compliance"
TOOL = np.array([0.0, 0.0, 109.0])
NOISE = 0.02
POINTS, ORIENTATIONS, SESSIONS = 40, 5, 4
SHIFTED_SESSION, SHIFT_MM = 2, np.array([0.5, 0.0, 0.3])


def _grid_set(truth, rng, shift_session: bool):
    """40 'grid points' (a joint vector each) reached in 5 wrist orientations; 4 sessions of 10 points."""
    robot = truth.robot
    centres = sample_poses(robot, TOOL, POINTS, JointBox(tuple((lo / 2, hi / 2) for lo, hi in zip(robot.lower_deg, robot.upper_deg))), rng)
    q = np.repeat(centres, ORIENTATIONS, axis=0)
    q[:, 3:] += rng.uniform(-20, 20, size=(len(q), 3))
    meas = simulate(truth, q, rng, noise_mm=NOISE)
    point = np.repeat(np.arange(POINTS), ORIENTATIONS).astype(float)
    session = point // (POINTS // SESSIONS)
    measured = meas.measured_mm + (np.outer(session == SHIFTED_SESSION, SHIFT_MM) if shift_session else 0.0)
    return replace(meas, measured_mm=measured, extra={"point": point, "session": session})


@pytest.fixture(scope="module")
def world():
    robot = postproc.load_robot("ur10")
    rng = np.random.default_rng(3)
    truth = random_truth(robot, TOOL, parse_effects(EFFECTS), rng)
    spec = FitSpec(robot, TOOL, parse_effects(EFFECTS))
    return spec, truth, _grid_set(truth, rng, False), _grid_set(truth, rng, True)


def test_points_hold_out_whole_groups_and_report_their_distance(world):
    spec, _, meas, _ = world
    points = run_points(spec, meas, every=5)
    random = run_random(spec, meas, fraction=0.2, seed=1)
    assert points.error.n == (POINTS // 5) * ORIENTATIONS  # every 5th point, all its orientations
    assert points.error.mean_mm < 4 * NOISE and random.error.mean_mm < 4 * NOISE  # the model is the truth's
    # A random pose keeps its siblings (same point, other wrist angles) in training; a held-out point does not.
    assert points.distance.median_rad > 1.5 * random.distance.median_rad
    stats = points.error
    assert stats.median_mm <= stats.p95_mm <= stats.max_mm and stats.rms_mm >= stats.mean_mm


def test_sessions_flag_the_one_that_moves_as_a_whole(world):
    spec, _, _, shifted = world
    result = run_sessions(spec, shifted)
    assert [s.session for s in result.sessions] == list(range(SESSIONS))
    moved = [s for s in result.sessions if s.moves_as_whole]
    assert [s.session for s in moved] == [SHIFTED_SESSION]
    assert moved[0].offset_mm == pytest.approx(np.linalg.norm(SHIFT_MM), rel=0.3)
    assert moved[0].mean_after_mm < 0.5 * moved[0].mean_mm


def test_sessions_from_time_gaps_when_no_session_column(world):
    _, _, meas, _ = world
    times = np.arange(len(meas)) * 20.0 + (np.arange(len(meas)) >= 100) * 7200.0  # a 2-hour pause after row 100
    timed = replace(meas, time_s=times, extra={"point": meas.extra["point"]})
    assert np.array_equal(session_ids(timed), (np.arange(len(meas)) >= 100).astype(int))


def test_series_reregisters_on_one_half_and_scores_the_other(world):
    spec, truth, meas, _ = world
    moved_frame = replace(meas, measured_mm=meas.measured_mm @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]]).T + [1500.0, -200.0, 30.0])
    result = run_series(spec, meas, moved_frame)
    assert result.error.n == len(meas) and result.error.mean_mm < 4 * NOISE
    assert result.ceiling is not None and result.ceiling.mean_mm < 4 * NOISE
    assert result.distance.median_rad == pytest.approx(0.0, abs=1e-9)  # the same joints


def test_points_without_a_point_column_is_refused(world):
    spec, _, meas, _ = world
    with pytest.raises(MeasurementError, match="column 'point'"):
        run_points(spec, replace(meas, extra={}), every=5)
    with pytest.raises(InputError, match="at least 2"):
        run_points(spec, meas, every=1)


@pytest.fixture(scope="module")
def csv_files(world, tmp_path_factory):
    _, _, meas, shifted = world
    folder = tmp_path_factory.mktemp("validate")
    write_measurements(folder / "grid.csv", meas)
    write_measurements(folder / "bare.csv", replace(meas, extra={}, time_s=None))
    return folder


def _validate(*args):
    return runner.invoke(app, ["validate", *args, "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS])


def test_cli_prints_every_figure_and_json(csv_files):
    text = _validate(str(csv_files / "grid.csv"), "--protocol", "points")
    assert text.exit_code == 0, text.output
    for word in ("mean", "median", "p95", "max", "nearest training pose", "rad"):
        assert word in text.stdout
    result = _validate(str(csv_files / "grid.csv"), "--protocol", "sessions", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc["error"]) == {"n", "mean_mm", "median_mm", "p95_mm", "max_mm", "rms_mm"}
    assert set(doc["distance"]) == {"median_rad", "p95_rad", "max_rad"} and len(doc["sessions"]) == SESSIONS


@pytest.mark.parametrize("args, message", [
    (["--protocol", "bogus"], "is not one of"),
    (["--protocol", "series"], "needs --other"),
    (["--protocol", "random", "--every", "3"], "--every: not used"),
    (["--protocol", "points", "--every", "1"], "at least 2"),
])
def test_cli_bad_options_exit_2(csv_files, args, message):
    result = _validate(str(csv_files / "grid.csv"), *args)
    assert result.exit_code == 2 and message in result.output


def test_cli_missing_group_column_names_file_and_column(csv_files):
    result = _validate(str(csv_files / "bare.csv"), "--protocol", "points")
    assert result.exit_code == 2
    assert "bare.csv" in result.output and "'point'" in result.output
    sessions = _validate(str(csv_files / "bare.csv"), "--protocol", "sessions")
    assert sessions.exit_code == 2 and "'session'" in sessions.output


def test_import_ur10_writes_the_group_columns(shared, tmp_path):
    a, _ = read_series(shared / "data" / "ur10_ipa" / "Series_A")
    assert {"point", "pose", "session"} <= set(a.extra)
    assert len(np.unique(a.extra["pose"])) == len(a)  # every pose of A's grid is its own
    assert 500 < len(np.unique(a.extra["point"])) < 700 and a.extra["session"].max() == 12
    result = runner.invoke(app, ["import-ur10", str(shared / "data" / "ur10_ipa" / "Series_B"), "-o", str(tmp_path / "B.csv")])
    assert result.exit_code == 0, result.output
    header = (tmp_path / "B.csv").read_text().splitlines()[0].split(",")
    assert header[-5:] == ["point", "pose", "probe_rx", "probe_ry", "probe_rz"] and "session" not in header  # B's time stamps are lost


def test_a_group_id_that_is_not_whole_names_its_line(world, tmp_path):
    _, _, meas, _ = world
    point = meas.extra["point"].copy()
    point[7] = 2.5
    write_measurements(tmp_path / "half.csv", replace(meas, extra={"point": point}))
    result = _validate(str(tmp_path / "half.csv"), "--protocol", "points")
    assert result.exit_code == 2 and "line 9" in result.output and "'point'" in result.output


def test_approach_from_the_row_order_is_taken_before_the_split(world):
    meas = replace(world[2], approach=None)  # as the UR10 data: no s1..s6 columns
    effects = parse_effects(EFFECTS + ",backlash")
    whole = with_order_columns(effects, meas)
    assert whole.approach is not None and meas.approach is None
    # Row 10's direction is from row 9, which a split may hold out: the column keeps it.
    step = np.sign(meas.q_deg[10] - meas.q_deg[9])
    assert np.array_equal(whole.approach[10][step != 0], step[step != 0])
    assert with_order_columns(parse_effects(EFFECTS), meas).approach is None  # no effect asks for it
