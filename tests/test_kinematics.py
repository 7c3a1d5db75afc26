"""Vectorised kinematics against pinocchio (the reference model), finite differences and round trips."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import postproc
from postproc.robot import kinematics as kin
from postproc.robot import pin_model

ALL = ["kr160_r1570", "irb6660_205_190", "irb2400_10", "kr6_r700_sixx", "ur10", "tx2_90"]
OPW = ["kr160_r1570", "irb6660_205_190", "irb2400_10", "kr6_r700_sixx", "tx2_90"]


def random_joints(robot, n, seed, margin=0.0):
    """n configurations inside every joint and coupling limit (rejection sampling)."""
    rng = np.random.default_rng(seed)
    lo = np.maximum(robot.lower_deg, -180.0) + margin
    hi = np.minimum(robot.upper_deg, 180.0) - margin
    out = np.empty((0, 6))
    while len(out) < n:
        q = rng.uniform(lo, hi, size=(2 * n, 6))
        out = np.concatenate([out, q[kin.within_limits(robot, q)]])
    return out[:n]


def ours_and_pinocchios(name: str, n: int, seed: int, ours_of, reference_of):
    """(robot, q, ours, reference) at ``n`` random joint sets of robot ``name``: our vectorised
    ``ours_of(robot, q)`` (postproc.fk, jacobian) and pinocchio's ``reference_of(model, data, q)``
    (pin_model.flange_pose, flange_jacobian) at every row of ``q``."""
    robot = postproc.load_robot(name)
    q = random_joints(robot, n, seed=seed)
    model = pin_model.build_model(robot)
    data = model.createData()
    return robot, q, ours_of(robot, q), np.stack([reference_of(model, data, qi) for qi in q])


@pytest.mark.parametrize("name", ALL)
def test_fk_matches_pinocchio(name):
    _, _, ours, ref = ours_and_pinocchios(name, 200, 1, postproc.fk, pin_model.flange_pose)
    np.testing.assert_allclose(ours[:, :3, 3], ref[:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(ours[:, :3, :3], ref[:, :3, :3], atol=1e-12)


def test_fk_large_batch_uses_chunks_and_threads_consistently():
    robot = postproc.load_robot("kr160_r1570")
    q = random_joints(robot, 3 * kin.CHUNK + 17, seed=2)
    big = postproc.fk(robot, q)
    small = np.concatenate([postproc.fk(robot, q[i : i + 1000]) for i in range(0, len(q), 1000)])
    np.testing.assert_array_equal(big, small)


def test_fk_with_tool_offset_and_transform():
    robot = postproc.load_robot("kr160_r1570")
    q = random_joints(robot, 50, seed=3)
    flange = postproc.fk(robot, q)
    tcp = postproc.fk(robot, q, tool=[10.0, -5.0, 200.0])
    expected = flange[:, :3, 3] + flange[:, :3, :3] @ np.array([10.0, -5.0, 200.0])
    np.testing.assert_allclose(tcp[:, :3, 3], expected, atol=1e-9)
    tool_t = np.eye(4)
    tool_t[:3, 3] = [10.0, -5.0, 200.0]
    np.testing.assert_allclose(postproc.fk(robot, q, tool=tool_t), tcp, atol=1e-12)


def test_bad_shapes_raise_typed_errors():
    robot = postproc.load_robot("kr160_r1570")
    with pytest.raises(postproc.KinematicsError, match=r"\(N, 6\)"):
        postproc.fk(robot, np.zeros((3, 5)))
    with pytest.raises(postproc.KinematicsError, match=r"\(N, 4, 4\)"):
        postproc.ik(robot, np.zeros((3, 3, 3)))
    with pytest.raises(postproc.KinematicsError, match="tool"):
        postproc.fk(robot, np.zeros((1, 6)), tool=[1.0, 2.0])
    # neither ortho-parallel (no [opw]) nor of the UR shape (postproc.robot.ur_kinematics): no analytic IK
    skewed = replace(postproc.load_robot("ur10"), alpha_deg=np.array([90.0, 0.0, 0.0, 90.0, 90.0, 0.0]))
    with pytest.raises(postproc.KinematicsError, match="no \\[opw\\] section"):
        postproc.ik(skewed, np.eye(4))


@pytest.mark.parametrize("name", ALL)
def test_jacobian_matches_pinocchio_and_finite_differences(name):
    robot, q, ours, ref = ours_and_pinocchios(name, 40, 4, postproc.jacobian, pin_model.flange_jacobian)
    np.testing.assert_allclose(ours, ref, atol=1e-8)
    # Finite differences of the TCP position, tool included, per radian of controller joint.
    tool = np.array([20.0, 0.0, 150.0])
    jac = postproc.jacobian(robot, q, tool=tool)
    h = 1e-6
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = np.rad2deg(h)
        diff = (postproc.fk(robot, q + dq, tool=tool)[:, :3, 3] - postproc.fk(robot, q - dq, tool=tool)[:, :3, 3]) / (2 * h)
        np.testing.assert_allclose(jac[:, :3, j], diff, atol=1e-5)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("payload", [0.0, 60.0])
def test_gravity_torque_matches_pinocchio(name, payload):
    robot = postproc.load_robot(name)
    com = (15.0, -10.0, 120.0)
    model = pin_model.build_model(robot, payload_kg=payload, payload_com_mm=com)
    data = model.createData()
    q = random_joints(robot, 100, seed=5)
    ours = postproc.gravity_torque(robot, q, payload_kg=payload, payload_com_mm=com)
    ref = np.stack([pin_model.gravity_torque(model, data, qi) for qi in q])
    scale = np.abs(ref).max()
    assert scale > 1.0
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-9 * scale)


def test_gravity_torque_by_hand_kr160_joint2_at_home():
    """At home, every link beyond joint 2 hangs forward of it: gravity tips the arm forward."""
    robot = postproc.load_robot("kr160_r1570")
    rots, origins = kin.joint_frames(robot, np.zeros((1, 6)))
    com = origins[0, 1:] + np.einsum("lij,lj->li", rots[0, 1:], robot.com_mm)
    # Joint 2's axis z1 is -y; r x (0, 0, -m g) has y component m g r_x, so about -y the
    # torque is -sum m g (x_l - x_J2): negative, tipping the arm forward and down.
    lever_m = (com[1:, 0] - origins[0, 1, 0]) / 1000.0
    assert (lever_m >= 0).all() and lever_m.sum() > 0
    expected = -np.sum(robot.mass_kg[1:] * 9.81 * lever_m)
    tau = postproc.gravity_torque(robot, np.zeros((1, 6)))[0]
    assert tau[1] == pytest.approx(expected, rel=1e-12)
    assert abs(tau[0]) < 1e-9  # gravity never turns a vertical axis 1


@pytest.mark.slow
@pytest.mark.parametrize("name", OPW)
def test_fk_ik_fk_round_trip_100k(name):
    robot = postproc.load_robot(name)
    q = random_joints(robot, 100_000, seed=6)
    poses = postproc.fk(robot, q)
    sols = postproc.ik(robot, poses)
    finite = ~np.isnan(sols).any(axis=-1)
    assert finite.any(axis=1).all()
    back = postproc.fk(robot, np.nan_to_num(sols.reshape(-1, 6))).reshape(len(q), 8, 4, 4)
    pos_err = np.abs(back[..., :3, 3] - poses[:, None, :3, 3]).max(axis=-1)
    rot_err = np.abs(back[..., :3, :3] - poses[:, None, :3, :3]).max(axis=(-1, -2))
    assert pos_err[finite].max() < 1e-9
    assert rot_err[finite].max() < 1e-9
    # The original configuration is one of the solutions (modulo whole turns).
    diff = np.abs((sols - q[:, None, :] + 180.0) % 360.0 - 180.0).max(axis=-1)
    assert np.nanmin(diff, axis=1).max() < 1e-7


def _singular_configurations(robot):
    q = random_joints(robot, 60, seed=7, margin=5.0)
    q[:20, 4] = 0.0  # wrist exactly singular
    q[20:40, 4] = np.array([1e-13, -1e-13, 1e-11, -1e-11, 1e-9] * 4)  # nearly singular
    return q


@pytest.mark.parametrize("name", OPW)
def test_near_singular_poses_are_solved_without_nan_or_exception(name):
    robot = postproc.load_robot(name)
    q = _singular_configurations(robot)
    poses = postproc.fk(robot, q)
    sols = postproc.ik(robot, poses)
    chosen, idx = kin.select_nearest(robot, sols, q)
    assert (idx >= 0).all() and not np.isnan(chosen).any()
    back = postproc.fk(robot, chosen)
    np.testing.assert_allclose(back[:, :3, 3], poses[:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(back[:, :3, :3], poses[:, :3, :3], atol=1e-9)


@pytest.mark.parametrize("name", OPW)
def test_shoulder_singularity_and_reach_boundary(name):
    robot = postproc.load_robot(name)
    p = robot.opw
    # Wrist centre exactly on axis 1 (shoulder singularity): any q1 works, the solver must pick one.
    # (With a lateral offset b, the nearest the wrist centre comes to axis 1 is b: there.)
    reach = np.hypot(p.c2 + np.hypot(p.a2, p.c3), 0.0)
    on_axis = np.eye(4)
    on_axis[:3, 3] = [0.0, p.b, p.c1 + 0.6 * reach + p.c4]
    sols = postproc.ik(robot, on_axis)[0]
    finite = ~np.isnan(sols).any(axis=-1)
    assert finite.any()
    back = postproc.fk(robot, sols[finite])
    np.testing.assert_allclose(back[:, :3, 3], np.repeat(on_axis[None, :3, 3], finite.sum(), 0), atol=1e-6)
    np.testing.assert_allclose(back[:, :3, :3], np.repeat(on_axis[None, :3, :3], finite.sum(), 0), atol=1e-9)
    # Out of reach: every branch NaN, no exception.
    far = np.eye(4)
    far[:3, 3] = [5.0 * reach, 0.0, p.c1]
    assert np.isnan(postproc.ik(robot, far)).all()


@pytest.mark.parametrize("name", OPW)
def test_select_nearest_recovers_the_original_configuration(name):
    robot = postproc.load_robot(name)
    q = random_joints(robot, 2000, seed=8, margin=1.0)
    sols = postproc.ik(robot, postproc.fk(robot, q))
    noise = np.random.default_rng(10).uniform(-0.01, 0.01, q.shape)
    chosen, idx = kin.select_nearest(robot, sols, q + noise)
    np.testing.assert_allclose(chosen, q, atol=1e-7)
    assert (idx >= 0).all()


def test_select_nearest_unwraps_turns_inside_wide_limits():
    robot = postproc.load_robot("irb2400_10")  # axis 6 spans +-400 degrees
    q = np.array([[10.0, 5.0, 5.0, 20.0, 40.0, 250.0]])
    sols = postproc.ik(robot, postproc.fk(robot, q))  # reports q6 as -110
    chosen, _ = kin.select_nearest(robot, sols, q)
    np.testing.assert_allclose(chosen, q, atol=1e-7)


def test_select_path_is_continuous_and_flags_unreachable_points():
    robot = postproc.load_robot("kr160_r1570")
    t = np.linspace(0.0, 1.0, 400)
    q = np.column_stack([-30 + 60 * t, 5 + 5 * t, -10 + 0 * t, 170 + 30 * t, 40 + 0 * t, 150 + 100 * t])
    poses = postproc.fk(robot, q)
    poses[200, :3, 3] = [9000.0, 0.0, 0.0]  # one unreachable target
    path, branch, ok = kin.select_path(robot, postproc.ik(robot, poses), q[0])
    assert not ok[200] and np.isnan(path[200]).all()
    keep = np.arange(400) != 200
    np.testing.assert_allclose(path[keep], q[keep], atol=1e-7)
    assert ok[keep].all() and (branch == branch[0]).all()


@pytest.mark.parametrize("name", OPW)
def test_select_by_controller_configuration_round_trip(name):
    robot = postproc.load_robot(name)
    q = random_joints(robot, 1500, seed=9, margin=2.0)
    sols = postproc.ik(robot, postproc.fk(robot, q))
    chosen, idx = kin.select_by_abb_conf(robot, sols, kin.abb_confdata(robot, q))
    np.testing.assert_allclose(chosen, q, atol=1e-7)
    status, turn = kin.kuka_status_turn(robot, q)
    chosen, idx = kin.select_by_kuka_status(robot, sols, status, turn)
    np.testing.assert_allclose(chosen, q, atol=1e-7)


def test_abb_confdata_by_hand():
    robot = postproc.load_robot("irb2400_10")
    q = np.array(
        [
            [0.0, 0.0, 0.0, 0.0, 30.0, 0.0],  # upright, forearm forward: all in front, axis 5 positive
            [0.0, 0.0, 0.0, 0.0, -30.0, 0.0],  # same with axis 5 negative
            [100.0, 0.0, 0.0, -100.0, 30.0, 200.0],  # quadrants 1, -2, 2
            [0.0, -60.0, 0.0, 0.0, 30.0, 0.0],  # arm leant back far: wrist centre behind axis 1
        ]
    )
    conf = kin.abb_confdata(robot, q)
    assert conf[0].tolist() == [0, 0, 0, 0]
    assert conf[1].tolist() == [0, 0, 0, 1]
    assert conf[2].tolist() == [1, -2, 2, 0]
    assert conf[3][3] & 4


def test_kuka_turn_bits_by_hand():
    robot = postproc.load_robot("kr6_r700_sixx")
    _, turn = kin.kuka_status_turn(robot, np.array([[-10.0, -90.0, 90.0, -5.0, 30.0, 10.0]]))
    assert turn[0] == 0b001011  # A1, A2 and A4 negative
