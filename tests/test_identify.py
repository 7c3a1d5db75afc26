"""Identification on simulated robots with known parameters and on the shared KR160 sets."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import FRAME, TOOL, identifiable_truth, kr160, z_scores

from postproc.errors import IdentificationError
from postproc.model.effects import parse_effects
from postproc.model.identify import Stats, fit, refit_base, residuals
from postproc.model.measurements import read_measurements
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate, tracker_frame

NOISE = 0.02
FLOOR = NOISE * np.sqrt(3)  # RMS of a 3-D error with 0.02 mm per axis

CATALOG_CASES = {
    "geometric": FRAME,
    "base_frame": FRAME,
    "tool_offset": FRAME,
    "joint_compliance": FRAME + ",joint_compliance",
    "external_load": FRAME + ",external_load",
    "joint_harmonics": FRAME + ",joint_harmonics[joints=2,3;orders=1,3]",
    "backlash": FRAME + ",backlash",
    "thermal": FRAME + ",thermal",
}


@pytest.mark.parametrize("effect", sorted(CATALOG_CASES))
def test_every_effect_recovers_its_parameters_and_reaches_the_noise_floor(effect):
    robot = kr160()
    spec = CATALOG_CASES[effect]
    truth, q, rng = identifiable_truth(robot, spec, seed=11)
    train = simulate(truth, q, rng, noise_mm=NOISE)
    val = simulate(truth, sample_poses(robot, TOOL, 150, Cylinder(), rng), rng, noise_mm=NOISE)
    result = fit(robot, TOOL, parse_effects(spec), train, cv_folds=0)
    z = z_scores(result, truth)
    own = {p.name for p in parse_effects(spec).get(effect).params(robot)}
    assert own & set(z), f"none of {effect}'s parameters was identified"
    worst = max(z, key=lambda k: abs(z[k]))
    assert abs(z[worst]) < 3.0, f"{worst}: {z[worst]:.2f} standard errors off"
    val_rms = Stats.of(residuals(result.model, val)).rms_mm
    assert val_rms < 1.15 * FLOOR, f"validation RMS {val_rms:.4f} mm vs noise floor {FLOOR:.4f} mm"


@pytest.mark.parametrize(("name", "effects"), [("a", FRAME + ",joint_compliance"), ("b", FRAME + ",joint_compliance,external_load")])
def test_shared_kr160_sets_validate_below_0_055_mm(shared, name, effects):
    train = read_measurements(shared / "data" / f"kr160_dev_{name}_train.csv")
    val = read_measurements(shared / "data" / f"kr160_dev_{name}_val.csv")
    result = fit(kr160(), TOOL, parse_effects(effects), train)
    val_rms = Stats.of(residuals(result.model, val)).rms_mm
    assert val_rms <= 0.055
    assert result.before.rms_mm > 0.4  # the nominal model is far off: the fit did the work
    assert result.cv_rms_mm == pytest.approx(val_rms, rel=0.2)


def test_identifiability_reports_the_classic_redundancies(shared):
    train = read_measurements(shared / "data" / "kr160_dev_a_train.csv")
    result = fit(kr160(), TOOL, parse_effects(FRAME + ",joint_compliance"), train, cv_folds=0)
    fixed = result.fixed
    assert "base_frame.rz" in fixed["geometric.dtheta1"]
    assert "base_frame.tz" in fixed["geometric.dd1"]
    assert "geometric.dd2" in fixed["geometric.dd3"]  # joints 2 and 3 are parallel
    assert "tool_offset.dz" in fixed["geometric.dd6"]
    assert fixed["compliance.c1"] == "no effect on these poses"  # a vertical axis 1 carries no gravity torque
    assert "base_frame.rz" not in fixed and "tool_offset.dz" not in fixed


def test_outliers_are_flagged_and_a_robust_loss_resists_them():
    robot = kr160()
    rng = np.random.default_rng(5)
    effects = parse_effects(FRAME + ",joint_compliance")
    truth = random_truth(robot, TOOL, effects, rng)
    data = simulate(truth, sample_poses(robot, TOOL, 250, Cylinder(), rng), rng)
    measured = data.measured_mm.copy()
    bad = [10, 77, 150]
    measured[bad] += [[2.0, 0, 0], [0, -3.0, 0], [0, 0, 2.5]]
    from dataclasses import replace

    dirty = replace(data, measured_mm=measured)
    val = simulate(truth, sample_poses(robot, TOOL, 150, Cylinder(), rng), rng)
    plain = fit(robot, TOOL, effects, dirty, cv_folds=0)
    robust = fit(robot, TOOL, effects, dirty, cv_folds=0, loss="soft_l1")
    assert set(str(i + 1) for i in bad) <= set(robust.outliers)
    assert set(str(i + 1) for i in bad) <= set(plain.outliers)
    rms = lambda r: Stats.of(residuals(r.model, val)).rms_mm  # noqa: E731
    assert rms(robust) < rms(plain)
    assert rms(robust) < 1.2 * FLOOR


def test_a_high_order_harmonic_is_recovered():
    """A 5 mdeg cyclic error at order 202 (twice per wave-generator turn of a 1:101 gear),
    period 1.8 deg, is fitted back from poses that sample it densely."""
    robot = kr160()
    rng = np.random.default_rng(5)
    spec = FRAME + ",joint_harmonics[terms=2:202]"
    truth = random_truth(robot, TOOL, parse_effects(spec), rng).with_values({"joint_harmonics.j2_sin202": 0.005, "joint_harmonics.j2_cos202": -0.004})
    data = simulate(truth, sample_poses(robot, TOOL, 400, Cylinder(), rng), rng, noise_mm=NOISE)
    values = fit(robot, TOOL, parse_effects(spec), data, cv_folds=0).model.as_dict()
    assert values["joint_harmonics.j2_sin202"] == pytest.approx(0.005, abs=0.001)
    assert values["joint_harmonics.j2_cos202"] == pytest.approx(-0.004, abs=0.001)


def test_harmonics_with_max_order_choose_a_high_order_term():
    """joint_harmonics[max_order=...] searches every order up to it (forward selection,
    cross-validated): a 15 mdeg order-17 error of joint 2 is found among 2 x 24 candidates."""
    robot = kr160()
    rng = np.random.default_rng(8)
    truth = random_truth(robot, TOOL, parse_effects(FRAME + ",joint_harmonics[terms=2:17]"), rng)
    truth = truth.with_values({"joint_harmonics.j2_sin17": 0.012, "joint_harmonics.j2_cos17": -0.009})
    data = simulate(truth, sample_poses(robot, TOOL, 300, Cylinder(), rng), rng, noise_mm=NOISE)
    result = fit(robot, TOOL, parse_effects(FRAME + ",joint_harmonics[max_order=24;joints=2,3]"), data, cv_folds=0)
    assert (2, 17) in result.model.effects.get("joint_harmonics").terms
    assert len(result.model.effects.get("joint_harmonics").terms) <= 3
    assert any("forward selection over joints 2,3 and orders 1-24" in n for n in result.notes)


def test_harmonics_without_options_choose_the_true_terms():
    robot = kr160()
    rng = np.random.default_rng(8)
    truth = random_truth(robot, TOOL, parse_effects(FRAME + ",joint_harmonics[joints=2;orders=3]"), rng)
    truth = truth.with_values({"joint_harmonics.j2_sin3": 0.02, "joint_harmonics.j2_cos3": -0.015})
    data = simulate(truth, sample_poses(robot, TOOL, 300, Cylinder(), rng), rng)
    result = fit(robot, TOOL, parse_effects(FRAME + ",joint_harmonics"), data, cv_folds=0)
    assert result.model.effects.get("joint_harmonics").terms == ((2, 3),)
    assert any("joint_harmonics[joints=2;orders=3]" in n for n in result.notes)


def test_backlash_without_direction_columns_infers_them_from_row_order():
    robot = kr160()
    rng = np.random.default_rng(9)
    truth = random_truth(robot, TOOL, parse_effects(FRAME), rng)
    data = simulate(truth, sample_poses(robot, TOOL, 120, Cylinder(), rng), rng)
    from dataclasses import replace

    result = fit(robot, TOOL, parse_effects(FRAME + ",backlash"), replace(data, approach=None), cv_folds=0)
    assert result.approach_inferred
    assert any("row order" in n for n in result.notes)


def test_tracker_frame_far_from_base_is_registered_and_reregistered():
    robot = kr160()
    rng = np.random.default_rng(12)
    effects = parse_effects(FRAME + ",joint_compliance")
    truth = random_truth(robot, TOOL, effects, rng)
    q = sample_poses(robot, TOOL, 250, Cylinder(), rng)
    series_a = simulate(tracker_frame(truth, [5.0, -10.0, 130.0], [2400.0, -1300.0, 150.0]), q, rng)
    q_b = sample_poses(robot, TOOL, 150, Cylinder(), rng)
    series_b = simulate(tracker_frame(truth, [-3.0, 4.0, -60.0], [-500.0, 3200.0, -400.0]), q_b, rng)
    result = fit(robot, TOOL, effects, series_a, cv_folds=0)
    assert result.after.rms_mm < 1.15 * FLOOR
    assert result.before.rms_mm < 5.0  # 'before' is the nominal robot rigidly registered, not metres off
    # On another tracker placement: only the frame is re-registered, all else kept.
    moved = refit_base(result.model, series_b)
    assert Stats.of(residuals(moved, series_b)).rms_mm < 1.2 * FLOOR
    assert Stats.of(residuals(result.model, series_b)).rms_mm > 100.0


def test_too_few_poses_is_an_identification_error():
    robot = kr160()
    rng = np.random.default_rng(3)
    truth = random_truth(robot, TOOL, parse_effects(FRAME), rng)
    data = simulate(truth, sample_poses(robot, TOOL, 8, Cylinder(), rng), rng)
    with pytest.raises(IdentificationError, match="measure more poses"):
        fit(robot, TOOL, parse_effects(FRAME), data, cv_folds=0)


def test_a_fit_says_each_step_of_the_solver():
    """A fit of many terms on 10^4 poses runs for minutes: the progress callback hears every
    Jacobian, so the command's progress line goes on (issue 31 saw 18 silent minutes)."""
    robot = kr160()
    spec = FRAME + ",joint_compliance"
    truth, q, rng = identifiable_truth(robot, spec, seed=11)
    heard = []
    fit(robot, TOOL, parse_effects(spec), simulate(truth, q, rng, noise_mm=NOISE), cv_folds=0, progress=heard.append)
    steps = [m for m in heard if m.startswith("fitting") and "(step " in m]
    assert len(steps) >= 2 and steps[0].endswith("(step 1)"), heard
