"""postproc: rewrite robot and five-axis toolpaths so the machine cuts where the CAM program says."""

from importlib.metadata import PackageNotFoundError, version

from . import kinematics
from .cam.post import post
from .errors import InputError, JobError, KinematicsError, PostprocError, RobotFileError, UnknownRobotError
from .kinematics import fk, gravity_torque, ik, jacobian
from .robots import RobotModel, available_robots, load_robot

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
]
