"""postproc: rewrite robot and five-axis toolpaths so the machine cuts where the CAM program says."""

from importlib.metadata import PackageNotFoundError, version

from . import moved

moved.install()  # old module paths (postproc.effects.api, postproc.compensate, ...) stay importable

from postproc.robot import kinematics
from postproc.robot.kinematics import fk, gravity_torque, ik, jacobian
from postproc.robot.robots import RobotModel, available_robots, load_robot

from .errors import InputError, JobError, KinematicsError, PostprocError, RobotFileError, UnknownRobotError

try:
    __version__ = version("postproc")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

__all__ = [
    "InputError",
    "JobError",
    "KinematicsError",
    "PostprocError",
    "RobotFileError",
    "RobotModel",
    "UnknownRobotError",
    "__version__",
    "available_robots",
    "fk",
    "gravity_torque",
    "ik",
    "jacobian",
    "kinematics",
    "load_robot",
    "post",
    "suggest_poses",
]


def __getattr__(name: str):
    # postproc.post and postproc.suggest_poses (issue 32) are resolved on first use: they
    # pull in compensation, the dialects and the program writers (about 1.5 s), which a
    # plain `import postproc` should not pay for.
    if name == "post":
        from postproc.cam.post import post  # lazily: compensation, languages, writers and scipy.optimize load on first use

        return post
    if name == "suggest_poses":
        from postproc.suggest import suggest_poses  # lazily: as post (scipy.optimize, scipy.spatial)

        return suggest_poses
    raise AttributeError(f"module 'postproc' has no attribute {name!r}")
