"""GPR on large sets: local exact-GP experts (auto above a threshold), their accuracy against
the exact GP, continuity at region borders, predictive variance, saving, and the memory
estimate that refuses a fit before it starts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import approx_fprime
from sklearn.gaussian_process import GaussianProcessRegressor

from postproc.model.learn import GPRPredictor
from postproc.model.learn.gp_lml import neg_log_marginal_likelihood
from postproc.model.learn.memory import MemoryBudgetError, gp_fit_bytes
from postproc.model.learn.residual import estimator_from_state, estimator_state


def _field(n, seed=0):
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(-1000, 1000, n), rng.uniform(-1000, 1000, n), rng.uniform(300, 1300, n), rng.uniform(-30, 30, (n, 3))])
    f = np.column_stack([np.sin(X[:, 0] / 300), np.cos(X[:, 1] / 250), np.sin((X[:, 0] + X[:, 2]) / 400)]) * 0.2
    return X, f + rng.normal(0, 0.01, f.shape), f


def test_lean_marginal_likelihood_matches_scikit_learn():
    X, y, _ = _field(120)
    Xs = (X - X.mean(0)) / X.std(0)
    gpr = GPRPredictor(anisotropic=True)
    kernel = gpr._kernel(6)
    theta = kernel.theta + np.random.default_rng(1).normal(0, 0.3, kernel.theta.shape)
    ref = GaussianProcessRegressor(kernel=kernel, normalize_y=True, optimizer=None).fit(Xs, y)
    lml, grad = ref.log_marginal_likelihood(theta, eval_gradient=True)
    yn = (y - y.mean(0)) / y.std(0)
    nll, ngrad = neg_log_marginal_likelihood(theta, Xs, yn)
    assert nll == pytest.approx(-lml, rel=1e-10)
    np.testing.assert_allclose(-ngrad, grad, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(ngrad, approx_fprime(theta, lambda t: neg_log_marginal_likelihood(t, Xs, yn)[0], 1e-6), rtol=1e-3, atol=1e-3)


def test_auto_switches_at_the_threshold():
    gpr = GPRPredictor(exact_max=300)
    assert gpr.resolved_method(300) == "exact" and gpr.resolved_method(301) == "local"
    assert GPRPredictor(method="local").resolved_method(10) == "local"


def test_local_experts_match_exact_accuracy_and_are_continuous():
    X, y, f = _field(900)
    Xt, _, ft = _field(300, seed=5)
    exact = GPRPredictor(anisotropic=True, n_restarts=0, method="exact").fit(X, y)
    local = GPRPredictor(anisotropic=True, n_restarts=0, method="local", leaf_size=250, global_size=300).fit(X, y)
    assert len(local.experts_) >= 4
    rms = lambda pred: float(np.sqrt(np.mean(np.sum((pred - ft) ** 2, axis=1))))  # noqa: E731
    assert rms(local.predict(Xt)) <= 1.25 * rms(exact.predict(Xt))
    # Continuity: a straight line across the workspace, 1 mm steps: no jump at the borders.
    line = np.column_stack([np.linspace(-900, 900, 1801), np.full(1801, 50.0), np.full(1801, 800.0), np.zeros((1801, 3))])
    steps = np.abs(np.diff(local.predict(line), axis=0)).max()
    assert steps < 5e-3
    mean, std = local.predict(Xt, return_std=True)
    assert std.shape == mean.shape and np.all(std > 0)
    far = Xt.copy()
    far[:, 2] += 5000.0
    assert local.predict(far, return_std=True)[1].mean() > std.mean()


def test_local_gp_survives_saving():
    X, y, _ = _field(400)
    local = GPRPredictor(n_restarts=0, method="local", leaf_size=150, global_size=200).fit(X, y)
    back = estimator_from_state(estimator_state(local))
    np.testing.assert_allclose(back.predict(X[:50]), local.predict(X[:50]), atol=1e-9)


def test_a_fit_that_would_not_fit_in_memory_is_refused_before_it_starts():
    X, y, _ = _field(3000)
    with pytest.raises(MemoryBudgetError, match=r"needs about .* GB.*--gp-method local"):
        GPRPredictor(anisotropic=True, method="exact", memory_limit_gb=0.5).fit(X, y)
    assert gp_fit_bytes(11911, 6, True) > 24 * 1024**3  # what the kernel killed at 24 GB (issue 17)


def test_pso_bp_on_a_large_set_uses_mini_batches_and_stops_early():
    from postproc.model.learn import PSOBPPredictor

    X, y, f = _field(3000)
    seen = []
    net = PSOBPPredictor(n_particles=8, pso_iters=4, epochs=200, patience=3, large_n=1000).fit(X, y, progress=lambda d, t, m: seen.append(d))
    assert net.epochs_run_ < 200 and seen == list(range(1, net.epochs_run_ + 1))
    assert np.mean((net.predict(X) - f) ** 2) < np.mean((f - f.mean(0)) ** 2)  # learned something


def test_interrupted_fit_says_so_and_writes_no_model(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    import postproc.model.identify
    from postproc.cli import app

    runner = CliRunner()
    meas = tmp_path / "m.csv"
    assert runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--n", "60", "-o", str(meas)]).exit_code == 0

    def interrupted(*args, progress=None, **kwargs):
        progress(1, 10, "expert 1 of 9")
        raise KeyboardInterrupt

    monkeypatch.setattr(postproc.model.identify, "fit_predictor", interrupted)
    out = tmp_path / "model.json"
    result = runner.invoke(app, ["fit", str(meas), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "none", "--cv", "0", "--predictor", "gpr", "-o", str(out)])
    assert result.exit_code == 130 and "interrupted: no model written" in result.stderr
    assert not out.exists() and list(tmp_path.iterdir()) == [meas]


def test_the_shared_fit_sums_its_blocks_likelihoods_and_keeps_the_better_start():
    from postproc.model.learn.gp_lml import optimize_shared_theta

    X, y, _ = _field(300)
    Xs = (X - X.mean(0)) / X.std(0)
    kernel = GPRPredictor(anisotropic=True)._kernel(6)
    blocks = [(Xs[:150], y[:150]), (Xs[150:], y[150:])]
    bad_start = kernel.theta.copy()
    bad_start[1:-1] = kernel.bounds[1:-1, 0]  # every length scale at its floor: the all-noise optimum's basin
    theta, value = optimize_shared_theta(blocks, [bad_start, kernel.theta], kernel.bounds, workers=2)
    normalised = [(Xb, (Yb - Yb.mean(0)) / Yb.std(0)) for Xb, Yb in blocks]
    assert value == pytest.approx(sum(neg_log_marginal_likelihood(theta, Xb, Yn)[0] for Xb, Yn in normalised), rel=1e-9)
    alone, alone_value = optimize_shared_theta(blocks, [bad_start], kernel.bounds)
    assert value <= alone_value + 1e-6
    assert not np.allclose(alone, theta)  # the floor start alone stays in its basin; the default start is kept
    assert np.all(theta[1:-1] > kernel.bounds[1:-1, 0] + 1.0)


def test_local_experts_start_from_the_kernel_their_data_share_not_from_a_sparse_sample():
    # A field that varies on a scale a sparse global sample cannot resolve but each expert's
    # dense data can: with the experts' kernels held at the start (expert_iter None), the
    # shared start predicts far better than the 40-pose sample's fit.
    rng = np.random.default_rng(3)
    X = rng.uniform(0, 1000, (2400, 3))
    f = np.column_stack([np.sin(X[:, 0] / 25) * np.cos(X[:, 1] / 30), np.sin(X[:, 2] / 20), np.cos((X[:, 0] - X[:, 2]) / 35)]) * 0.1
    y = f + rng.normal(0, 0.005, f.shape)
    train, test = np.arange(2000), np.arange(2000, 2400)
    options = dict(anisotropic=True, n_restarts=0, method="local", leaf_size=300, global_size=40, expert_iter=None)
    shared = GPRPredictor(**options).fit(X[train], y[train])
    sample = GPRPredictor(**options, shared_experts=0).fit(X[train], y[train])
    assert len(shared.shared_experts_) == 4 and len(sample.shared_experts_) == 0 and shared.global_poses_ == 40
    err_shared = np.abs(shared.predict(X[test]) - f[test]).mean()
    err_sample = np.abs(sample.predict(X[test]) - f[test]).mean()
    assert err_shared < 0.6 * err_sample, (err_shared, err_sample)
