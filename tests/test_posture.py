"""The controller's posture carried along a path (postproc.robot.posture): joint targets and
applicable configuration data set it, every other target keeps the branch it is in."""

from __future__ import annotations

import numpy as np
import pytest

from postproc import load_robot
from postproc.robot import kinematics as kin
from postproc.robot.posture import branch_of, carry


@pytest.fixture(scope="module")
def robot():
    return load_robot("kr160_r1570")


def _path(q0, step, n):
    return np.asarray(q0, float) + np.arange(n)[:, None] * np.asarray(step, float)


def _sols(robot, q):
    return kin.ik(robot, kin.fk(robot, q))


def test_a_joint_target_sets_the_wrist_flipped_posture(robot):
    """The issue's pocket: the first PTP puts the wrist flipped (A4 = 180, A5 = 80); the LIN
    targets after it must stay on that branch, not the one nearest all-zero joints."""
    q = _path([10.0, -60.0, 40.0, 180.0, 80.0, 30.0], [0.4, 0.2, -0.3, 0.1, 0.2, 0.5], 40)
    anchor = np.zeros(40, bool)
    anchor[0] = True
    anchor_q = np.full((40, 6), np.nan)
    anchor_q[0] = q[0]
    got = carry(robot, _sols(robot, q), anchor, anchor_q)
    assert got.ok.all()
    np.testing.assert_allclose(got.q, q, atol=1e-6)
    assert (got.branch == branch_of(robot, q[:1])[0]).all()
    assert got.notes == ()
    # what the old rule (nearest all-zero joints) picks is another branch for this pocket
    nearest, _ = kin.select_nearest(robot, _sols(robot, q[:1]), np.zeros(6))
    assert np.abs(nearest[0] - q[0]).max() > 90


def test_configuration_data_switch_branch_mid_path(robot):
    q_a = _path([0.0, -60.0, 40.0, 20.0, 40.0, 10.0], [0.5, 0, 0, 0, 0, 0], 10)
    q_b = _path([5.0, -60.0, 40.0, 200.0, -40.0, 190.0], [0.5, 0, 0, 0, 0, 0], 10)
    q_b[:, 3] -= 360.0  # A4 within +-350
    q = np.vstack([q_a, q_b])
    anchor = np.zeros(20, bool)
    anchor[[0, 10]] = True
    anchor_q = np.where(anchor[:, None], q, np.nan)
    got = carry(robot, _sols(robot, q), anchor, anchor_q)
    assert got.ok.all()
    np.testing.assert_allclose(got.q, q, atol=1e-6)
    assert got.set_by[9] == 0 and got.set_by[10] == 10 and got.set_by[19] == 10
    assert got.branch[0] != got.branch[10]


def test_turns_unwrap_along_the_path(robot):
    """A6 passes 180 deg: the carried joints keep counting (range +-350), no jump back."""
    q = _path([0.0, -60.0, 40.0, 0.0, 45.0, 170.0], [0, 0, 0, 0, 0, 1.0], 25)
    anchor = np.zeros(25, bool)
    anchor[0] = True
    got = carry(robot, _sols(robot, q), anchor, np.where(anchor[:, None], q, np.nan))
    np.testing.assert_allclose(got.q[:, 5], q[:, 5], atol=1e-6)
    assert got.q[-1, 5] > 190


def test_start_joints_given_and_unknown_start_is_noted(robot):
    q = _path([0.0, -60.0, 40.0, 180.0, 60.0, 0.0], [0.3, 0, 0, 0, 0, 0], 5)
    none = np.zeros(5, bool)
    nan = np.full((5, 6), np.nan)
    told = carry(robot, _sols(robot, q), none, nan, start_q=q[0])
    np.testing.assert_allclose(told.q, q, atol=1e-6)
    assert told.notes == () and (told.set_by == -1).all()
    guessed = carry(robot, _sols(robot, q), none, nan, lines=np.arange(10, 15))
    assert guessed.notes and "--start-joints" in guessed.notes[0] and "lines 10-14" in guessed.notes[0]


def test_a_flip_between_targets_is_not_ok(robot):
    """Through the wrist singularity the carried branch flips A4/A6 by ~180 deg: flagged."""
    q = _path([0.0, -60.0, 40.0, 30.0, 6.0, 0.0], [0, 0, 0, 0, -1.0, 0], 12)  # A5 crosses 0
    anchor = np.zeros(12, bool)
    anchor[0] = True
    got = carry(robot, _sols(robot, q), anchor, np.where(anchor[:, None], q, np.nan))
    assert not got.ok.all()


def _flanges(robot, q):
    return kin.fk(robot, q)


def test_straight_segments_between_good_targets_pass(robot):
    from postproc.robot.posture import check_linear_segments

    q = _path([0.0, -60.0, 40.0, 20.0, 40.0, 10.0], [1.0, 0.5, -0.5, 0.5, 0.5, 1.0], 6)
    f = _flanges(robot, q)
    reason = check_linear_segments(robot, f[:-1], f[1:], branch_of(robot, q[1:]), q[:-1])
    assert (reason == 0).all()


def test_a_segment_through_the_wrist_singularity_is_flagged(robot):
    """A5 = +5 then -5: both end points are reachable, the straight line between them passes
    A5 = 0 (on the carried branch the wrist flips there)."""
    from postproc.robot.posture import check_linear_segments

    a = np.array([[0.0, -60.0, 40.0, 30.0, 5.0, 0.0]])
    b = np.array([[0.0, -60.0, 40.0, 30.0, -5.0, 0.0]])
    reason = check_linear_segments(robot, _flanges(robot, a), _flanges(robot, b), branch_of(robot, a), a)
    assert reason[0] in (2, 3)


def test_interpolation_hits_both_ends(robot):
    from postproc.robot.posture import interpolate_poses

    q = _path([0.0, -60.0, 40.0, 20.0, 40.0, 10.0], [10.0, 5.0, -5.0, 30.0, 20.0, 40.0], 2)
    f = _flanges(robot, q)
    poses = interpolate_poses(f[:1], f[1:], np.array([0.0, 0.5, 1.0]))
    np.testing.assert_allclose(poses[0, 0], f[0], atol=1e-9)
    np.testing.assert_allclose(poses[0, 2], f[1], atol=1e-9)
    np.testing.assert_allclose(poses[0, 1, :3, 3], (f[0, :3, 3] + f[1, :3, 3]) / 2, atol=1e-9)
