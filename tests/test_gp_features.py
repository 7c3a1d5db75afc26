"""The gpr predictor's features (--gp-features): the arm's posture as well as its pose.

Two wrist configurations (q4 + 180, -q5, q6 + 180) put the flange, and so the probe, at
the same pose; an error that depends on which one the arm is in (a wrist's own
eccentricity, another IK branch) is then invisible to pose features and plain to joints.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from helpers import TOOL
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import IdentificationError
from postproc.model.effects import parse_effects
from postproc.model.identify import fit, fit_predictor, residuals
from postproc.model.learn.features import GP_KINDS, features
from postproc.model.measurements import write_measurements
from postproc.model.model_io import load_model, save_model
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

runner = CliRunner()
WRIST_STEP_MM = 0.3  # the error that differs between the two wrist configurations


def flipped(q: np.ndarray) -> np.ndarray:
    """The other wrist configuration reaching the same flange pose."""
    out = q.copy()
    out[:, 3] = np.where(q[:, 3] > 0, q[:, 3] - 180.0, q[:, 3] + 180.0)
    out[:, 4] = -q[:, 4]
    out[:, 5] = np.where(q[:, 5] > 0, q[:, 5] - 180.0, q[:, 5] + 180.0)
    return out


@pytest.fixture(scope="module")
def two_wrists(robot):
    """Poses measured in both wrist configurations; the error steps by WRIST_STEP_MM in x with the sign of q5."""
    rng = np.random.default_rng(3)
    truth = random_truth(robot, TOOL, parse_effects("none"), rng)
    q = sample_poses(robot, TOOL, 120, Cylinder(), rng)
    q = q[np.abs(q[:, 4]) > 10.0]  # away from the wrist singularity, where both wrists coincide
    both = np.vstack([q, flipped(q)])
    meas = simulate(truth, both, rng, noise_mm=0.01)
    step = np.zeros_like(meas.measured_mm)
    step[:, 0] = WRIST_STEP_MM * np.sign(both[:, 4])
    return replace(meas, measured_mm=meas.measured_mm + step)


def test_both_wrists_reach_the_same_pose(robot, two_wrists):
    q = two_wrists.q_deg
    half = len(q) // 2
    pose = features(robot, TOOL, q, "pose")
    np.testing.assert_allclose(pose[:half, :3], pose[half:, :3], atol=1e-6)
    assert np.abs(features(robot, TOOL, q, "tcp+joints")[:half, 3:] - q[half:]).max() > 10.0


@pytest.mark.parametrize("kind, width", [("pose", 6), ("tcp+joints", 9), ("joints", 6)])
def test_feature_widths(robot, kind, width):
    q = np.zeros((4, 6))
    assert kind in GP_KINDS
    assert features(robot, TOOL, q, kind).shape == (4, width)


def test_joints_tell_the_wrists_apart_where_the_pose_cannot(robot, two_wrists):
    nominal = fit(robot, TOOL, parse_effects("none"), two_wrists, cv_folds=0).model
    rms = {}
    for kind in ("pose", "tcp+joints"):
        hybrid = fit_predictor(nominal, two_wrists, "gpr", gp_options={"features": kind})
        rms[kind] = float(np.sqrt(np.mean(np.sum(residuals(hybrid, two_wrists) ** 2, axis=1))))
    assert rms["pose"] > 0.7 * WRIST_STEP_MM  # the same input, two answers: it can only average
    assert rms["tcp+joints"] < 0.2 * WRIST_STEP_MM


def test_the_features_survive_the_model_file(robot, two_wrists, tmp_path):
    nominal = fit(robot, TOOL, parse_effects("none"), two_wrists, cv_folds=0).model
    hybrid = fit_predictor(nominal, two_wrists, "gpr", gp_options={"features": "tcp+joints"})
    save_model(tmp_path / "m.json", hybrid)
    back, doc = load_model(tmp_path / "m.json")
    assert doc["predictor"]["features"] == "tcp+joints"
    np.testing.assert_allclose(back.predict(two_wrists), hybrid.predict(two_wrists), atol=1e-9)


def test_unknown_features_refused(robot, two_wrists):
    nominal = fit(robot, TOOL, parse_effects("none"), two_wrists, cv_folds=0).model
    with pytest.raises(IdentificationError, match="not one of pose, tcp\\+joints, joints"):
        fit_predictor(nominal, two_wrists, "gpr", gp_options={"features": "position"})


@pytest.mark.parametrize("args, message", [
    (["--gp-features", "elbow"], "--gp-features: 'elbow' is not one of pose, tcp+joints, joints"),
    (["--gp-features", "joints", "--predictor", "grid"], "--gp-features: not used"),
    (["--gp-features", "joints"], "--gp-features: not used"),
])
def test_cli_refuses_bad_or_unused_features(two_wrists, tmp_path, args, message):
    write_measurements(tmp_path / "m.csv", two_wrists)
    extra = ["--predictor", "gpr"] if "--predictor" not in args and "elbow" in args else []
    for command in (["fit", str(tmp_path / "m.csv"), "-o", str(tmp_path / "o.json"), "--cv", "0"],
                    ["validate", str(tmp_path / "m.csv"), "--protocol", "random"]):
        result = runner.invoke(app, [*command, "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "none", *args, *extra])
        assert result.exit_code == 2, result.output
        assert message in " ".join(result.output.split())
