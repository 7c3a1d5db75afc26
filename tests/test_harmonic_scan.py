"""The cyclic-error scan (postproc.model.harmonic_scan) on a residual with planted terms."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.model.harmonic_scan import (
    Residual,
    amplitude_phase,
    choose_terms,
    per_group_sums,
    periodogram,
    term_columns,
)

PLANTED = {(2, 17): (0.02, -0.01), (3, 5): (0.0, 0.015)}  # (joint, order): (sin, cos) deg


def planted_residual(n_groups=150, per_group=4, noise_mm=0.002, seed=3) -> tuple[Residual, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = n_groups * per_group
    q_rad = rng.uniform(-np.pi, np.pi, (n, 6))
    dp_dq = rng.normal(0.0, 15.0, (n, 3, 6))  # mm per degree, about an arm of 1 m
    base = rng.normal(size=(3 * n, 4))
    empty = Residual(np.zeros((n, 3)), dp_dq, base, q_rad)
    explained = term_columns(empty, list(PLANTED)) @ np.ravel(list(PLANTED.values())) + base @ rng.normal(0, 0.01, 4)
    r = -explained.reshape(n, 3) + rng.normal(0.0, noise_mm, (n, 3))
    return Residual(r, dp_dq, base, q_rad), np.repeat(np.arange(n_groups), per_group)


def test_periodogram_peaks_at_the_planted_term_and_only_there():
    res, groups = planted_residual()
    test = groups % 5 == 4
    gains = periodogram(res, np.arange(1, 61), ~test, test)
    assert np.unravel_index(np.argmax(gains), gains.shape) == (1, 16)  # joint 2, order 17
    assert gains[1, 16] > 0.5
    assert np.abs(gains[[0, 3, 4, 5]]).max() < 0.05  # joints without a planted term: chance only


def test_choose_terms_finds_the_planted_terms_and_stops():
    res, groups = planted_residual()
    test = groups % 5 == 4
    choice = choose_terms(res, groups, ~test, [(j, k) for j in range(1, 7) for k in range(1, 31)], max_terms=8)
    assert set(choice.terms) == set(PLANTED)
    assert choice.cv_rms_mm[2] < 0.2 * choice.cv_rms_mm[0]


def test_amplitude_and_phase_of_one_term():
    res, _ = planted_residual()
    amp, phase = amplitude_phase(res, (2, 17))
    assert amp == pytest.approx(1e3 * np.hypot(0.02, -0.01), rel=0.05)
    assert phase == pytest.approx(np.degrees(np.arctan2(-0.01, 0.02)), abs=3.0)


def test_per_group_sums_are_the_sums_over_each_groups_training_rows():
    rng = np.random.default_rng(2)
    groups = rng.integers(0, 40, 500)
    train = rng.random(500) < 0.8
    values = rng.random((4, 500))
    train_groups = np.unique(groups[train])
    expected = np.array([[row[train & (groups == g)].sum() for g in train_groups] for row in values])
    np.testing.assert_allclose(per_group_sums(values, groups, train, train_groups), expected, rtol=1e-12)
