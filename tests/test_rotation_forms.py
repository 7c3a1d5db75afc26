"""The table of orientation notations (postproc.programs.rotation_forms) and Toolpath.extras."""

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.programs import rotation_forms
from postproc.programs.parse.common import Builder
from postproc.robot.frames import abc_to_matrix, matrix_to_quat_wxyz


@pytest.mark.parametrize("name", ["quat", "abc", "wpr"])
def test_numbers_read_back_as_the_same_rotation(name):
    notation = rotation_forms.form(name)
    rot = abc_to_matrix(np.array([[10.0, 20.0, 30.0], [-170.0, 89.0, 5.0], [179.0, -45.0, -179.5]]))
    numbers = notation.numbers_from_matrix(rot)
    assert np.allclose(notation.to_matrix(numbers), rot, atol=1e-12)
    assert np.allclose(np.abs(np.einsum("ij,ij->i", notation.quaternions(numbers), matrix_to_quat_wxyz(rot))), 1.0)


def test_abc_spelled_near_the_numbers_the_program_wrote():
    notation = rotation_forms.form("abc")
    near = np.array([[179.9, 0.0, 180.0]])  # a KUKA program's A 179.9, C 180: written as such, not -180.1 / -180
    rot = abc_to_matrix(np.array([[-179.95, 0.0, -180.0]]))
    assert np.allclose(notation.numbers_from_matrix(rot, near), [[180.05, 0.0, 180.0]])
    other = np.array([[0.0, 170.0, 0.0]])  # the other triple of one rotation (B and 180 - B)
    assert np.allclose(notation.numbers_from_matrix(abc_to_matrix(other), other), other)


def test_quaternion_kept_exactly_and_its_sign_follows_the_text():
    notation = rotation_forms.form("quat")
    q = np.array([[0.5, 0.5, -0.5, 0.5]])
    assert np.array_equal(notation.numbers(q), q)
    assert np.array_equal(notation.numbers(q, near=-q), -q)


def test_axis_gives_no_rotation_and_an_unknown_name_is_refused():
    assert np.isnan(rotation_forms.form("axis").quaternions(np.array([[0.0, 0.0, 1.0]]))).all()
    with pytest.raises(InputError, match="not one of"):
        rotation_forms.form("wxyz")


def test_a_language_column_lives_in_extras_and_take_slices_it():
    builder = Builder("test", "abc", [])
    builder.declare_extra("test.blend", float, np.nan)
    builder.add_block(np.array([0, 1, 2]), **{"test.blend": np.array([1.0, 2.0, 3.0])})
    builder.add_block(np.array([3]))
    tp = builder.build()
    assert np.array_equal(tp.extras["test.blend"], [1.0, 2.0, 3.0, np.nan], equal_nan=True)
    assert np.array_equal(tp.take([3, 1]).extras["test.blend"], [np.nan, 2.0], equal_nan=True)
