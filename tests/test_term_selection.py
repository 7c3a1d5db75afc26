"""Term selection (postproc.model.term_selection): best subset over the whole family finds the
true support where greedy forward selection does not, reports how stable the choice is,
and chooses nothing when there is nothing to find; on simulated KR160s through ``fit``."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL, kr160

from postproc.model.effects import parse_effects
from postproc.model.identify import Stats, fit, residuals
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.model.term_selection import select_terms

NOISE = 0.02
FLOOR = NOISE * np.sqrt(3)  # 3-D RMS of 0.02 mm per axis


def _family(rng, n_units=200, n_terms=24, n_base=8, mixing=0.5):
    """A design of n_terms column pairs, correlated through shared factors, and base columns;
    rows come in units of three (like a pose's x, y, z)."""
    rows = 3 * n_units
    shared = rng.standard_normal((rows, 6))
    design = rng.standard_normal((rows, 2 * n_terms)) + mixing * shared @ rng.standard_normal((6, 2 * n_terms))
    base = rng.standard_normal((rows, n_base))
    return design, base, [[2 * t, 2 * t + 1] for t in range(n_terms)]


def _target(rng, design, base, support, noise=NOISE, size=0.2):
    """Target of the terms in ``support`` (random phases), base columns and noise; and its term part."""
    coef = np.zeros(design.shape[1])
    for t in support:
        angle = rng.uniform(0, 2 * np.pi)
        coef[2 * t : 2 * t + 2] = size * rng.uniform(0.5, 1.5) * np.array([np.cos(angle), np.sin(angle)])
    signal = design @ coef
    return signal + base @ rng.standard_normal(base.shape[1]) + noise * rng.standard_normal(len(design)), signal


def _folds(rows, seed=0, k=5):
    return np.repeat(np.random.default_rng(seed).permutation(rows // 3) % k, 3)


def _units(rows):
    return np.repeat(np.arange(rows // 3), 3)


def _greedy_first(design, base, target, groups):
    """The term greedy forward selection takes first: the one that helps most alone."""
    def rss(cols):
        a = np.column_stack([base, design[:, cols]])
        return np.sum((target - a @ np.linalg.lstsq(a, target, rcond=None)[0]) ** 2)

    return int(np.argmin([rss(g) for g in groups]))


def test_best_subset_finds_two_terms_that_a_decoy_imitates():
    rng = np.random.default_rng(1)
    design, base, groups = _family(rng, mixing=0.0)
    # Term 5 imitates the sum of the true terms 2 and 9: alone it explains more than either.
    truth = (2, 9)
    y, signal = _target(rng, design, base, truth)
    decoy = signal / signal.std() + 0.3 * rng.standard_normal(len(y))
    design[:, 10:12] = np.column_stack([decoy, rng.standard_normal(len(y))])
    assert _greedy_first(design, base, y, groups) == 5  # greedy would start on the decoy
    pick = select_terms(design, y, groups, _folds(len(y)), base=base, unit_of=_units(len(y)))
    assert pick.chosen == truth
    assert pick.stability[list(truth)].min() >= 0.9 and pick.stability[5] <= 0.1
    assert pick.cv_rms < 1.1 * NOISE * np.sqrt(3)


@pytest.mark.parametrize("seed", range(6))
def test_random_supports_of_several_terms_are_found_exactly(seed):
    rng = np.random.default_rng(100 + seed)
    design, base, groups = _family(rng)
    truth = tuple(sorted(rng.choice(len(groups), size=rng.integers(1, 5), replace=False).tolist()))
    y, _ = _target(rng, design, base, truth)
    pick = select_terms(design, y, groups, _folds(len(y), seed), base=base, unit_of=_units(len(y)), seed=seed)
    assert pick.chosen == truth
    assert pick.support_stability >= 0.8
    assert pick.cv_rms < 1.1 * NOISE * np.sqrt(3)  # the refit reaches the noise floor
    assert pick.cv_rms_by_size[0] > 2 * pick.cv_rms


def test_nothing_to_find_selects_nothing():
    for seed in range(3):
        rng = np.random.default_rng(200 + seed)
        design, base, groups = _family(rng)
        y, _ = _target(rng, design, base, ())
        pick = select_terms(design, y, groups, _folds(len(y), seed), base=base, unit_of=_units(len(y)), seed=seed)
        assert pick.chosen == ()
        assert not np.any(pick.coef)


def _kr160_case(terms: str, seed: int, n: int, amplitude_deg: float | None = None):
    """A simulated KR160 with reducer harmonics ``terms`` (random, or each of the given
    amplitude with a random phase); the chosen terms, validation RMS and the fit's notes."""
    robot = kr160()
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE + f",joint_harmonics[terms={terms}]"), rng)
    phases = {p.name: rng.uniform(0, 2 * np.pi) for p in truth.params if "_sin" in p.name} if amplitude_deg else {}
    values = {}
    for name, phase in phases.items():
        values[name] = amplitude_deg * np.cos(phase)
        values[name.replace("_sin", "_cos")] = amplitude_deg * np.sin(phase)
    truth = truth.with_values(values)
    train = simulate(truth, sample_poses(robot, TOOL, n, Cylinder(), rng), rng, noise_mm=NOISE)
    val = simulate(truth, sample_poses(robot, TOOL, 300, Cylinder(), rng), rng, noise_mm=NOISE)
    result = fit(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE + ",joint_harmonics"), train, cv_folds=0)
    harmonics = result.model.effects.get("joint_harmonics")
    return (harmonics.terms if harmonics else ()), Stats.of(residuals(result.model, val)).rms_mm, result.notes


def test_kr160_reducer_harmonics_2_4_and_3_3_are_found_and_reach_the_noise_floor():
    # 120 poses. Greedy forward selection took 3:4 alone here (validation RMS 0.0414 mm,
    # 20 % above the noise floor); with 2:4 and 3:3 it is 0.0365 mm.
    terms, val_rms, notes = _kr160_case("2:4,3:3", seed=9, n=120)
    assert terms == ((2, 4), (3, 3))
    assert val_rms < 1.1 * FLOOR, f"validation RMS {val_rms:.4f} mm vs noise floor {FLOOR:.4f} mm"
    assert any("2:4 (" in n and "3:3 (" in n and "% of resamples" in n for n in notes)  # stability is reported


@pytest.mark.parametrize(("terms", "seed"), [("1:2,2:3,5:1", 21), ("1:3,2:2,3:3,5:2", 25)])
def test_kr160_harmonics_on_several_joints_reach_the_noise_floor(terms, seed):
    """Harmonics of several orders on several joints. Joint 2 sweeps a narrow range in this
    workspace, so its orders 1 and 2 can be near-collinear with each other and with the
    gravity compliance: there the choice may differ, but then it is flagged unstable; every
    term chosen stably is a true one, and the refit reaches the noise floor."""
    chosen, val_rms, notes = _kr160_case(terms, seed=seed, n=200, amplitude_deg=0.02)
    truth = {tuple(int(v) for v in t.split(":")) for t in terms.split(",")}
    stable = {tuple(int(v) for v in m[0].split(":")) for m in re.findall(r"(\d:\d) \((\d+) %\)", " ".join(notes)) if int(m[1]) >= 90}
    assert stable and stable <= truth and len(chosen) >= len(truth) - 1
    assert val_rms < 1.1 * FLOOR, f"validation RMS {val_rms:.4f} mm vs noise floor {FLOOR:.4f} mm"


def test_without_base_columns():
    """A model with no parameters of its own (``--effects none``): nothing to profile out."""
    rng = np.random.default_rng(7)
    design, base, groups = _family(rng, n_units=120)
    y, _ = _target(rng, design, base[:, :0], (3, 11))
    pick = select_terms(design, y, groups, _folds(len(y)), base=np.zeros((len(y), 0)), unit_of=_units(len(y)))
    # With 120 units a noise term can pass the one-standard-error rule (here term 20, 2.8 %
    # of held-out MSE); it is then chosen less often than the true ones.
    assert {3, 11} <= set(pick.chosen) and pick.stability[[3, 11]].min() == 1.0
    assert all(pick.stability[t] < 0.9 for t in set(pick.chosen) - {3, 11})
