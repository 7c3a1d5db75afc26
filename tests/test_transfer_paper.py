"""Seed 001's transfer learning as published (postproc.model.learn.transfer_paper) and the
source-region predictor of eq. 26, next to the default (physics) Tr-GPR."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.model.learn import TrGPRPredictor
from postproc.model.learn import transfer_paper as paper
from postproc.model.learn.residual import estimator_from_state, estimator_state


def _regions(rng, n_source=60, n_target=40):
    """Pose features of a source sector theta1 in [-40, -30] deg and a target sector [-30, 40],
    with a smooth error field that turns with the base angle."""
    def poses(lo, hi, n):
        t, r, z = np.radians(rng.uniform(lo, hi, n)), rng.uniform(800, 1300, n), rng.uniform(400, 900, n)
        return np.column_stack([r * np.cos(t), r * np.sin(t), z, np.degrees(t), rng.uniform(-5, 5, (n, 2))])

    def errors(X):
        t = np.radians(X[:, 3])
        local = np.column_stack([0.4 * np.sin(X[:, 2] / 150.0), 0.2 * np.cos(np.hypot(X[:, 0], X[:, 1]) / 120.0), 0.3 + 0.0004 * X[:, 2]])
        return np.column_stack([np.cos(t) * local[:, 0] - np.sin(t) * local[:, 1], np.sin(t) * local[:, 0] + np.cos(t) * local[:, 1], local[:, 2]])

    Xs, Xt = poses(-40, -30, n_source), poses(-30, 40, n_target)
    return Xs, errors(Xs) + 0.02 * rng.standard_normal((n_source, 3)), Xt, errors(Xt) + 0.02 * rng.standard_normal((n_target, 3))


def test_turn_of_eq_11_12_is_recovered_from_regions_sampled_alike():
    rng = np.random.default_rng(0)
    Xs, _, _, _ = _regions(rng)
    Xt = paper.turn(Xs, 35.0, np.array([0.0, 0.0, 7.0]))  # a horizontal shift would move theta1 too
    theta, shift = paper.fit_turn(Xt, Xs)
    assert theta == pytest.approx(35.0, abs=1e-9)
    np.testing.assert_allclose(shift, [0.0, 0.0, 7.0], atol=1e-9)
    np.testing.assert_allclose(paper.unturn(Xt, theta, shift), Xs, atol=1e-9)


def test_label_map_of_eq_13_14_has_the_papers_size_and_recovers_an_exact_map():
    rng = np.random.default_rng(1)
    design = np.column_stack([rng.uniform(800, 1300, (16, 3)), rng.normal(0, 0.5, (16, 3)), np.ones(16)])  # (X T, Y_sd, L)
    true_h = np.vstack([rng.normal(0, 1e-3, (3, 3)), np.eye(3) + rng.normal(0, 0.1, (3, 3)), rng.normal(0, 0.2, (1, 3))])
    h, lam = paper.label_map(design, design @ true_h, np.ones((16, 3)))
    assert h.shape == (7, 3)  # (3 position coordinates + 3 source errors + L) x 3
    np.testing.assert_allclose(design @ h, design @ true_h, atol=1e-4)


def test_measurement_weights_follow_eq_13():
    sigma = np.full(3, 0.02)
    w = paper.measurement_weights(np.array([[0.5, -0.03, 0.041]]), sigma)
    np.testing.assert_allclose(w, [[25.0, 0.0, 2.05]])  # |e|/sigma; zero unless |e| - sigma > sigma


def test_paper_variant_merges_kn_plus_m_samples_and_keeps_the_source_model_for_the_source_region():
    rng = np.random.default_rng(2)
    Xs, ys, Xt, yt = _regions(rng)
    model = TrGPRPredictor(variant="paper", n_iter=4).fit(Xt, yt, Xs, ys)
    assert len(model.alignments_) == 5 and all(np.shape(a["H"]) == (7, 3) for a in model.alignments_)
    assert len(model.learners_[0].X_train_) == 5 * len(Xs) + len(Xt)  # eq. 17: kn + m
    assert np.all(model.learner_weights_ > 0)  # ln(1/beta) of the rounds kept (eps_t <= 0.5)
    np.testing.assert_allclose(model.predict(Xs), model.source_model_.predict(Xs))  # eq. 26
    other = model.predict(Xt)
    assert not np.allclose(other, model.source_model_.predict(Xt))
    again = estimator_from_state(estimator_state(model))
    np.testing.assert_allclose(again.predict(np.vstack([Xs, Xt])), np.vstack([model.predict(Xs), other]), atol=1e-9)


def test_source_region_predictor_beats_the_transfer_model_there():
    """eq. 26: inside the source region the densely measured source GPR predicts better
    than the model trained on the source data turned into the target sub-spaces."""
    rng = np.random.default_rng(3)
    Xs, ys, Xt, yt = _regions(rng)
    Xv, yv, _, _ = _regions(rng, n_source=40, n_target=1)
    kept = TrGPRPredictor(n_iter=3).fit(Xt, yt, Xs, ys)
    dropped = TrGPRPredictor(n_iter=3, keep_source=False).fit(Xt, yt, Xs, ys)
    err = lambda m: np.mean(np.linalg.norm(m.predict(Xv) - yv, axis=1))  # noqa: E731
    assert err(kept) < err(dropped)
    np.testing.assert_allclose(kept.predict(Xt), dropped.predict(Xt))  # outside it nothing changes


@pytest.mark.slow
def test_seed001_design_default_and_as_published():
    """Seed 001 Table 7-8 design (one configuration family; 126 source poses in theta1
    [-40, -30] deg, 80 target poses in 5 sub-spaces of [-30, 40], validation in [-20, 20]).
    The default Tr-GPR is within 1.2x of GPR on 378 validation-region poses and far better
    than GPR on the 80 target poses; the as-published variant beats GPR on the 50
    validation-region poses but not the default (numbers in the README)."""
    from postproc.model.learn.experiments import seed001_transfer

    rows = {r["model"].split(" (")[0]: r["mean_mm"] for r in seed001_transfer(1)}
    assert rows["Tr-GPR"] <= 1.2 * rows["GPR-378"]
    assert rows["Tr-GPR"] <= 0.6 * rows["GPR-80"]
    assert rows["Tr-GPR as published"] < rows["GPR-50"]
    assert rows["Tr-GPR as published"] < 0.1 * rows["uncompensated"]
