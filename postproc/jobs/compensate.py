"""Pre-compensation of a program, the public entry (see ``postproc.compensation.core``).

``compensate_with(request, tp)`` compensates a parsed program as a ``CompensationRequest``
asks (its robot model, solver options, frames, tools and process forces).
``compensate(tp, model, **options)`` is the older keyword form: it builds the request.

The core imports no language: it asks the controller object it is given for the rules it
needs (a ``postproc.programs.controller.Controller``: ``conf_applies``, ``branch_from_conf``,
``inexact_interpolation``, ``arc_ends_at_target``). This module, on the floor of the programs,
gives it the controller of the language the toolpath was read in (``Dialect.controller`` of
``Toolpath.dialect``) where the caller names none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postproc.compensation import core
from postproc.compensation.core import (  # noqa: F401  (the names callers take from here)
    PATH_MIN_LENGTH_MM,
    PATH_TOLERANCE_MM,
    POSTURE_CONF,
    POSTURE_PATH,
    CompensationError,
    PathDetail,
    Reference,
    Report,
    _refuse_unplaced,
    check_inputs,
)
from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.model.errormodel import ErrorModel
from postproc.process.force_file import base_frame_forces, read_force_file
from postproc.process.forces import load_cut_params, program_forces
from postproc.programs import dialects
from postproc.programs.ir import Toolpath

from .targets import RobotTarget

# compensate()'s keywords that are not the request's: how this one call runs.
RUN_OPTIONS = ("progress", "reference", "detail")


@dataclass(frozen=True)
class ProcessForces:
    """The process force of every target (N, 3, N in the base frame; None: no per-target
    force) and what the user should know about it."""

    per_target: np.ndarray | None
    notes: tuple[str, ...] = ()


def request_for(model: ErrorModel, **options) -> CompensationRequest:
    """The request of ``compensate(tp, model, **options)``'s keyword form."""
    force_n, start = options.pop("force_n", None), options.pop("start_joints", None)
    return CompensationRequest(RobotTarget(model), force_n=None if force_n is None else tuple(np.ravel(force_n).tolist()),
                               start_joints=None if start is None else tuple(np.ravel(start).tolist()),
                               frames=options.pop("frames", None) or {}, tools=options.pop("tools", None) or {}, **options)


def process_forces(request: CompensationRequest, tp: Toolpath) -> ProcessForces:
    """The per-target forces the request gives: its own array, a force file's rows, or the
    cut's milling force (a constant ``force_n`` is the core's to turn, target by target)."""
    if request.force_per_target is not None:
        return ProcessForces(np.asarray(request.force_per_target, dtype=float))
    if request.force_file is None and request.cut is None:
        return ProcessForces(None)
    placed = tp.with_frames(dict(request.frames), dict(request.tools)) if (request.frames or request.tools) else tp
    if request.cut is not None:
        return ProcessForces(program_forces(placed, params=load_cut_params(request.cut)))
    tool_frame, unlisted = read_force_file(request.force_file, tp)
    notes = (f"{unlisted} Cartesian target(s) have no row in {request.force_file}: no process force there",) if unlisted else ()
    return ProcessForces(base_frame_forces(placed, tool_frame), notes)


def compensate_with(request: CompensationRequest, tp: Toolpath, *, controller=None, forces: ProcessForces | None = None,
                    **run) -> tuple[Toolpath, Report]:
    """``tp`` compensated as ``request`` asks, by ``controller``'s rules (default: those of the
    language ``tp`` was read in). ``forces``: ``process_forces(request, tp)`` where the caller
    has it already; ``run``: ``progress``, ``reference``, ``detail`` (``core.compensate``)."""
    forces = process_forces(request, tp) if forces is None else forces
    model = _error_model(request)
    return core.compensate(with_robot(tp, model), model, controller=dialects.of(tp).controller if controller is None else controller,
                           force_per_target=forces.per_target, **request.solver_options(), **run)


def compensate(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> tuple[Toolpath, Report]:
    """``compensate_with`` of the request ``options`` describe (``core.compensate``'s keywords)."""
    run = {key: options.pop(key) for key in RUN_OPTIONS if key in options}
    return compensate_with(request_for(model, **options), tp, controller=controller, **run)


def predicted_positions(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> tuple:
    """``core.predicted_positions`` by ``controller``'s rules, by default those of ``tp``'s language."""
    return core.predicted_positions(with_robot(tp, model), model, controller=dialects.of(tp).controller if controller is None else controller, **options)


def reference_postures(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> Reference:
    """``core.reference_postures`` by ``controller``'s rules, by default those of ``tp``'s language."""
    return core.reference_postures(with_robot(tp, model), model, controller=dialects.of(tp).controller if controller is None else controller, **options)


def with_robot(tp: Toolpath, model: ErrorModel) -> Toolpath:
    """``tp`` with what the model's robot data determine filled in (``Dialect.with_robot``:
    INFORM's pulse positions placed with the robot file's pulse data)."""
    return dialects.of(tp).with_robot(tp, model.robot)


def _error_model(request: CompensationRequest) -> ErrorModel:
    """The robot's error model; a five-axis machine is compensated by ``postproc.fivex``."""
    model = getattr(request.machine, "model", None)
    if not isinstance(model, ErrorModel):
        raise InputError(f"{request.machine.source}: a {request.machine.kind}, not a robot error model: "
                              "five-axis programs are compensated by postproc.fivex")
    return model
