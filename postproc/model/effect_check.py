"""Contract checks for an error effect (``postproc effect check FILE``; the catalog's own tests).

``check_effect`` builds a small model of one effect on a random measurement set with
every column and checks what the rest of postproc relies on: the declaration, the plain
texts (identifiability included), the options spec and the model file round trips,
sane parameters and bounds, zero parameters giving the nominal robot, and the analytic
Jacobian against central finite differences.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass

import numpy as np

from postproc.errors import PostprocError
from postproc.robot.robots import load_robot

from .effects import KINDS, Effect, EffectSum, parse_effects
from .errormodel import ErrorModel
from .measurements import MeasurementSet
from .model_io import model_document, model_from_document

GROUPS = ("force", "approach", "temp", "t")
CONSUMABLE = ("force", "temp")
TOOL_MM = (40.0, -25.0, 180.0)  # off every wrist axis, so that every joint moves the point
JACOBIAN_RTOL = 1e-5


@dataclass(frozen=True)
class Check:
    name: str
    ok: bool
    detail: str


def check_effect(cls: type[Effect], robot_name: str = "kr160_r1570", poses: int = 25, seed: int = 0) -> list[Check]:
    """Every contract check of one effect class; the checks after a failed declaration are skipped."""
    checks = [_declaration(cls), _texts(cls)]
    effect, note = _instance(cls)
    checks.append(Check("instance", effect is not None, note))
    if effect is None or not checks[0].ok:
        return checks
    robot = load_robot(robot_name)
    steps = [_options_round_trip, _parameters, _zero_is_nominal, _jacobian, _model_file_round_trip]
    for step in steps:
        try:
            checks.append(step(effect, robot, _measurements(robot, poses, seed)))
        except (PostprocError, NotImplementedError, ValueError, TypeError, KeyError, IndexError) as exc:
            checks.append(Check(step.__name__.strip("_").replace("_", " "), False, f"{type(exc).__name__}: {exc}"))
    return checks


def _declaration(cls) -> Check:
    problems = []
    if not re.fullmatch(r"[a-z][a-z0-9_]*", cls.name or ""):
        problems.append(f"name '{cls.name}' must be lower case letters, digits and _")
    if cls.kind not in KINDS:
        problems.append(f"kind '{cls.kind}' is not one of {', '.join(KINDS)}")
    problems += [f"needs '{g}' is not one of {', '.join(GROUPS)}" for g in cls.needs if g not in GROUPS]
    problems += [f"consumes '{g}' is not one of {', '.join(CONSUMABLE)}" for g in cls.consumes if g not in CONSUMABLE]
    return Check("declaration", not problems, "; ".join(problems) or f"kind {cls.kind}, needs {', '.join(cls.needs) or 'nothing'}")


def _texts(cls) -> Check:
    texts = {attr: str(getattr(cls, attr, "")).strip() for attr in ("summary", "finding", "identifiability")}
    missing = [attr for attr, text in texts.items() if not text]
    placeholder = [attr for attr, text in texts.items() if "EDIT" in text]  # the template's marker
    problems = ([f"missing: {', '.join(missing)}"] if missing else []) + ([f"still the template's EDIT text: {', '.join(placeholder)}"] if placeholder else [])
    return Check("texts", not problems, "; ".join(problems) or "summary, finding and identifiability given")


def _instance(cls) -> tuple[Effect | None, str]:
    """The effect with its default options (an effect whose terms the fit chooses: its first two)."""
    try:
        effect = cls.from_options({})
        if not effect.resolved:
            effect = effect.with_terms(effect.candidate_terms()[:2])
    except Exception as exc:  # noqa: BLE001 - any failure of the user's constructor is this check's finding
        return None, f"{cls.__name__}.from_options({{}}) failed: {type(exc).__name__}: {exc}"
    return effect, effect.spec()


def _measurements(robot, n: int, seed: int) -> MeasurementSet:
    rng = np.random.default_rng(seed)
    low, high = np.maximum(robot.lower_deg, -150.0), np.minimum(robot.upper_deg, 150.0)
    return MeasurementSet(
        q_deg=rng.uniform(low, high, (n, 6)),
        measured_mm=np.zeros((n, 3)),
        ids=tuple(str(i) for i in range(n)),
        force_n=rng.normal(0, 200, (n, 3)),
        approach=rng.choice([-1.0, 1.0], (n, 6)),
        temp_c=rng.uniform(18, 30, n),
        time_s=np.arange(n) * 30.0,
    )


def _options_round_trip(effect: Effect, robot, meas) -> Check:
    again = parse_effects(effect.spec()).effects[0]
    same = type(again) is type(effect) and again.spec() == effect.spec() and again.options() == effect.options()
    return Check("options round trip", same, effect.spec() if same else f"'{effect.spec()}' reads back as '{again.spec()}'")


def _parameters(effect: Effect, robot, meas) -> Check:
    params = effect.params(robot)
    problems = [] if params else ["no parameters"]
    names = [p.name for p in params]
    if len(set(names)) != len(names):
        problems.append("parameter names repeat")
    for p in params:
        if not p.unit or not (np.isfinite(p.scale) and p.scale > 0 and np.isfinite(p.typical) and p.typical > 0):
            problems.append(f"{p.name}: needs a unit, and a finite positive scale and typical")
        if not (p.lower < p.upper and p.lower <= p.initial <= p.upper):
            problems.append(f"{p.name}: bounds must hold the initial value ({p.lower} <= {p.initial} <= {p.upper})")
    rng = np.random.default_rng(0)
    draws = np.array([[effect.draw(p, rng, 1.0) for _ in range(50)] for p in params]).reshape(len(params), -1)
    if not np.isfinite(draws).all():
        problems.append("draw() gives a value that is not finite")
    lower, upper = np.array([[p.lower] for p in params]), np.array([[p.upper] for p in params])
    outside = float(((draws < lower) | (draws > upper)).mean()) if params else 0.0
    # Not a failure: the simulator clips a drawn true value into the bounds. Said, because
    # a true robot then often sits on a bound (e.g. a one-sided draw would fit better).
    note = f"; note: {outside:.0%} of draw()'s values fall outside the bounds (the simulator clips them)" if outside > 0.05 else ""
    return Check("parameters and bounds", not problems, "; ".join(problems) or f"{len(params)} parameter(s): {', '.join(names)}{note}")


def _zero_is_nominal(effect: Effect, robot, meas) -> Check:
    model = ErrorModel.create(robot, TOOL_MM, EffectSum((effect,)))
    moved = model.predict_prepared(model.prepare(meas), np.zeros(len(model.params)))
    nominal = ErrorModel.create(robot, TOOL_MM, EffectSum()).predict(meas)
    worst = float(np.abs(moved - nominal).max())
    return Check("zero parameters = nominal robot", worst < 1e-9, f"largest difference {worst:.3g} mm")


def _values(model: ErrorModel, effect: Effect, seed: int) -> np.ndarray:
    """Parameter values a little off the initial ones, inside the bounds (base frames at
    zero: their small-angle derivative is exact there)."""
    if effect.kind == "base":
        return np.zeros(len(model.params))
    rng = np.random.default_rng(seed)
    values = np.array([p.initial + 0.5 * p.typical * rng.standard_normal() for p in model.params])
    return np.clip(values, [p.lower for p in model.params], [p.upper for p in model.params])


def _jacobian(effect: Effect, robot, meas) -> Check:
    model = ErrorModel.create(robot, TOOL_MM, EffectSum((effect,)))
    prep = model.prepare(meas)
    values = _values(model, effect, 1)
    _, jac = model.evaluate(prep, values)
    worst, where = 0.0, "-"
    for k, p in enumerate(model.params):
        h = p.scale * 1e-3
        up, down = values.copy(), values.copy()
        up[k] += h
        down[k] -= h
        fd = (model.predict_prepared(prep, up) - model.predict_prepared(prep, down)) / (2 * h)
        scale = max(np.abs(fd).max(), np.abs(jac[:, :, k]).max())
        if scale < 1e-9:
            continue  # the parameter does not move this point (e.g. a joint-6 term on the axis)
        error = float(np.abs(fd - jac[:, :, k]).max() / scale)
        if error > worst:
            worst, where = error, p.name
    return Check("analytic Jacobian = finite differences", worst < JACOBIAN_RTOL, f"largest relative difference {worst:.2g} ({where})")


def _model_file_round_trip(effect: Effect, robot, meas) -> Check:
    model = ErrorModel.create(robot, TOOL_MM, EffectSum((effect,)))
    model = model.with_vector(_values(model, effect, 2))
    doc = json.loads(json.dumps(model_document(model)))
    again = model_from_document(doc, "<round trip>")
    diff = float(np.abs(again.predict(meas) - model.predict(meas)).max())
    same = again.effects.spec() == model.effects.spec() and np.array_equal(again.values, model.values) and diff == 0.0
    return Check("model file round trip", same, f"spec {again.effects.spec()}, predictions differ by {diff:.3g} mm")
