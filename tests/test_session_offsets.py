"""Session offsets: each measuring session's frame shift, estimated from the physics residual,
applied to measurements of that session and never to a program."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.errors import MeasurementError, ModelFileError
from postproc.model.effects import parse_effects
from postproc.model.identify import residuals
from postproc.model.measurements import write_measurements
from postproc.model.model_io import load_model, model_from_document, save_model
from postproc.model.session_offsets import SHRINK_POSES, SessionOffsets, with_session_offsets
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate
from postproc.model.validate import FitSpec, fit_model, run_random

runner = CliRunner()
EFFECTS = "geometric,base_frame,tool_offset,joint_compliance"
TOOL = np.array([0.0, 0.0, 109.0])
NOISE = 0.02
SHIFTS = {0: [0.0, 0.0, 0.0], 1: [0.15, -0.1, 0.0], 2: [0.0, 0.2, -0.25], 3: [-0.2, 0.0, 0.1]}  # mm, each session's tracker frame


@pytest.fixture(scope="module")
def world():
    """Four sessions of 60 random poses, each measured in its own shifted frame."""
    robot = postproc.load_robot("ur10")
    rng = np.random.default_rng(11)
    truth = random_truth(robot, TOOL, parse_effects(EFFECTS), rng)
    box = JointBox(tuple((lo / 2, hi / 2) for lo, hi in zip(robot.lower_deg, robot.upper_deg)))
    q = sample_poses(robot, TOOL, 240, box, rng)
    meas = simulate(truth, q, rng, noise_mm=NOISE)
    session = np.repeat(np.arange(4), 60)
    shift = np.array([SHIFTS[s] for s in session])
    return robot, truth, replace(meas, measured_mm=meas.measured_mm + shift, extra={"session": session.astype(float)})


def test_the_offset_is_the_sessions_mean_residual_shrunk_by_its_size():
    sessions = np.array([5, 5, 5, 9])
    resid = np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0], [0, 0, 4.0]])
    offsets = SessionOffsets.estimate(sessions, resid)
    assert offsets.ids.tolist() == [5, 9] and offsets.counts.tolist() == [3, 1]
    np.testing.assert_allclose(offsets.offsets_mm, [[6.0 / (3 + SHRINK_POSES), 0, 0], [0, 0, 4.0 / (1 + SHRINK_POSES)]])
    at = offsets.at(np.array([9, 7, 5]))  # 7: a session the fit never saw gets none
    np.testing.assert_allclose(at, [offsets.offsets_mm[1], [0, 0, 0], offsets.offsets_mm[0]])
    assert offsets.unknown(np.array([9, 7, 5, 7])) == 2


def test_offsets_take_the_sessions_shift_out_of_held_out_measurements(world):
    robot, _, meas = world
    spec = FitSpec(robot, TOOL, parse_effects(EFFECTS))
    without = run_random(spec, meas, fraction=0.25, seed=2)
    with_offsets = run_random(replace(spec, session_offsets=True), meas, fraction=0.25, seed=2)
    assert without.error.mean_mm > 3 * NOISE  # the frames' shifts are left in the residual
    assert with_offsets.error.mean_mm < 0.6 * without.error.mean_mm
    model = fit_model(replace(spec, session_offsets=True), meas, lambda message: None)
    found = model.session_offsets.offsets_mm - model.session_offsets.offsets_mm.mean(axis=0)  # the fit's base frame takes their mean
    truth = np.array(list(SHIFTS.values()))
    np.testing.assert_allclose(found, (truth - truth.mean(axis=0)) * (60 / (60 + SHRINK_POSES)), atol=0.03)


def test_a_program_never_gets_an_offset_and_the_model_file_keeps_them(world, tmp_path):
    robot, _, meas = world
    spec = FitSpec(robot, TOOL, parse_effects(EFFECTS))
    plain = fit_model(spec, meas, lambda message: None)
    model = with_session_offsets(plain, meas)
    q = meas.q_deg[:20]
    # Compensation predicts from joints alone: no session, no offset.
    np.testing.assert_array_equal(model.predict_prepared(model.prepare(q_deg=q)), plain.predict_prepared(plain.prepare(q_deg=q)))
    # A measurement of a known session does get its offset.
    first = meas.subset(np.arange(20))
    np.testing.assert_allclose(model.predict(first) - plain.predict(first), model.session_offsets.at(np.zeros(20)))
    # ... and a measurement without the column is predicted as a program would be.
    bare = replace(first, extra={})
    np.testing.assert_array_equal(model.predict(bare), plain.predict(bare))
    path = tmp_path / "m.json"
    save_model(path, model)
    loaded, doc = load_model(path)
    assert [r["session"] for r in doc["session_offsets"]] == [0, 1, 2, 3]
    np.testing.assert_allclose(residuals(loaded, meas), residuals(model, meas), atol=1e-9)
    doc["session_offsets"][1]["offset_mm"] = [0.1, 0.2]
    with pytest.raises(ModelFileError, match="session_offsets"):
        model_from_document(doc, "m.json")


def test_a_predictor_is_refused_before_the_offsets(world):
    robot, _, meas = world
    model = fit_model(FitSpec(robot, TOOL, parse_effects(EFFECTS)), meas, lambda message: None)
    with pytest.raises(ValueError, match="before a predictor"):
        with_session_offsets(replace(model, residual=object()), meas)


def test_cli_fit_writes_the_offsets_and_refuses_a_file_without_sessions(world, tmp_path):
    _, _, meas = world
    good = tmp_path / "good.csv"
    write_measurements(good, meas)
    out = tmp_path / "model.json"
    args = ["fit", str(good), "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS, "--cv", "0", "--session-offsets", "-o", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "session offsets: 4 sessions, largest" in result.stdout
    assert len(json.loads(out.read_text())["session_offsets"]) == 4
    bare = tmp_path / "bare.csv"
    write_measurements(bare, replace(meas, extra={}))
    out.unlink()
    result = runner.invoke(app, [*args[:1], str(bare), *args[2:]])
    assert result.exit_code == 2 and "session" in result.stderr and "column missing" in result.stderr
    assert not out.exists()
    with pytest.raises(MeasurementError, match="session"):
        with_session_offsets(load_model_free(meas), replace(meas, extra={"session": np.r_[0.5, np.zeros(len(meas) - 1)]}))


def load_model_free(meas):
    """A nominal model of the UR10 (no fit needed to test the column check)."""
    from postproc.model.effects import EffectSum
    from postproc.model.errormodel import ErrorModel

    return ErrorModel.create(postproc.load_robot("ur10"), TOOL, EffectSum())


def test_cli_validate_takes_the_offsets(world, tmp_path):
    _, _, meas = world
    path = tmp_path / "m.csv"
    write_measurements(path, meas)
    args = ["validate", str(path), "--protocol", "random", "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS, "--json"]
    plain = json.loads(runner.invoke(app, args).stdout)["error"]["mean_mm"]
    result = runner.invoke(app, [*args, "--session-offsets"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["error"]["mean_mm"] < 0.6 * plain


def test_evaluate_applies_the_offsets_only_when_asked(world, tmp_path):
    _, _, meas = world
    path = tmp_path / "m.csv"
    write_measurements(path, meas)
    plain, offsets = tmp_path / "plain.json", tmp_path / "offsets.json"
    base = ["fit", str(path), "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS, "--cv", "0"]
    assert runner.invoke(app, [*base, "-o", str(plain)]).exit_code == 0
    assert runner.invoke(app, [*base, "--session-offsets", "-o", str(offsets)]).exit_code == 0
    mean = lambda result: json.loads(result.stdout)["mean_mm"]  # noqa: E731
    asked = runner.invoke(app, ["evaluate", str(offsets), str(path), "--json", "--session-offsets"])
    unasked = runner.invoke(app, ["evaluate", str(offsets), str(path), "--json"])
    assert asked.exit_code == 0 and unasked.exit_code == 0
    # Another file's session ids need not be the fit's set-ups: without the option they are set aside, and said so.
    assert "not applied" in unasked.stderr and "not applied" not in asked.stderr
    assert mean(unasked) == pytest.approx(mean(runner.invoke(app, ["evaluate", str(plain), str(path), "--json"])), abs=0.01)
    assert mean(asked) < 0.6 * mean(unasked)
    refused = runner.invoke(app, ["evaluate", str(plain), str(path), "--session-offsets"])
    assert refused.exit_code == 2 and "has no session offsets" in refused.stderr


def test_evaluate_asked_for_offsets_refuses_a_file_without_sessions_and_counts_unseen_ones(world, tmp_path):
    _, _, meas = world
    path, model = tmp_path / "m.csv", tmp_path / "offsets.json"
    write_measurements(path, meas)
    assert runner.invoke(app, ["fit", str(path), "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS, "--cv", "0",
                               "--session-offsets", "-o", str(model)]).exit_code == 0
    bare = tmp_path / "bare.csv"
    write_measurements(bare, replace(meas, extra={}))
    refused = runner.invoke(app, ["evaluate", str(model), str(bare), "--session-offsets"])
    assert refused.exit_code == 2 and "column missing" in refused.stderr and "session" in refused.stderr
    other = tmp_path / "other.csv"
    write_measurements(other, replace(meas, extra={"session": meas.extra["session"] + 2}))  # sessions 2-5: 4 and 5 unseen
    noted = runner.invoke(app, ["evaluate", str(model), str(other), "--json", "--session-offsets"])
    assert noted.exit_code == 0 and "120 of 240 poses are of sessions the model has no offset for" in noted.stderr
