"""--noise-model settle: each pose's place after the last large move, the variance of each
place from the training residual, and its use as weights in the physics fit, as noise levels
in the gpr predictor (saved and restored) and as sample weights for a plugin predictor."""

from __future__ import annotations

from dataclasses import replace
from typing import ClassVar

import numpy as np
import pytest
from scipy.optimize import approx_fprime
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.errors import IdentificationError, InputError
from postproc.model import validate as protocols
from postproc.model.effects import parse_effects
from postproc.model.identify import fit, fit_predictor, residuals
from postproc.model.learn import GPRPredictor
from postproc.model.learn.gp_lml import neg_log_marginal_likelihood, with_group_noise
from postproc.model.learn.state import base_estimator_from_state, estimator_state
from postproc.model.measurements import write_measurements
from postproc.model.noise_model import NoiseRatios, checked, settle_place
from postproc.model.path_history import previous_targets
from postproc.model.predictor_plugins import PREDICTORS, PluginPredictor
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate

TOOL = np.array([0.0, 0.0, 109.0])
EFFECTS = "geometric,base_frame,tool_offset"
VISITS, PER_VISIT = 60, 6
SETTLED_MM, FIRST_MM = 0.01, 0.5  # noise of a settled pose, of the first pose after a move
runner = CliRunner()


def _visits(robot, rng, visits=VISITS, per_visit=PER_VISIT):
    """``visits`` grid points, each measured ``per_visit`` times with the joints moved by
    hundredths of a degree (the TCP moves < 1 mm within a visit, metres between visits)."""
    box = JointBox(tuple((lo / 2, hi / 2) for lo, hi in zip(robot.lower_deg, robot.upper_deg)))
    centres = sample_poses(robot, TOOL, visits, box, rng)
    return np.repeat(centres, per_visit, axis=0) + rng.uniform(-0.02, 0.02, size=(visits * per_visit, 6))


@pytest.fixture(scope="module")
def world():
    robot = postproc.load_robot("ur10")
    rng = np.random.default_rng(5)
    truth = random_truth(robot, TOOL, parse_effects(EFFECTS), rng)
    q = _visits(robot, rng)
    meas = simulate(truth, q, rng, noise_mm=SETTLED_MM)
    first = np.arange(len(q)) % PER_VISIT == 0
    kick = rng.normal(scale=FIRST_MM / np.sqrt(3), size=(len(q), 3)) * first[:, None]  # unsettled: large, in no fixed direction
    return robot, truth, replace(meas, measured_mm=meas.measured_mm + kick), first


def test_place_counts_targets_since_the_last_large_move(world):
    robot, _, meas, _ = world
    place = settle_place(robot, TOOL, meas.q_deg, previous_targets(meas.q_deg))
    expected = np.minimum(np.arange(len(meas)) % PER_VISIT, 3)
    expected[:PER_VISIT] = 3  # the first visit has no large move into it
    np.testing.assert_array_equal(place, expected)
    # A threshold above every move: all settled.
    assert (settle_place(robot, TOOL, meas.q_deg, previous_targets(meas.q_deg), threshold_mm=1e6) == 3).all()


def test_ratios_estimate_each_places_variance():
    rng = np.random.default_rng(0)
    place = np.repeat(np.arange(4), 400)
    scale = np.array([3.0, 2.0, 1.0, 1.0])[place]
    ratios = NoiseRatios.estimate(place, rng.normal(size=(len(place), 3)) * scale[:, None], 3)
    np.testing.assert_allclose(ratios.ratios, [9.0, 4.0, 1.0, 1.0], rtol=0.15)
    np.testing.assert_allclose(ratios.weights(np.array([0, 3])), [1 / ratios.ratios[0], 1.0])
    # Too few poses of a place: it keeps the settled variance (weight 1), never a guess.
    few = NoiseRatios.estimate(np.r_[np.zeros(5, int), np.full(100, 3)], np.ones((105, 3)) * 10, 3)
    assert few.ratios == (1.0, 1.0, 1.0, 1.0)


def test_unknown_noise_model_is_refused():
    with pytest.raises(InputError, match="--noise-model"):
        checked("robust")


def test_weighted_physics_fit_is_not_pulled_off_by_the_unsettled_poses(world):
    robot, truth, meas, _ = world
    plain = fit(robot, TOOL, parse_effects(EFFECTS), meas, cv_folds=0)
    settle = fit(robot, TOOL, parse_effects(EFFECTS), meas, cv_folds=0, noise="settle")
    clean = simulate(truth, meas.q_deg, np.random.default_rng(1), noise_mm=0.0)  # where the arm really is
    err_plain = np.linalg.norm(residuals(plain.model, clean), axis=1).mean()
    err_settle = np.linalg.norm(residuals(settle.model, clean), axis=1).mean()
    assert err_settle < 0.5 * err_plain
    assert any(n.startswith("noise model settle") for n in settle.notes)


def test_group_noise_gradient_is_the_likelihoods():
    rng = np.random.default_rng(0)
    X, Y, groups = rng.normal(size=(30, 2)), rng.normal(size=(30, 3)), rng.integers(0, 3, 30)
    theta, _ = with_group_noise(np.log([1.0, 0.7, 1.3, 0.1]), np.zeros((4, 2)), 3)
    theta[-2:] = np.log([5.0, 3.0])  # groups 0 and 1: 5 and 3 times the noise of group 2
    numeric = approx_fprime(theta, lambda t: neg_log_marginal_likelihood(t, X, Y, groups, 4)[0], 1e-6)
    np.testing.assert_allclose(neg_log_marginal_likelihood(theta, X, Y, groups, 4)[1], numeric, atol=1e-4)
    # All groups at the kernel's level (ratio 1): the plain likelihood.
    same = np.r_[theta[:4], 0.0, 0.0]
    assert neg_log_marginal_likelihood(same, X, Y, groups, 4)[0] == pytest.approx(neg_log_marginal_likelihood(theta[:4], X, Y)[0])


def _noisy_curve(rng, n=300):
    X = rng.uniform(-3, 3, size=(n, 1))
    groups = (np.arange(n) % 4 != 0).astype(int)  # group 0: every 4th pose, the noisy one
    noise = np.where(groups == 0, 1.0, 0.02)
    y = np.sin(X) * np.array([1.0, 0.5, -0.3]) + rng.normal(size=(n, 3)) * noise[:, None]
    return X, y, groups


@pytest.mark.parametrize("method", ["exact", "local"])
def test_gp_noise_groups_learn_the_noisy_group_and_are_restored(method):
    rng = np.random.default_rng(2)
    X, y, groups = _noisy_curve(rng)
    options = {"method": method, "leaf_size": 120, "n_restarts": 0, "random_state": 0}
    grouped = GPRPredictor(**options).fit(X, y, noise_groups=groups)
    plain = GPRPredictor(**options).fit(X, y)
    grid = np.linspace(-2.5, 2.5, 50)[:, None]
    truth = np.sin(grid) * np.array([1.0, 0.5, -0.3])
    err_grouped = np.abs(grouped.predict(grid) - truth).mean()
    assert err_grouped < 0.6 * np.abs(plain.predict(grid) - truth).mean()
    restored = base_estimator_from_state(estimator_state(grouped))
    np.testing.assert_allclose(restored.predict(grid), grouped.predict(grid), atol=1e-8)


class _WeightedMean(PluginPredictor):
    """A plugin predictor that takes sample weights: the weighted mean of the residual."""

    name, features = "test-weighted-mean", "position"
    seen: ClassVar[dict] = {}

    def fit(self, X, y, sample_weight=None):
        _WeightedMean.seen["w"] = sample_weight
        self.mean_ = np.average(y, axis=0, weights=sample_weight)
        return self

    def predict(self, X):
        return np.tile(self.mean_, (len(X), 1))


class _Unweighted(_WeightedMean):
    name = "test-unweighted"

    def fit(self, X, y):
        return super().fit(X, y)


def test_plugin_predictor_gets_weights_or_is_refused(world, monkeypatch):
    robot, _, meas, first = world
    monkeypatch.setitem(PREDICTORS, _WeightedMean.name, _WeightedMean)
    monkeypatch.setitem(PREDICTORS, _Unweighted.name, _Unweighted)
    model = fit(robot, TOOL, parse_effects(EFFECTS), meas, cv_folds=0).model
    fit_predictor(model, meas, _WeightedMean.name, noise="settle")
    weights = _WeightedMean.seen["w"]
    assert weights[first][1:].max() < 0.1 * weights[~first].min()  # the first poses of each visit weigh far less
    fit_predictor(model, meas, _Unweighted.name)  # without the noise model: the old contract, fit(X, y)
    with pytest.raises(IdentificationError, match="takes no per-pose noise"):
        fit_predictor(model, meas, _Unweighted.name, noise="settle")


def test_validate_takes_the_noise_model_and_the_gp_sizes(world, tmp_path):
    _, _, meas, _ = world
    path = tmp_path / "m.csv"
    write_measurements(path, meas)
    base = ["validate", str(path), "--protocol", "random", "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS]
    bad = runner.invoke(app, [*base, "--noise-model", "robust"])
    assert bad.exit_code == 2 and "--noise-model" in bad.output
    for option, value in (("--gp-leaf-size", "200"), ("--gp-global-size", "1500")):
        unused = runner.invoke(app, [*base, option, value])
        assert unused.exit_code == 2 and option in unused.output
    small = runner.invoke(app, [*base, "--predictor", "gpr", "--gp-global-size", "5"])
    assert small.exit_code == 2 and "--gp-global-size" in small.output
    ok = runner.invoke(app, [*base, "--noise-model", "settle", "--json"])
    assert ok.exit_code == 0, ok.output


def test_gp_noise_ratios_leave_the_kernels_length_scales_as_without_groups():
    # Fitted together, ratios and length scales fall into a degenerate optimum on Series A
    # (gp_lml): the ratios are fitted with the kernel held, so its length scales stay.
    rng = np.random.default_rng(4)
    X, y, groups = _noisy_curve(rng, 200)
    options = {"method": "exact", "n_restarts": 0, "random_state": 0}
    grouped = GPRPredictor(**options).fit(X, y, noise_groups=groups)
    plain = GPRPredictor(**options).fit(X, y)
    ratio = np.exp(grouped.gpr_.theta_full_[-1])
    assert ratio > 10  # group 0 is 50 times noisier in standard deviation
    np.testing.assert_allclose(grouped.gpr_.theta_full_[:2], plain.gpr_.kernel_.theta[:2], atol=0.2)


def test_validate_hands_the_options_to_every_fold(world, tmp_path, monkeypatch):
    _, _, meas, _ = world
    path = tmp_path / "m.csv"
    write_measurements(path, meas)
    seen = {}

    def capture(spec, data, fraction, seed, say):
        seen["spec"] = spec
        raise InputError("captured")

    monkeypatch.setattr(protocols, "run_random", capture)
    runner.invoke(app, ["validate", str(path), "--protocol", "random", "--robot", "ur10", "--tool", "0,0,109", "--effects", EFFECTS,
                        "--predictor", "gpr", "--gp-leaf-size", "300", "--gp-global-size", "1500", "--noise-model", "settle"])
    spec = seen["spec"]
    assert spec.noise == "settle" and spec.gp_options["leaf_size"] == 300 and spec.gp_options["global_size"] == 1500
