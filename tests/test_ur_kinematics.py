"""Analytic inverse kinematics of UR arms (postproc.robot.ur_kinematics), checked against the DH
forward kinematics: every branch reproduces the pose, the joints it came from are among them."""

from __future__ import annotations

import numpy as np
import pytest

import postproc
from postproc.robot import kinematics as kin
from postproc.robot import posture
from postproc.robot import ur_kinematics as ur


@pytest.mark.parametrize("name", ["ur10e", "ur5e", "ur10"])
def test_every_solution_reaches_the_pose_and_the_source_joints_are_found(name):
    robot = postproc.load_robot(name)
    assert ur.is_ur_geometry(robot) and robot.has_analytic_ik
    q = np.random.default_rng(3).uniform(-180.0, 180.0, (500, 6))
    poses = kin.fk(robot, q)
    sols = kin.ik(robot, poses)
    solved = ~np.isnan(sols).any(axis=2)
    assert solved.sum(axis=1).min() >= 2
    reached = kin.fk(robot, np.nan_to_num(sols.reshape(-1, 6))).reshape(len(q), 8, 4, 4)
    error = np.abs(reached - poses[:, None]).max(axis=(2, 3))
    assert np.where(solved, error, 0.0).max() < 1e-6
    distance = np.abs((sols - q[:, None] + 180.0) % 360.0 - 180.0).max(axis=2)
    assert (np.nanmin(distance, axis=1) < 1e-6).all()


def test_one_branch_is_the_same_as_all_branches():
    robot = postproc.load_robot("ur10e")
    poses = kin.fk(robot, np.random.default_rng(4).uniform(-150.0, 150.0, (50, 6)))
    branch = np.arange(50) % 8
    np.testing.assert_array_equal(kin.ik_branch(robot, poses, branch), kin.ik(robot, poses)[np.arange(50), branch])


def test_the_branch_of_joints_is_the_branch_that_reproduces_them():
    robot = postproc.load_robot("ur5e")
    q = np.array([[10.0, -80.0, 100.0, -110.0, -90.0, 30.0], [-40.0, -100.0, -70.0, -20.0, 60.0, 0.0]])
    b = posture.branch_of(robot, q)
    np.testing.assert_allclose(kin.ik(robot, kin.fk(robot, q))[np.arange(2), b], q, atol=1e-8)


def test_singularity_margins_of_a_ur_arm():
    robot = postproc.load_robot("ur10e")
    wrist, elbow, shoulder = posture.singularity_margins(robot, np.array([[0.0, -90.0, 0.0, -90.0, 0.0, 0.0], [0.0, -90.0, 90.0, -90.0, 90.0, 0.0]]))
    np.testing.assert_allclose(wrist, [0.0, 90.0], atol=1e-9)
    np.testing.assert_allclose(elbow, [0.0, 90.0], atol=1e-9)
    assert shoulder[1] > 100.0


@pytest.mark.parametrize("name, d1, a2, a3, d4, d5, d6", [
    ("ur10e", 0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),  # Universal Robots' DH page, UR10e
    ("ur5e", 0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),  # the same page, UR5e
])
def test_the_robot_files_hold_the_published_dh_and_their_zero_pose(name, d1, a2, a3, d4, d5, d6):
    """At all-zero joints a UR arm lies stretched along -x: the flange at (a2 + a3, -(d4 + d6),
    d1 - d5), its z axis along -y (the published table's geometry, worked out by hand)."""
    robot = postproc.load_robot(name)
    np.testing.assert_allclose(robot.d_mm, np.array([d1, 0, 0, d4, d5, d6]) * 1000.0)
    np.testing.assert_allclose(robot.a_mm, np.array([0, a2, a3, 0, 0, 0]) * 1000.0)
    pose = kin.fk(robot, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(pose[:3, 3], np.array([a2 + a3, -(d4 + d6), d1 - d5]) * 1000.0, atol=1e-9)
    np.testing.assert_allclose(pose[:3, 2], [0, -1, 0], atol=1e-12)
    assert robot.estimates["stiffness"] and robot.sources["kinematics"].startswith("Universal Robots")
