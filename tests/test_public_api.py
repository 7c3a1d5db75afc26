"""The public API survives the flow layout (issue 27): the top-level names, the documented
module paths, and every old module path (postproc.moved) as the same module object."""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings

import pytest

import postproc
from postproc.moved import MOVED, new_path

TOP_LEVEL = ["fk", "ik", "jacobian", "gravity_torque", "kinematics", "load_robot", "available_robots", "RobotModel",
             "post", "suggest_poses", "InputError", "JobError", "KinematicsError", "PostprocError", "RobotFileError",
             "UnknownRobotError", "__version__"]


@pytest.mark.parametrize("name", TOP_LEVEL)
def test_top_level_names(name):
    assert getattr(postproc, name) is not None


def test_every_old_module_path_is_the_new_module():
    for old in sorted(MOVED):
        new = "postproc." + MOVED[old]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            assert importlib.import_module(f"postproc.{old}") is importlib.import_module(new), old


def test_an_old_path_warns_with_the_new_one():
    # a fresh interpreter: this process may have imported the old path already
    code = ("import warnings; warnings.simplefilter('error')\n"
            "try:\n    import postproc.effects.api\nexcept DeprecationWarning as w:\n    print(w)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "postproc.effects is now postproc.model.effects" in out


def test_a_plugin_written_against_the_old_path_still_subclasses_the_same_base():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from postproc.effects.api import Effect as OldEffect
    from postproc.model.effects.api import Effect
    assert OldEffect is Effect


def test_programs_lends_its_old_names_and_loads_no_language_for_the_ir():
    from postproc.programs import parse_program, write_program  # the old postproc.programs module's names
    assert parse_program.__module__ == write_program.__module__ == "postproc.programs.program_io"
    code = "import sys, postproc.programs.ir; print(any(m.startswith('postproc.programs.dialects') for m in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"
    with pytest.raises(AttributeError):
        postproc.programs.no_such_name  # noqa: B018


def test_new_path_leaves_new_names_alone():
    assert new_path("postproc.robot.kinematics") is None
    assert new_path("postproc.programs.parse.common") is None
    assert new_path("postproc.parse.common") == "postproc.programs.parse.common"
    assert new_path("postproc.fivex.machine") is None
    assert new_path("postproc.fivex.commands") == "postproc.jobs.five_axis.commands"


def test_programs_lends_exactly_the_public_functions_of_program_io():
    import inspect

    from postproc.programs import LENT, program_io
    public = {name for name, f in inspect.getmembers(program_io, inspect.isfunction) if f.__module__ == program_io.__name__ and not name.startswith("_")}
    assert LENT == public
