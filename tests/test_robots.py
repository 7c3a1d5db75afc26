"""Robot files: every bundled robot loads; the loader names file and key on every kind of error."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

import postproc
from postproc.errors import RobotFileError, UnknownRobotError
from postproc.robot.robots import parse_robot_toml

REQUIRED = {"kr160_r1570", "irb6660_205_190", "irb2400_10", "kr6_r700_sixx", "ur10", "ur10e", "ur5e"}


def test_all_required_robots_are_bundled_and_valid():
    names = set(postproc.available_robots())
    assert REQUIRED <= names
    for name in names:
        robot = postproc.load_robot(name)
        assert robot.name == name
        assert set(robot.sources) >= {"kinematics", "limits", "masses", "stiffness"}


def test_kr160_home_flange_position():
    robot = postproc.load_robot("kr160_r1570")
    pose = postproc.fk(robot, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(pose[:3, 3], [1175.0, 0.0, 1040.0], atol=1e-9)


def test_kr160_carries_the_seed_stiffness_and_masses():
    robot = postproc.load_robot("kr160_r1570")
    np.testing.assert_array_equal(robot.stiffness_nm_per_rad, np.array([1.75, 1.72, 1.95, 3.73, 2.11, 1.74]) * 1e6)
    np.testing.assert_array_equal(robot.mass_kg, [402, 182, 118, 64, 21, 38])
    assert robot.verified and not robot.estimates["stiffness"]


def test_irb6660_marks_estimates_and_has_coupling_limit():
    robot = postproc.load_robot("irb6660_205_190")
    assert robot.estimates["stiffness"] is True
    assert "estimate" in robot.sources["stiffness"]
    assert len(robot.couplings) == 1
    q = np.zeros((2, 6))
    q[1, 1], q[1, 2] = -40.0, -10.0  # q2 + q3 = -50 violates the coupling
    assert postproc.robot.kinematics.within_limits(robot, q).tolist() == [True, False]


def test_load_by_path(tmp_path):
    text = (resources.files("postproc.robot_files") / "kr6_r700_sixx.toml").read_text()
    path = tmp_path / "kr6_r700_sixx.toml"
    path.write_text(text)
    assert postproc.load_robot(path).name == "kr6_r700_sixx"


def test_unknown_robot_lists_the_bundled_ones():
    with pytest.raises(UnknownRobotError, match="kr160_r1570"):
        postproc.load_robot("kr999")


def _kr160_text() -> str:
    return (resources.files("postproc.robot_files") / "kr160_r1570.toml").read_text()


@pytest.mark.parametrize(
    ("old", "new", "key", "message"),
    [
        ('length = "mm"', 'length = "m"', "units.length", "must be 'mm'"),
        ("d = [500.0, 0.0, 0.0, 710.0, 0.0, 215.0]", "d = [0.5, 0.0, 0.0, 0.71, 0.0, 0.215]", "kinematics.d", "look like metres"),
        ("a = [250.0, 610.0, 70.0, 0.0, 0.0, 0.0]\n", "a = [0.25, 0.61, 0.07, 0.0, 0.0, 0.0]\n", "kinematics.a", "look like metres"),
        ("joint_sign = [1, 1, 1, 1, 1, 1]", "joint_sign = [1, 2, 1, 1, 1, 1]", "kinematics.joint_sign", "+1 or -1"),
        ('name = "kr160_r1570"', 'name = "kr161"', "name", "does not match"),
        ("verified = true", "verified = true\nspeed = 3", "speed", "unknown key"),
        ("k = [1.75e6, 1.72e6, 1.95e6, 3.73e6, 2.11e6, 1.74e6]", "k = [1.75, 1.72, 1.95, 3.73, 2.11, 1.74]", "stiffness.k", "look like"),
        ("k = [1.75e6, 1.72e6, 1.95e6, 3.73e6, 2.11e6, 1.74e6]", "k = [1.75e6, 1.72e6, 1.95e6]", "stiffness.k", "6 numbers"),
        ("a2 = 70.0", "a2 = -70.0", "opw", "does not describe"),
        ("lower = [-185.0,", "lower = [190.0,", "limits.lower", "joint 1"),
        ("mass = [402.0,", 'mass = ["heavy",', "masses.mass[0]", "finite number"),
    ],
)
def test_loader_errors_name_file_and_key(old, new, key, message):
    text = _kr160_text()
    assert old in text
    with pytest.raises(RobotFileError) as info:
        parse_robot_toml(text.replace(old, new, 1), "robots/kr160_r1570.toml")
    assert info.value.key == key
    assert "robots/kr160_r1570.toml" in str(info.value)
    if message:
        assert message in str(info.value)


def test_toml_syntax_error_is_a_robot_file_error():
    with pytest.raises(RobotFileError, match="kr160_r1570.toml"):
        parse_robot_toml(_kr160_text() + "\n[[[", "robots/kr160_r1570.toml")


def test_missing_section_is_named():
    text = _kr160_text()
    start = text.index("[stiffness]")
    with pytest.raises(RobotFileError) as info:
        parse_robot_toml(text[:start], "robots/kr160_r1570.toml")
    assert info.value.key == "stiffness"


def test_model_arrays_are_read_only():
    robot = postproc.load_robot("kr160_r1570")
    with pytest.raises(ValueError):
        robot.d_mm[0] = 1.0
