"""Data-driven predictors: scikit-learn conformance and behaviour on simulated residuals."""

from __future__ import annotations

import importlib.metadata

import numpy as np
import pytest
from sklearn.base import clone

import postproc
from postproc.errors import InputError
from postproc.model.effects import parse_effects
from postproc.model.learn import GPRPredictor, GridPredictor, OutsideGridError, PSOBPPredictor, hidden_size_table
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

FAST_NN = {"n_particles": 12, "pso_iters": 8, "epochs": 120}


@pytest.fixture(scope="module")
def errors():
    """Pose features (nominal TCP, joints) and measured position errors of a simulated KR160."""
    robot = postproc.load_robot("kr160_r1570")
    rng = np.random.default_rng(4)
    effects = parse_effects("geometric,base_frame,tool_offset,joint_compliance")
    truth = random_truth(robot, [0, 0, 200], effects, rng)
    d = simulate(truth, sample_poses(robot, [0, 0, 200], 260, Cylinder(), rng), rng)
    return np.hstack([d.nominal_mm, d.q_deg]), d.measured_mm - d.nominal_mm


@pytest.mark.parametrize("make", [lambda: GPRPredictor(n_restarts=0), lambda: PSOBPPredictor(**FAST_NN)], ids=["gpr", "pso-bp"])
def test_estimator_conventions_and_determinism(make, errors):
    X, y = errors
    est = make()
    params = est.get_params()
    twin = clone(est)
    assert twin.get_params() == params and twin is not est
    assert twin.set_params(**params) is twin
    assert not any(k.endswith("_") for k in vars(est))  # nothing learned before fit
    assert est.fit(X[:200], y[:200]) is est
    a = est.predict(X[200:])
    b = make().fit(X[:200], y[:200]).predict(X[200:])
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)  # same data, same seed: same model
    before = np.sqrt(np.mean(np.sum(y[200:] ** 2, axis=1)))
    after = np.sqrt(np.mean(np.sum((y[200:] - a) ** 2, axis=1)))
    assert after < 0.5 * before


def test_gpr_exposes_predictive_uncertainty(errors):
    X, y = errors
    gpr = GPRPredictor(n_restarts=0).fit(X[:150], y[:150])
    mean, std = gpr.predict(X[150:], return_std=True)
    assert mean.shape == (len(X) - 150, 3) and np.all(std > 0)
    far = X[150:151] + np.array([[800.0, 800.0, 800.0] + [0.0] * 6])
    assert gpr.predict(far, return_std=True)[1].mean() > std.mean()  # less sure far from the data


def test_pso_stage_then_backpropagation_improve(errors):
    X, y = errors
    net = PSOBPPredictor(**FAST_NN).fit(X, y)
    ys = (y - y.mean(axis=0)) / y.std(axis=0)
    assert net.pso_mse_ < np.mean(ys**2)  # the swarm beats predicting the mean
    pred = (net.predict(X) - y.mean(axis=0)) / y.std(axis=0)
    assert np.mean((pred - ys) ** 2) < net.pso_mse_  # back-propagation refines the swarm's best


def test_hidden_size_table_has_seed000_criteria(errors):
    X, y = errors
    rows = hidden_size_table(X[:120], y[:120], sizes=(5, 9), folds=3, **FAST_NN)
    assert [r["hidden"] for r in rows] == [5, 9]
    for r in rows:
        assert set(r) == {"hidden", "mean_mm", "mse_mm2", "max_mm", "above_threshold", "mean_above_mm"}
        assert 0 <= r["above_threshold"] <= 1 and r["max_mm"] >= r["mean_mm"] > 0


def test_grid_is_trilinear_inside_and_refuses_outside():
    axes = [np.linspace(800, 1200, 5), np.linspace(-200, 200, 4), np.linspace(300, 700, 3)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    field = lambda p: np.stack([0.001 * p[:, 0] - 0.5, 0.002 * p[:, 1], -0.003 * p[:, 2] + 1.0], axis=1)  # noqa: E731
    grid = GridPredictor().fit(X, field(X))
    q = np.array([[950.0, 13.0, 444.0], [1200.0, 200.0, 700.0]])
    np.testing.assert_allclose(grid.predict(q), field(q), atol=1e-12)  # a linear field is reproduced exactly
    with pytest.raises(OutsideGridError, match="outside the measured grid"):
        grid.predict(np.array([[1201.0, 0.0, 500.0]]))
    with pytest.raises(InputError, match="full regular grid"):
        GridPredictor().fit(X[:-1], field(X[:-1]))


def test_one_torch_and_it_is_the_pinned_one():
    import torch

    assert torch.__version__.startswith("2.13.0")
    assert importlib.metadata.version("torch").startswith("2.13.0")
    names = [d.metadata["Name"].lower() for d in importlib.metadata.distributions()]
    assert names.count("torch") == 1 and not any(n.startswith("nvidia-") for n in names)


def test_region_similarity():
    from postproc.model.learn import region_similarity

    rng = np.random.default_rng(0)
    base = rng.normal(0, 1, (50, 3))
    assert region_similarity(base, 2.0 * base + 0.5) == pytest.approx(1.0)  # the same pattern, scaled and shifted
    assert region_similarity(base, rng.normal(0, 1, (50, 3))) < 0.9  # unrelated patterns
