"""Effect specs, each effect's physics, and the analytic identification Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

import postproc
from postproc.errors import MeasurementError
from postproc.model.effect_check import check_effect, with_random_context
from postproc.model.effects import BUILTIN, CATALOG, EffectSpecError, EffectSum, Geometric, JointHarmonics, parse_effects
from postproc.model.effects.backlash import approach_from_order
from postproc.model.errormodel import ErrorModel
from postproc.model.measurements import MeasurementSet


def test_catalog_names_are_the_spec_names():
    assert set(CATALOG) >= {"geometric", "base_frame", "tool_offset", "joint_compliance", "external_load", "joint_harmonics", "backlash", "thermal"}


def test_parse_effects_with_options_and_round_trip():
    effects = parse_effects("geometric, joint_harmonics[joints=2,3;orders=3,4], backlash[joints=1,2,3], thermal[reference=21.5]")
    assert effects.names() == ["geometric", "joint_harmonics", "backlash", "thermal"]
    assert effects.get("joint_harmonics").terms == ((2, 3), (2, 4), (3, 3), (3, 4))
    assert effects.get("backlash").joints == (1, 2, 3)
    assert effects.get("thermal").reference_c == 21.5
    assert parse_effects(effects.spec()).spec() == effects.spec()
    assert parse_effects("none").names() == []
    assert (Geometric() + JointHarmonics.grid([2], [3])).spec() == "geometric,joint_harmonics[joints=2;orders=3]"


def test_harmonics_take_the_orders_of_a_strain_wave_gear():
    """Orders near twice a gear ratio (about 200 on a 1:101 strain-wave gear) are terms like any other."""
    effects = parse_effects("joint_harmonics[terms=2:17,3:202]")
    assert effects.get("joint_harmonics").terms == ((2, 17), (3, 202))
    assert parse_effects(effects.spec()).spec() == effects.spec()
    assert parse_effects("joint_harmonics[joints=2;orders=101,202]").get("joint_harmonics").terms == ((2, 101), (2, 202))


def test_harmonics_with_max_order_leave_the_terms_to_the_fit():
    effect = parse_effects("joint_harmonics[max_order=30;joints=2,3]").get("joint_harmonics")
    assert not effect.resolved
    assert len(effect.candidate_terms()) == 60 and (3, 30) in effect.candidate_terms()
    assert parse_effects(effect.spec()).get("joint_harmonics").candidate_terms() == effect.candidate_terms()
    assert effect.with_terms(((2, 17),)).spec() == "joint_harmonics[joints=2;orders=17]"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("joint_harmonics[max_order=30;orders=2]", "goes with joints only"),
        ("joint_harmonics[max_order=20,30]", "one order"),
        ("joint_harmonics[terms=2:1001]", "order 1..1000"),
        ("joint_harmonics[joints=2;orders=1001]", "1..1000"),
        ("geometric,heat", "unknown effect 'heat'"),
        ("geometric,geometric", "appears twice"),
        ("joint_harmonics[joints=7]", "1..6"),
        ("joint_harmonics[joints=2;order=3]", "unknown option"),
        ("backlash[joints=1,2", "unbalanced"),
        ("geometric[x=1]", "takes no options"),
        ("thermal[reference=warm]", "temperature"),
    ],
)
def test_bad_effect_specs(text, message):
    with pytest.raises(EffectSpecError, match=message):
        parse_effects(text)


def _random_set(n=25, seed=0):
    rng = np.random.default_rng(seed)
    return with_random_context(rng.uniform(-60, 60, (n, 6)), rng)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_every_catalog_effect_passes_the_contract(name):
    """``postproc effect check``'s contract, alone: analytic Jacobian = finite differences,
    zero parameters = nominal robot, bounds, texts, options and model file round trips."""
    failed = [f"{c.name}: {c.detail}" for c in check_effect(CATALOG[name]) if not c.ok]
    assert not failed, failed


def test_analytic_jacobian_of_the_whole_catalog_together():
    """Every catalog effect in one model (no hand-written list: a new effect is in it)."""
    robot = postproc.load_robot("kr160_r1570")
    effects = EffectSum(tuple(cls.from_options({}) for cls in (CATALOG[name] for name in sorted(BUILTIN))))
    effects = EffectSum(tuple(e if e.resolved else e.with_terms(e.candidate_terms()[:2]) for e in effects))
    model = ErrorModel.create(robot, [10.0, -5.0, 200.0], effects)
    rng = np.random.default_rng(1)
    model = model.with_vector(model.values + np.array([p.typical for p in model.params]) * rng.standard_normal(len(model.params)))
    # Exact small-angle base-frame derivative holds at zero rotation; keep the rotation in the registration.
    model = model.with_vector(np.where([model.owner(p.name).kind == "base" for p in model.params], 0.0, model.values))
    prep = model.prepare(_random_set())
    _, jac = model.evaluate(prep)
    for k, p in enumerate(model.params):
        h = p.scale * 1e-3
        up, down = model.values.copy(), model.values.copy()
        up[k] += h
        down[k] -= h
        fd = (model.predict_prepared(prep, up) - model.predict_prepared(prep, down)) / (2 * h)
        scale = max(np.abs(fd).max(), np.abs(jac[:, :, k]).max())
        if scale < 1e-9:
            continue  # e.g. joint 6 compliance with the tool on the joint-6 axis: no effect at all
        assert np.abs(fd - jac[:, :, k]).max() < 1e-5 * scale, p.name


def test_compliance_deflects_by_gravity_torque_over_stiffness():
    robot = postproc.load_robot("kr160_r1570")
    meas = _random_set()
    model = ErrorModel.create(robot, [0, 0, 200], parse_effects("joint_compliance"))
    prep = model.prepare(meas)
    basis, idx = prep.bases[0]
    dq = np.einsum("njp,p->nj", basis, model.values[idx])
    expected = np.rad2deg(postproc.gravity_torque(robot, meas.q_deg) / robot.stiffness_nm_per_rad)
    np.testing.assert_allclose(dq, expected, rtol=1e-12)


def test_external_load_is_jacobian_transpose_force():
    robot = postproc.load_robot("kr160_r1570")
    meas = _random_set()
    model = ErrorModel.create(robot, [0, 0, 200], parse_effects("external_load"))
    prep = model.prepare(meas)
    jac = postproc.jacobian(robot, meas.q_deg, tool=[0, 0, 200])
    expected = np.einsum("nij,ni->nj", jac[:, :3], meas.force_n) / 1000.0
    np.testing.assert_allclose(prep.ctx.force_torque, expected, rtol=1e-12)
    # One shared set of compliances with joint_compliance.
    both = ErrorModel.create(robot, [0, 0, 200], parse_effects("joint_compliance,external_load"))
    assert [p.name for p in both.params] == [f"compliance.c{i}" for i in range(1, 7)]


def test_thermal_growth_scales_link_lengths():
    robot = postproc.load_robot("kr160_r1570")
    meas = _random_set()
    model = ErrorModel.create(robot, [0, 0, 0], parse_effects("thermal"), {"thermal.alpha": 1e-4})
    pos = model.predict(meas)
    grow = 1 + 1e-4 * (meas.temp_c - 20.0)
    expected = np.stack([postproc.robot.kinematics.forward_dh(postproc.robot.kinematics.dh_angles(robot, meas.q_deg[i : i + 1]), robot.d_mm * g, robot.a_mm * g, robot.alpha_deg)[0, :3, 3] for i, g in enumerate(grow)])
    np.testing.assert_allclose(pos, expected, atol=1e-9)


def test_backlash_direction_from_row_order():
    q = np.array([[0.0, 0], [1.0, 0], [1.0, -1], [0.5, -1], [0.5, -0.5]])
    q6 = np.hstack([q, np.zeros((5, 4))])
    s = approach_from_order(q6)
    assert s[:, 0].tolist() == [1, 1, 1, -1, -1]
    assert s[:, 1].tolist() == [1, 1, -1, -1, 1]


def test_missing_column_for_an_effect_is_named():
    robot = postproc.load_robot("kr160_r1570")
    meas = _random_set()
    no_force = MeasurementSet(q_deg=meas.q_deg, measured_mm=meas.measured_mm, ids=meas.ids, source="dev.csv")
    model = ErrorModel.create(robot, [0, 0, 200], parse_effects("external_load"))
    with pytest.raises(MeasurementError, match="external_load.*fx, fy, fz"):
        model.prepare(no_force)
    with pytest.raises(MeasurementError, match="thermal.*temp"):
        ErrorModel.create(robot, [0, 0, 200], parse_effects("thermal")).prepare(no_force)
