"""The compensation loop's compiled shortcuts give bit for bit what the generic code gives
(postproc.model.fast_model, kinematics.ik_branch / branch_joints)."""

import numpy as np
import pytest

import postproc
from postproc.model import fast_model
from postproc.model.effects import parse_effects
from postproc.model.sim import random_truth
from postproc.robot import kinematics as kin

ROBOTS = ("kr160_r1570", "irb2400_10", "kr6_r700_sixx")


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a).view(np.int64)


def _joints(robot, n: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(robot.lower_deg, robot.upper_deg, (n, 6))


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("spec", ["geometric,base_frame,tool_offset,joint_compliance", "joint_compliance",
                                  "joint_compliance[payload=12;payload_com=10,-20,80],tool_offset", "geometric,joint_compliance"])
def test_compiled_positions_bit_for_bit(robot_name, spec):
    robot = postproc.load_robot(robot_name)
    model = random_truth(robot, np.array([5.0, -10.0, 200.0]), parse_effects(spec), np.random.default_rng(3))
    q = _joints(robot, 5000)
    generic = model.predict_prepared(model.prepare(q_deg=q))
    fast = fast_model.compiled_positions(model, q)
    assert fast is not None
    assert np.array_equal(_bits(fast), _bits(generic))


@pytest.mark.parametrize("spec", ["geometric,base_frame", "joint_compliance,joint_harmonics[joints=2,3;orders=1,2]", "joint_compliance,thermal",
                                  "joint_compliance,backlash", "joint_compliance,link_bending"])
def test_other_models_take_the_generic_path(spec):
    robot = postproc.load_robot("kr160_r1570")
    model = random_truth(robot, np.array([0.0, 0.0, 200.0]), parse_effects(spec), np.random.default_rng(0))
    assert fast_model.compiled_positions(model, _joints(robot, 10)) is None


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_ik_of_one_branch_bit_for_bit(robot_name):
    robot = postproc.load_robot(robot_name)
    rng = np.random.default_rng(1)
    q = _joints(robot, 20000)
    q[:500, 4] = 0.0  # the wrist singularity
    flange = kin.fk(robot, q)
    flange[:50, 0, 3] += 5000.0  # out of reach: NaN rows
    branch = rng.integers(-1, 8, len(q))
    sols = kin.ik(robot, flange)
    one = kin.ik_branch(robot, flange, np.maximum(branch, 0))
    assert np.array_equal(_bits(one), _bits(sols[np.arange(len(q)), np.maximum(branch, 0)]))
    q_all, b_all = kin.select_branch(robot, sols, branch, q)
    q_one, b_one = kin.branch_joints(robot, flange, branch, q)
    assert np.array_equal(_bits(q_one), _bits(q_all)) and np.array_equal(b_one, b_all)
    assert (b_one != branch).any() and (b_one == branch).any()  # both the shortcut and the fallback ran
