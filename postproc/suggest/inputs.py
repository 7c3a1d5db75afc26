"""What a suggest-poses job designs for: the model (effects at nominal or fitted values)
and the tracker, from the command line's parts."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from postproc.errors import InputError
from postproc.model.effects import EffectSum
from postproc.model.errormodel import ErrorModel

from .candidates import Tracker


def design_model(robot, tool_mm, effects: EffectSum | None, fitted: ErrorModel | None) -> ErrorModel:
    """The model whose identification the design serves: ``effects`` (default: the fitted
    model's) with the fitted model's values and registration where it has them, else nominal."""
    if fitted is None:
        if effects is None:
            raise InputError("suggest-poses needs --effects (or --model MODEL.json)")
        _require_terms(effects)
        return ErrorModel.create(robot, tool_mm, effects)
    if robot.name != fitted.robot.name:
        raise InputError(f"--robot {robot.name} does not match the model's robot {fitted.robot.name}")
    chosen = fitted.effects if effects is None else effects
    _require_terms(chosen)
    model = ErrorModel.create(robot, tool_mm, chosen, fitted.as_dict())
    return replace(model, base_rotation=fitted.base_rotation, base_translation=fitted.base_translation)


def _require_terms(effects: EffectSum) -> None:
    """A design serves named parameters: an effect whose terms fit chooses from the data
    (e.g. joint_harmonics[max_order=60]) has none yet, so the user names them."""
    for effect in effects:
        if not effect.resolved:
            raise InputError(f"--effects: {effect.spec()} leaves its terms to fit, which chooses them from measurements; suggest-poses designs "
                             f"for named terms: give them (e.g. {effect.name}[terms=2:17,1:17,3:17]) or --model MODEL.json of a fit that chose them")


def tracker_from(position_mm: np.ndarray | None, range_mm: tuple[float, float] | None, cone_deg: float | None) -> Tracker | None:
    """A Tracker from --tracker X,Y,Z [--tracker-range MIN:MAX] [--tracker-cone DEG], or None without a position."""
    if position_mm is None:
        if range_mm is not None or cone_deg is not None:
            raise InputError("--tracker-range and --tracker-cone need the tracker's position (--tracker X,Y,Z, robot base frame, mm)")
        return None
    if range_mm is not None and not 0 <= range_mm[0] < range_mm[1]:
        raise InputError(f"--tracker-range: {range_mm[0]:g}:{range_mm[1]:g} must be MIN:MAX with 0 <= MIN < MAX (mm)")
    if cone_deg is not None and not 0 < cone_deg <= 180:
        raise InputError(f"--tracker-cone: {cone_deg:g} must be a half-angle in (0, 180] degrees")
    base = Tracker(np.asarray(position_mm, dtype=float))
    return replace(base, range_mm=base.range_mm if range_mm is None else tuple(range_mm), cone_deg=cone_deg)
