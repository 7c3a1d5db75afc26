"""Pre-compensation of a program, the public entry (see ``postproc.compensation.core``).

The core imports no language: it asks the controller object it is given for the rules it
needs (a ``postproc.controller.Controller``: ``conf_applies``, ``branch_from_conf``,
``inexact_interpolation``, ``arc_ends_at_target``). This module, on the floor of the programs,
gives it the controller of the language the toolpath was read in (``Dialect.controller`` of
``Toolpath.dialect``) where the caller names none, so ``compensate(tp, model)`` works as it always has.
"""

from __future__ import annotations

from . import dialects
from .compensation import core
from .compensation.core import (  # noqa: F401  (the names callers take from here)
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
from .errormodel import ErrorModel
from .ir import Toolpath


def compensate(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> tuple[Toolpath, Report]:
    """``core.compensate`` (its options) by ``controller``'s rules, by default those of the
    language ``tp`` was read in."""
    return core.compensate(tp, model, controller=dialects.of(tp).controller if controller is None else controller, **options)


def predicted_positions(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> tuple:
    """``core.predicted_positions`` by ``controller``'s rules, by default those of ``tp``'s language."""
    return core.predicted_positions(tp, model, controller=dialects.of(tp).controller if controller is None else controller, **options)


def reference_postures(tp: Toolpath, model: ErrorModel, *, controller=None, **options) -> Reference:
    """``core.reference_postures`` by ``controller``'s rules, by default those of ``tp``'s language."""
    return core.reference_postures(tp, model, controller=dialects.of(tp).controller if controller is None else controller, **options)
