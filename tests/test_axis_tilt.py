"""axis_tilt (Hayati's beta): the first-order displacement, why the DH errors cannot carry it,
recovery by the fit and diagnosis of a hidden tilt on a UR-type arm (axes 2, 3, 4 parallel)."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import TOOL, kr160

import postproc
from postproc.model.diagnose import diagnose
from postproc.model.effects import parse_effects
from postproc.model.effects.axis_tilt import parallel_pairs
from postproc.model.errormodel import ErrorModel
from postproc.model.identify import fit
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate
from postproc.robot.kinematics import joint_frames

FR = "geometric,base_frame,tool_offset,joint_compliance"
UR_TOOL = np.array([0.0, 0.0, 109.0])


def ur10():
    return postproc.load_robot("ur10")


def _poses(n: int, seed: int) -> np.ndarray:
    return sample_poses(ur10(), UR_TOOL, n, JointBox(), np.random.default_rng(seed))


def test_parallel_pairs_from_the_twists():
    assert parallel_pairs(ur10()) == [2, 3]
    assert parallel_pairs(kr160()) == [2]
    assert [p.name for p in next(iter(parse_effects("axis_tilt[frames=3]"))).params(ur10())] == ["axis_tilt.beta3"]


def test_first_order_matches_an_exact_rotation_about_y():
    """Rot_y(beta) inserted after DH frame i turns everything beyond it about y_i through o_i."""
    q = _poses(50, 1)
    beta = 0.05  # deg
    model = ErrorModel.create(ur10(), UR_TOOL, parse_effects("axis_tilt[frames=3]"), {"axis_tilt.beta3": beta})
    moved = model.predict_prepared(model.prepare(q_deg=q)) - model.nominal().predict_prepared(model.nominal().prepare(q_deg=q))
    rots, origins = joint_frames(ur10(), q)
    point = origins[:, 6] + rots[:, 6] @ UR_TOOL
    y, lever = rots[:, 3, :, 1], point - origins[:, 3]
    b = np.deg2rad(beta)
    exact = lever * (np.cos(b) - 1) + np.cross(y, lever) * np.sin(b) + y * np.einsum("nk,nk->n", y, lever)[:, None] * (1 - np.cos(b))
    assert np.abs(moved).max() > 0.05  # mm: a 0.05 deg tilt is visible
    np.testing.assert_allclose(moved, exact, atol=1e-3)  # second order in beta: well below a micrometre per 0.05 deg


def test_the_dh_errors_cannot_carry_a_tilt():
    """The beta columns are not in the span of the 24 DH errors, base frame and tool offset."""
    q = _poses(300, 2)
    model = ErrorModel.create(ur10(), UR_TOOL, parse_effects(FR + ",axis_tilt"))
    _, jac = model.evaluate(model.prepare(q_deg=q))
    j = jac.reshape(-1, jac.shape[-1])
    tilt = [model.index(n) for n in ("axis_tilt.beta2", "axis_tilt.beta3")]
    others = j[:, [k for k in range(j.shape[1]) if k not in tilt]]
    for k in tilt:
        coef, *_ = np.linalg.lstsq(others, j[:, k], rcond=None)
        left = np.linalg.norm(j[:, k] - others @ coef) / np.linalg.norm(j[:, k])
        assert left > 0.2, f"{model.params[k].name}: only {left:.2f} of its column is new"


def _truth_and_data(seed: int, n: int):
    rng = np.random.default_rng(seed)
    truth = random_truth(ur10(), UR_TOOL, parse_effects(FR + ",axis_tilt"), rng)
    truth = truth.with_values({"axis_tilt.beta2": 0.04, "axis_tilt.beta3": -0.03})
    return truth, simulate(truth, _poses(n, seed), rng)


def test_fit_recovers_the_true_tilts():
    truth, data = _truth_and_data(seed=5, n=200)
    result = fit(ur10(), UR_TOOL, parse_effects(FR + ",axis_tilt"), data, cv_folds=0)
    for name in ("axis_tilt.beta2", "axis_tilt.beta3"):
        assert name not in result.fixed
        fitted, true, std = result.model.value(name), truth.value(name), result.std[name]
        assert abs(fitted - true) < 4 * std + 1e-4, f"{name}: {fitted:.4g} vs true {true:.4g} (std {std:.2g})"
        assert std < 0.2 * abs(true)
    assert result.after.rms_mm < 1.1 * 0.02 * np.sqrt(3)


def test_diagnose_ranks_a_hidden_tilt_first():
    truth, data = _truth_and_data(seed=7, n=150)
    model = fit(ur10(), UR_TOOL, parse_effects(FR), data, cv_folds=0).model
    result = diagnose(model, data, seed=7, folds=3, candidates=["axis_tilt", "link_bending", "base_tilt"])
    top = result.candidates[0]
    assert top.effect == "axis_tilt" and top.significant, [(c.effect, c.explained) for c in result.candidates]
    assert "parallel joint axes" in top.message


@pytest.mark.parametrize("bad", ["axis_tilt[frames=0]", "axis_tilt[frames=x]", "axis_tilt[axes=2]"])
def test_bad_options_are_refused(bad):
    from postproc.model.effects import EffectSpecError

    with pytest.raises(EffectSpecError):
        parse_effects(bad)
