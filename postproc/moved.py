"""Module paths before the flow layout (0.x, issue 27), kept importable.

The package was reordered into folders that follow a program through it (``programs`` →
``robot`` → ``model`` → ``compensation`` → ``jobs``; ``process``, ``fivex``, ``suggest``,
``report``, ``cam``, ``cli`` beside them). Code written against the old paths — a user's
effect plugin importing ``postproc.effects.api``, a script importing ``postproc.compensate`` —
keeps working: importing an old path returns the module at its new place (the same module
object, so monkeypatching and ``isinstance`` behave as before) and warns once with the new
path. ``postproc.programs`` needs no entry: it is the ``programs`` package, whose face lends
the old module's names.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

# old path below ``postproc.`` -> new path below ``postproc.``; a package moved with all of its modules
MOVED = {
    "ir": "programs.ir",
    "rotation_forms": "programs.rotation_forms",
    "arcs": "programs.arcs",
    "controller": "programs.controller",
    "program_content": "programs.content",
    "workpiece": "programs.workpiece",
    "parse": "programs.parse",
    "dialects": "programs.dialects",
    "emit": "programs.emit",
    "frames": "robot.frames",
    "kinematics": "robot.kinematics",
    "dh": "robot.dh",
    "robots": "robot.robots",
    "pin_model": "robot.pin_model",
    "ur_kinematics": "robot.ur_kinematics",
    "posture": "robot.posture",
    "effects": "model.effects",
    "errormodel": "model.errormodel",
    "fast_model": "model.fast_model",
    "identify": "model.identify",
    "term_selection": "model.term_selection",
    "diagnose": "model.diagnose",
    "candidates": "model.candidates",
    "structure": "model.structure",
    "held_out": "model.held_out",
    "noise_floor": "model.noise_floor",
    "effect_check": "model.effect_check",
    "effect_template": "model.effect_template",
    "learn": "model.learn",
    "model_io": "model.model_io",
    "measurements": "model.measurements",
    "formats": "model.formats",
    "sim": "model.sim",
    "coverage": "model.coverage",
    "coverage_text": "model.coverage_text",
    "validate": "model.validate",
    "plugin_records": "model.plugin_records",
    "predictor_plugins": "model.predictor_plugins",
    "segments": "compensation.segments",
    "compensate": "jobs.compensate",
    "subdivide": "jobs.subdivide",
    "stream": "jobs.stream",
    "batch": "jobs.batch",
    "targets": "jobs.targets",
    "target_file": "jobs.target_file",
    "program_check": "jobs.program_check",
    "convert_conf": "jobs.convert_conf",
    "forces": "process.forces",
    "force_file": "process.force_file",
    "compliance": "process.compliance",
    "engagement": "process.engagement",
    "placement": "process.placement",
    "placement_branch": "process.placement_branch",
    "place_program": "process.place_program",
    "place_report": "process.place_report",
    "fivex.program": "jobs.five_axis.program",
    "fivex.offsets": "jobs.five_axis.offsets",
    "fivex.compensate": "jobs.five_axis.compensate",
    "fivex.emit": "jobs.five_axis.emit",
    "fivex.commands": "jobs.five_axis.commands",
    "plugin_option": "cli.plugin_option",
}


# old paths that stay the documented way in (``postproc.kinematics`` is in ``postproc.__all__``)
STILL_PUBLIC = {"postproc.kinematics"}
_LONGEST_FIRST = sorted(MOVED, key=len, reverse=True)


def new_path(old: str) -> str | None:
    """The new dotted name of an old ``postproc.…`` module, or None if it did not move."""
    rel = old.removeprefix("postproc.")
    for key in _LONGEST_FIRST:
        if rel == key or rel.startswith(key + "."):
            return "postproc." + MOVED[key] + rel[len(key):]
    return None


class _MovedModule(importlib.abc.Loader):
    def __init__(self, target: str):
        self.target = target

    def create_module(self, spec):
        return importlib.import_module(self.target)

    def exec_module(self, module):
        """The module ran at its new path already."""


class MovedFinder(importlib.abc.MetaPathFinder):
    """Maps an old path to its module. It is asked first: an old path names no file of this
    package any more, but a stale copy of the old tree (an old editable install's finder)
    could still answer it."""

    def find_spec(self, fullname, path=None, target=None):
        if not fullname.startswith("postproc."):
            return None
        new = new_path(fullname)
        if new is None:
            return None
        if fullname not in STILL_PUBLIC:
            warnings.warn(f"{fullname} is now {new}", DeprecationWarning, stacklevel=2)
        return importlib.util.spec_from_loader(fullname, _MovedModule(new), is_package=True)


def install() -> None:
    """Add the finder once (``import postproc`` calls this)."""
    if not any(isinstance(finder, MovedFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
