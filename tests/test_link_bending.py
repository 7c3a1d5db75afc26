"""link_bending: the beam formulas, recovery by the fit, and diagnosis of a hidden bending.

The workspace is a joint-space box: bending is told apart from joint compliance by how
the load across each link changes with the arm's posture, which a wide range of joint 2
and 3 angles shows (a thin Cartesian slab of tool-down poses barely does).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import TOOL, kr160

from postproc.model.diagnose import diagnose
from postproc.model.effects import parse_effects
from postproc.model.effects.link_bending import segment_deflection
from postproc.model.errormodel import ErrorModel
from postproc.model.identify import fit
from postproc.model.sim import JointBox, random_truth, sample_poses, simulate

FR = "geometric,base_frame,tool_offset,joint_compliance"
TRUTH = FR + ",link_bending"
BOX = JointBox()  # the joint limits (within +-170 deg)


def test_cantilever_formulas():
    """A horizontal 1 m beam with EI = 1 (b = L/EI = 1): tip load 100 N and, with the load's
    centre 1 m beyond the tip, tip moment 100 N*m: delta = PL^3/3EI + ML^2/2EI, theta = PL^2/2EI + ML/EI."""
    base, tip = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])
    down = np.array([0.0, 0.0, -100.0])
    at_tip = segment_deflection(base, tip, [(tip.copy(), down, True)], tip)
    np.testing.assert_allclose(at_tip, [[0.0, 0.0, -1000.0 * 100.0 / 3.0]])
    with_moment = segment_deflection(base, tip, [(np.array([[2.0, 0.0, 0.0]]), down, True)], tip + [[1.0, 0.0, 0.0]])
    slope = 100.0 / 2 + 100.0  # rad
    np.testing.assert_allclose(with_moment, [[0.0, 0.0, -1000.0 * (100.0 / 3 + 100.0 / 2 + slope)]])
    # A load at mid-span: P a^2 (3L - a) / 6EI at the tip; a load along the beam bends nothing.
    mid = segment_deflection(base, tip, [(np.array([[0.5, 0.0, 0.0]]), down, False)], tip)
    np.testing.assert_allclose(mid, [[0.0, 0.0, -1000.0 * 100.0 * 0.25 * 2.5 / 6]])
    axial = segment_deflection(base, tip, [(tip.copy(), np.array([-100.0, 0.0, 0.0]), True)], tip)
    np.testing.assert_allclose(axial, 0.0, atol=1e-9)


def test_deflection_grows_with_reach_and_points_down():
    robot = kr160()
    model = ErrorModel.create(robot, TOOL, parse_effects("link_bending"), {"link_bending.upper_arm": 1.5e-7, "link_bending.forearm": 3e-7})
    near = np.array([[0.0, -90.0, 0.0, 0.0, 0.0, 0.0]])  # upper arm level, forearm hanging: TCP 790 mm from axis 1
    far = np.array([[0.0, -90.0, 90.0, 0.0, 0.0, 0.0]])  # both links level: TCP 1985 mm from axis 1
    shift = [model.predict_prepared(model.prepare(q_deg=q))[0] - model.nominal().predict_prepared(model.nominal().prepare(q_deg=q))[0] for q in (near, far)]
    assert np.linalg.norm(shift[1]) > 3 * np.linalg.norm(shift[0]) > 0
    assert shift[1][2] < -0.9 * np.linalg.norm(shift[1])  # the outstretched arm sags


def _truth_and_data(seed: int, n: int, soft: float = 1.0):
    """A random true robot with bending (``soft`` times the drawn compliances) and n poses of it."""
    rng = np.random.default_rng(seed)
    truth = random_truth(kr160(), TOOL, parse_effects(TRUTH), rng)
    truth = truth.with_values({p.name: soft * v for p, v in zip(truth.params, truth.values) if p.name.startswith("link_bending.")})
    return truth, simulate(truth, sample_poses(kr160(), TOOL, n, BOX, rng), rng)


def test_fit_recovers_the_true_bending():
    truth, data = _truth_and_data(seed=5, n=300)
    result = fit(kr160(), TOOL, parse_effects(TRUTH), data, cv_folds=0)
    for part in ("upper_arm", "forearm"):
        name = f"link_bending.{part}"
        assert name not in result.fixed
        fitted, true, std = result.model.value(name), truth.value(name), result.std[name]
        assert abs(fitted - true) < 3 * std, f"{name}: {fitted:.3g} vs true {true:.3g} (std {std:.2g})"
        assert std < 0.35 * true, f"{name}: standard error {std:.2g} too large to call it identified"
    assert result.after.rms_mm < 1.1 * 0.02 * np.sqrt(3)


def test_diagnose_ranks_hidden_bending_first():
    # A soft arm (twice the drawn bending compliances) so 150 poses suffice for a fast test;
    # the competitors include order-1 harmonics of joints 2 and 3, which share the gravity shape.
    truth, data = _truth_and_data(seed=7, n=150, soft=2.0)
    model = fit(kr160(), TOOL, parse_effects(FR), data, cv_folds=0).model
    result = diagnose(model, data, seed=7, folds=4, candidates=["link_bending", "backlash", "thermal", "joint_harmonics[joints=2,3;orders=1]"])
    top = result.candidates[0]
    assert top.effect == "link_bending" and top.significant, [(c.effect, c.explained) for c in result.candidates]
    assert "bend" in top.message
    assert not any(c.significant for c in result.candidates[1:])


@pytest.mark.parametrize("spec", ["link_bending"])
def test_named_in_the_catalog_by_its_file_alone(spec):
    from postproc.model.effects import CATALOG

    assert CATALOG[spec].__module__ == "postproc.model.effects.link_bending"
