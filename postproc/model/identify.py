"""Identification: nonlinear least squares over the union of effect parameters.

1. Parameters the data cannot separate are found by a column-pivoted QR of the scaled
   identification Jacobian, fixed at their initial value, and reported with the kept
   parameters that absorb them.
2. The rest are fitted by scipy's least squares with the analytic Jacobian, parameter
   scaling, and an optional robust loss; outliers are flagged either way.
3. Standard errors from the Jacobian at the solution; k-fold cross-validated RMS.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field, replace
from dataclasses import replace as _replace
from types import SimpleNamespace
from typing import Callable

import numpy as np
from scipy.linalg import qr
from scipy.optimize import least_squares

from postproc.errors import IdentificationError
from postproc.robot.frames import kabsch
from postproc.robot.robots import RobotModel
from postproc.threads import small_matrices

from .coverage import Coverage
from .effects import Effect, EffectSum, catalog_of_kind
from .errormodel import ErrorModel, Prepared
from .harmonic_scan import Residual, choose_terms
from .measurements import MeasurementSet
from .noise_model import NoiseRatios, checked, settle_place
from .path_history import path_travel_mm
from .predictor_plugins import PREDICTORS
from .term_selection import select_terms as best_subset
from .term_selection import term_labels

RANK_TOL = 1e-7
OUTLIER_SIGMAS = 4.0  # per-pose 3-D residual beyond 4 robust sigmas (chi, 3 dof: p < 0.2 %)


@dataclass(frozen=True)
class Stats:
    n: int
    rms_mm: float
    mean_mm: float
    max_mm: float
    rms_axis_mm: tuple[float, float, float]

    @classmethod
    def of(cls, residual: np.ndarray) -> "Stats":
        norm = np.linalg.norm(residual, axis=1)
        return cls(
            n=len(norm),
            rms_mm=float(np.sqrt(np.mean(norm**2))),
            mean_mm=float(norm.mean()),
            max_mm=float(norm.max()),
            rms_axis_mm=tuple(float(v) for v in np.sqrt(np.mean(residual**2, axis=0))),
        )

    def as_dict(self) -> dict:
        return {"n": self.n, "rms_mm": self.rms_mm, "mean_mm": self.mean_mm, "max_mm": self.max_mm, "rms_axis_mm": list(self.rms_axis_mm)}


@dataclass(frozen=True)
class FitResult:
    model: ErrorModel
    std: dict[str, float]
    fixed: dict[str, str]  # parameter -> why it was not identified
    outliers: tuple[str, ...]  # ids of flagged poses
    before: Stats
    after: Stats
    cv_rms_mm: float | None
    approach_inferred: bool
    notes: tuple[str, ...] = field(default_factory=tuple)


def residuals(model: ErrorModel, meas: MeasurementSet, prep: Prepared | None = None) -> np.ndarray:
    prep = model.prepare(meas) if prep is None else prep
    return model.predict_prepared(prep) - meas.measured_mm


def _base_indices(model: ErrorModel) -> np.ndarray:
    """Indices of the parameters of the model's base-frame effect(s)."""
    idx = [model.indices_of(e) for e in model.effects.of_kind("base")]
    return np.concatenate(idx) if idx else np.zeros(0, dtype=int)


def register_base(model: ErrorModel, meas: MeasurementSet, prep: Prepared) -> ErrorModel:
    """Closed-form initial base frame (Kabsch) from the current model's positions to the measured ones."""
    unregistered = replace(model, base_rotation=np.eye(3), base_translation=np.zeros(3))
    values = unregistered.values.copy()
    values[_base_indices(model)] = 0.0
    robot_frame = unregistered.predict_prepared(prep, values)
    rot, trans = kabsch(robot_frame, meas.measured_mm)
    return replace(unregistered, values=values, base_rotation=rot, base_translation=trans)


def identifiability(model: ErrorModel, prep: Prepared, free_mask: np.ndarray) -> tuple[np.ndarray, dict[str, str]]:
    """Which parameters the data can separate. Returns the new free mask and, for each
    parameter fixed here, the reason (with the kept parameters that absorb it).

    Columns of the scaled identification Jacobian are normalised and taken in a fixed
    priority order (each effect's ``keep_priority``: frames first, as they absorb the DH
    errors they duplicate, then joint-space effects, then DH errors); a parameter is kept
    when its column adds a direction the earlier ones do not span (|R_kk| of an unpivoted
    QR above RANK_TOL). The choice is deterministic: it never flips between fits of similar data.
    """
    _, jac = model.evaluate(prep)
    j = jac.reshape(jac.shape[0] * 3, jac.shape[-1]) * np.array([p.scale for p in model.params])
    priority = {p.name: model.owner(p.name).keep_priority(p.name) for p in model.params}
    cols = np.nonzero(free_mask)[0]
    cols = np.array(sorted(cols, key=lambda c: priority[model.params[c].name]), dtype=int)
    sub = j[:, cols]
    norms = np.linalg.norm(sub, axis=0)
    fixed: dict[str, str] = {}
    nonzero = norms > 1e-12 * max(norms.max(), 1e-300)
    for c in cols[~nonzero]:
        fixed[model.params[c].name] = "no effect on these poses"
    cols = cols[nonzero]
    sub = sub[:, nonzero] / norms[nonzero]
    _, r = qr(sub, mode="economic")
    # With fewer equations than parameters the trailing columns have no diagonal entry.
    keep_local = np.zeros(sub.shape[1], dtype=bool)
    keep_local[: min(sub.shape)] = np.abs(np.diag(r)) > RANK_TOL
    keep = cols[keep_local]
    fixed.update(_absorbers(model, sub, keep_local, keep, cols))
    new_mask = np.zeros_like(free_mask)
    new_mask[keep] = True
    return new_mask, fixed


def _absorbers(model: ErrorModel, sub: np.ndarray, keep_local: np.ndarray, keep: np.ndarray, cols: np.ndarray) -> dict[str, str]:
    """For each dropped column, the kept parameters whose columns reproduce it."""
    kept = sub[:, keep_local]
    out = {}
    for k in np.nonzero(~keep_local)[0]:
        coef, *_ = np.linalg.lstsq(kept, sub[:, k], rcond=None)
        order = np.argsort(-np.abs(coef))
        partners = [model.params[keep[i]].name for i in order[:3] if abs(coef[i]) > 0.05]
        reason = "cannot be separated from " + (", ".join(partners) if partners else "the other parameters")
        out[model.params[cols[k]].name] = reason + " (fixed; its effect is absorbed there)"
    return out


def _solve(model: ErrorModel, prep: Prepared, measured: np.ndarray, free: np.ndarray, loss: str, f_scale: float, max_nfev: int | None = None,
           say=lambda message: None, weights: np.ndarray | None = None):
    """Least squares over the free parameters; ``say`` hears of every Jacobian (a fit of many
    terms on 10^4 poses runs for minutes: the command's progress line must go on).
    ``weights`` (N,): each pose's weight, 1 / its relative noise variance (None: all 1)."""
    free = np.asarray(free, dtype=bool)
    root = np.ones((len(measured), 1)) if weights is None else np.sqrt(np.asarray(weights, dtype=float))[:, None]
    if not free.any():
        return model.values.copy(), SimpleNamespace(success=True, message="nothing to fit")
    scales = np.array([p.scale for p in model.params])[free]
    base = model.values.copy()

    def unpack(x):
        v = base.copy()
        v[free] = x
        return v

    def fun(x):
        return ((model.predict_prepared(prep, unpack(x)) - measured) * root).ravel()

    jacobians = [0]

    def jac(x):
        jacobians[0] += 1
        say(f"fitting {int(free.sum())} parameters (step {jacobians[0]})")
        _, jj = model.evaluate(prep, unpack(x))
        return (jj * root[:, :, None]).reshape(jj.shape[0] * 3, jj.shape[-1])[:, free]

    lower = np.array([p.lower for p in model.params])[free]
    upper = np.array([p.upper for p in model.params])[free]
    bounded = np.isfinite(lower).any() or np.isfinite(upper).any()
    x0 = np.clip(base[free], lower, upper)
    method = "lm" if loss == "linear" and not bounded else "trf"
    res = least_squares(fun, x0, jac=jac, x_scale=scales, method=method, loss=loss, f_scale=f_scale, bounds=(lower, upper) if bounded else (-np.inf, np.inf), max_nfev=max_nfev, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return unpack(res.x), res


def resolve_terms(robot, tool_mm, effects: EffectSum, meas: MeasurementSet, prior=None, seed: int = 0, say=lambda m: None,
                  weights: np.ndarray | None = None) -> tuple[EffectSum, list[str]]:
    """Effects whose terms the fit chooses (e.g. harmonics without options) get the terms the
    data support, or are left out when they support none; returns the effects and notes.
    ``weights``: each pose's least-squares weight (``fit``'s noise model), None: all 1."""
    notes = []
    for effect in [e for e in effects if not e.resolved]:
        say(f"choosing {effect.name} terms")
        without = EffectSum(tuple(e for e in effects if e is not effect))
        choose = select_cyclic_terms if effect.term_search == "forward" else select_terms
        chosen, how = choose(robot, tool_mm, without, effect, meas, prior=prior, seed=seed, weights=weights)
        if chosen.terms:
            effects = effects.replaced(effect, chosen)
            notes.append(f"{effect.name}: data support {chosen.spec()} (terms and how often they were chosen: {how})")
        else:
            effects = without
            notes.append(f"{effect.name}: the data support no term; the effect is left out ({how})")
    return effects, notes


def fit(
    robot: RobotModel,
    tool_mm,
    effects: EffectSum,
    meas: MeasurementSet,
    *,
    loss: str = "linear",
    cv_folds: int = 5,
    prior: ErrorModel | None = None,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
    noise: str = "none",
    weights: np.ndarray | None = None,
) -> FitResult:
    """Identify the parameters of ``effects`` from a measurement set.

    ``prior``: a previously fitted model whose parameter values (and base registration)
    start this fit, e.g. to extend a model by one effect. BLAS runs one thread unless the
    set is large (``postproc.threads``). ``noise``: ``none`` (every pose equally trusted)
    or ``settle`` (each pose weighted by 1 / its place's noise variance after the last
    large move, estimated from an unweighted fit: ``postproc.model.noise_model``);
    ``weights`` (N,): per-pose weights given directly (they take the place of ``noise``).
    """
    with small_matrices(3 * len(meas)):
        weights, note = pose_weights(robot, tool_mm, effects, meas, checked(noise), weights, prior, seed, progress or (lambda msg: None))
        result = _fit(robot, tool_mm, effects, meas, loss, cv_folds, prior, seed, progress, weights)
        return result if note is None else replace(result, notes=(note, *result.notes))


def pose_weights(robot, tool_mm, effects: EffectSum, meas: MeasurementSet, noise: str, weights, prior, seed, say) -> tuple[np.ndarray | None, str | None]:
    """The per-pose weights of a fit and a note on where they came from: those given, else
    for ``settle`` 1 / the variance ratio of each pose's place after the last large move,
    the ratios from the residual of an unweighted fit of the effects whose terms are fixed."""
    if weights is not None:
        return np.asarray(weights, dtype=float), None
    if noise == "none":
        return None, None
    history = meas.path_history()
    place = settle_place(robot, tool_mm, meas.q_deg, history)
    say("noise model: an unweighted fit for the variance of each place after a move")
    fixed_terms = EffectSum(tuple(e for e in effects if e.resolved))
    first = _fit(robot, tool_mm, fixed_terms, meas, "linear", 0, prior, seed, None, None)
    ratios = NoiseRatios.estimate(place, residuals(first.model, meas), history.shape[1])
    counts = np.bincount(place, minlength=history.shape[1] + 1)
    return ratios.weights(place), (f"noise model settle: variance of the poses 1, 2, 3, 4+ after a move > 10 mm "
                                   f"{ratios.describe()} times the settled poses' ({' / '.join(map(str, counts))} poses); weights 1 / that")


def _fit(robot, tool_mm, effects, meas, loss, cv_folds, prior, seed, progress, weights=None) -> FitResult:
    say = progress or (lambda msg: None)
    coverage = Coverage.of(robot, tool_mm, meas.q_deg)  # the model records the region it was fitted on
    effects, notes = resolve_terms(robot, tool_mm, effects, meas, prior=prior, seed=seed, say=say, weights=weights)
    model = replace(_initial_model(robot, tool_mm, effects, meas, prior), coverage=coverage)
    prep = model.prepare(meas)
    notes.extend(prep.notes)
    framed = bool(effects.of_kind("base"))
    # One nominal error for a data set everywhere (simulate, fit, report, ladder): the nominal robot registered onto it.
    before = Stats.of(residuals(nominal_model(robot, tool_mm, meas, registered=True), meas))
    if not model.params:
        # --effects none: the nominal model, nothing to identify (a predictor may sit on top).
        as_saved = Stats.of(residuals(model, meas))  # unregistered: what evaluate gives for this model
        return FitResult(model=model, std={}, fixed={}, outliers=(), before=before, after=as_saved,
                         cv_rms_mm=as_saved.rms_mm if cv_folds else None, approach_inferred=False, notes=tuple(notes))
    if framed and prior is None:
        model = register_base(model, meas, prep)

    say("identifiability")
    free, fixed = identifiability(model, prep, np.ones(len(model.params), dtype=bool))
    if 3 * len(meas) <= free.sum():
        raise IdentificationError(f"{meas.source}: {len(meas)} poses give {3 * len(meas)} equations for {int(free.sum())} identifiable parameters; measure more poses")

    say("fitting")
    f_scale = 0.05
    values, res = _solve(model, prep, meas.measured_mm, free, loss, f_scale, say=say, weights=weights)
    if not res.success:
        raise IdentificationError(f"{meas.source}: the fit did not converge ({res.message})")
    model = model.with_vector(values)
    if framed:
        # Re-centre the registration on the fitted rotation so the small-angle Jacobian is exact.
        model = _recentre_base(model)

    resid = residuals(model, meas, prep)
    cv = None
    if cv_folds and cv_folds >= 2 and len(meas) >= 2 * cv_folds:
        cv = cross_validate(model, meas, free, cv_folds, loss, f_scale, seed, say, weights)
    return FitResult(model=model, std=_standard_errors(model, prep, resid, free), fixed=fixed, outliers=_outliers(meas, resid),
                     before=before, after=Stats.of(resid), cv_rms_mm=cv, approach_inferred=prep.approach_inferred, notes=tuple(notes))


def _initial_model(robot, tool_mm, effects: EffectSum, meas: MeasurementSet, prior: ErrorModel | None) -> ErrorModel:
    if len(meas) < 3:
        raise IdentificationError(f"{meas.source}: {len(meas)} poses cannot identify anything")
    model = ErrorModel.create(robot, tool_mm, effects)
    if 3 * len(meas) < len(model.params):
        raise IdentificationError(f"{meas.source}: {len(meas)} poses give {3 * len(meas)} equations for {len(model.params)} parameters; measure more poses")
    if prior is not None:
        model = replace(model.with_values(prior.as_dict()), base_rotation=prior.base_rotation, base_translation=prior.base_translation)
    return model


def _standard_errors(model: ErrorModel, prep: Prepared, resid: np.ndarray, free: np.ndarray) -> dict[str, float]:
    """Standard error of every parameter from the Jacobian at the solution (0 for fixed ones)."""
    dof = max(resid.size - int(free.sum()), 1)
    _, jj = model.evaluate(prep)
    jf = jj.reshape(jj.shape[0] * 3, jj.shape[-1])[:, free]
    s2 = float(np.sum(resid**2)) / dof
    try:
        std_free = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(jf.T @ jf)), 0, None))
    except np.linalg.LinAlgError:
        std_free = np.full(int(free.sum()), np.nan)
    std = {p.name: 0.0 for p in model.params}
    for k, i in enumerate(np.nonzero(free)[0]):
        std[model.params[i].name] = float(std_free[k])
    return std


def _outliers(meas: MeasurementSet, resid: np.ndarray) -> tuple[str, ...]:
    sigma = 1.4826 * np.median(np.abs(resid - np.median(resid, axis=0)))
    norms = np.linalg.norm(resid, axis=1)
    return tuple(meas.ids[i] for i in np.nonzero(norms > OUTLIER_SIGMAS * max(sigma, 1e-9))[0])


def _frame_effect():
    """A fresh instance of the catalog's base-frame effect (the one that re-registers a frame)."""
    return catalog_of_kind("base")[0]()


def refit_base(model: ErrorModel, meas: MeasurementSet) -> ErrorModel:
    """Re-register the measurement frame on another set (a tracker moved between series),
    keeping every other parameter: Kabsch, then a least-squares refinement of the 6 DOF."""
    framed = model if model.effects.of_kind("base") else ErrorModel.create(
        model.robot, model.tool_mm, model.effects + _frame_effect(), model.as_dict()
    )
    prep = framed.prepare(meas)
    framed = register_base(framed, meas, prep)
    free = np.zeros(len(framed.params), dtype=bool)
    free[_base_indices(framed)] = True
    values, _ = _solve(framed, prep, meas.measured_mm, free, "linear", 0.05)
    return _recentre_base(framed.with_vector(values))


def nominal_model(robot: RobotModel, tool_mm, meas: MeasurementSet, registered: bool) -> ErrorModel:
    """What the controller assumes; with ``registered``, rigidly moved onto the data (Kabsch),
    which is the fair 'before' for data measured in another frame (a tracker's)."""
    if not registered:
        return ErrorModel.create(robot, tool_mm, EffectSum())
    reg = ErrorModel.create(robot, tool_mm, EffectSum((_frame_effect(),)))
    return register_base(reg, meas, reg.prepare(meas))


def _recentre_base(model: ErrorModel) -> ErrorModel:
    """Move the fitted base-frame parameters into the registration (R0, t0) and zero them."""
    rot, trans = model.base_transform()
    values = model.values.copy()
    values[_base_indices(model)] = 0.0
    return replace(model, values=values, base_rotation=rot, base_translation=trans)


def cross_validate(model: ErrorModel, meas: MeasurementSet, free: np.ndarray, folds: int, loss: str, f_scale: float, seed: int, say=lambda m: None,
                   weights: np.ndarray | None = None) -> float:
    """k-fold cross-validated RMS (mm): refit the free parameters without each fold, predict it
    (the refits weighted by ``weights``; the RMS over all poses, as measured)."""
    errors = cross_validation_errors(model, meas, free, folds, loss, f_scale, seed, say, weights)
    return float(np.sqrt(np.mean(np.sum(errors**2, axis=1))))


def fold_assignment(n: int, folds: int, seed: int) -> np.ndarray:
    """Fold number of each pose: a seeded permutation dealt round-robin, so every fold spans the set."""
    order = np.random.default_rng(seed).permutation(n)
    fold_of = np.empty(n, dtype=int)
    fold_of[order] = np.arange(n) % folds
    return fold_of


def cross_validation_errors(model: ErrorModel, meas: MeasurementSet, free: np.ndarray, folds: int, loss: str = "linear", f_scale: float = 0.05, seed: int = 0, say=lambda m: None,
                            weights: np.ndarray | None = None) -> np.ndarray:
    """Held-out errors (N, 3), in the set's row order: each fold predicted by a refit without it."""
    fold_of = fold_assignment(len(meas), folds, seed)
    errors = np.zeros((len(meas), 3))
    for k in range(folds):
        say(f"cross-validation fold {k + 1}/{folds}")
        test = fold_of == k
        train_set, test_set = meas.subset(~test), meas.subset(test)
        prep_train = model.prepare(train_set)
        values, _ = _solve(model, prep_train, train_set.measured_mm, free, loss, f_scale, max_nfev=200, weights=None if weights is None else weights[~test])
        errors[test] = model.with_vector(values).predict(test_set) - test_set.measured_mm
    return errors


def free_mask(result: "FitResult") -> np.ndarray:
    """Which parameters of a fit's model were identified."""
    return np.array([p.name not in result.fixed for p in result.model.params])


def select_terms(robot, tool_mm, others: EffectSum, family: Effect, meas: MeasurementSet, prior=None, seed: int = 0, max_terms: int = 4,
                 weights: np.ndarray | None = None) -> tuple[Effect, str]:
    """A term family's terms (e.g. harmonics' (joint, order)) by best-subset regression over
    the whole family, with cross-validation and a stability check (``postproc.model.term_selection``),
    on the residual of the model without the family linearised around its fit. Returns the
    family with the chosen terms and a note of how stable the choice was."""

    result = fit(robot, tool_mm, others, meas, cv_folds=0, prior=prior, seed=seed, weights=weights)
    prep = result.model.prepare(meas)
    pos, jac = result.model.evaluate(prep)
    root = np.repeat(np.ones(len(meas)) if weights is None else np.sqrt(weights), 3)  # weighted rows: each scaled by sqrt(w)
    free = np.array([result.std.get(p.name, 0.0) > 0 for p in result.model.params], dtype=bool)
    dp_dq = kin_joint_columns(result.model, prep)  # d p / d q_j in the measurement frame, per degree
    candidates = family.candidate_terms()
    cols = [family.term_columns(dp_dq, meas.q_deg, term).reshape(3 * len(meas), -1) * root[:, None] for term in candidates]
    groups = np.split(np.arange(sum(c.shape[1] for c in cols)), np.cumsum([c.shape[1] for c in cols])[:-1])
    pick = best_subset(np.hstack(cols), (meas.measured_mm - pos).reshape(-1) * root, groups, np.repeat(fold_assignment(len(meas), 5, seed), 3),
                       base=jac.reshape(3 * len(meas), -1)[:, free] * root[:, None], unit_of=np.repeat(np.arange(len(meas)), 3), max_terms=max_terms, seed=seed)
    how = f"best subset, 5-fold CV RMS {pick.cv_rms:.4f} mm, the whole set chosen in {100 * pick.support_stability:.0f} % of resamples"
    labels = [":".join(map(str, t)) if isinstance(t, tuple) else str(t) for t in candidates]
    return family.with_terms(tuple(candidates[t] for t in pick.chosen)), (term_labels(labels, pick) + "; " if pick.chosen else "") + how


def cyclic_residual(model: ErrorModel, meas: MeasurementSet, weights: np.ndarray | None = None) -> Residual:
    """The model's residual on ``meas`` with the columns a cyclic-error scan needs
    (``postproc.model.harmonic_scan``); with ``weights``, each pose's rows scaled by sqrt(w),
    so the scan's least squares are the weighted ones."""
    prep = model.prepare(meas)
    _, jac = model.evaluate(prep)
    root = np.ones(len(meas)) if weights is None else np.sqrt(np.asarray(weights, dtype=float))
    return Residual(residuals(model, meas, prep) * root[:, None], kin_joint_columns(model, prep) * root[:, None, None],
                    (jac * root[:, None, None]).reshape(3 * len(meas), -1), np.radians(meas.q_deg))


def select_cyclic_terms(robot, tool_mm, others: EffectSum, family: Effect, meas: MeasurementSet, prior=None, seed: int = 0,
                        weights: np.ndarray | None = None) -> tuple[Effect, str]:
    """The terms of a family searched forward (cyclic joint errors with a high largest
    order): forward selection over its candidate (joint, order) terms on the residual of the
    model without it, the number of terms by 5-fold cross-validation that holds out whole
    commanded positions (column ``point``) where the set has them, else single poses
    (``postproc.model.harmonic_scan.choose_terms``)."""
    result = fit(robot, tool_mm, others, meas, cv_folds=0, prior=prior, seed=seed, weights=weights)
    grouped = "point" in meas.extra
    groups = meas.extra["point"].astype(np.int64) if grouped else np.arange(len(meas))
    candidates = family.candidate_terms()
    choice = choose_terms(cyclic_residual(result.model, meas, weights), groups, np.ones(len(meas), dtype=bool), candidates, seed=seed)
    n = len(choice.terms)
    joints, orders = sorted({j for j, _ in candidates}), sorted({k for _, k in candidates})
    how = (f"forward selection over joints {','.join(map(str, joints))} and orders {orders[0]}-{orders[-1]}, "
           f"5-fold CV by {'commanded position' if grouped else 'pose'}: {n} terms, CV RMS {choice.cv_rms_mm[0]:.4f} -> {choice.cv_rms_mm[n]:.4f} mm")
    return family.with_terms(choice.terms), how


def _noise_places(model: ErrorModel, q_deg: np.ndarray, history: np.ndarray, noise: str, kind: str) -> np.ndarray | None:
    """Each pose's place after the last large move where the predictor is given a noise model;
    refuses a predictor that cannot take one (rather than fitting it as if trusted alike)."""
    if noise == "none":
        return None
    takes = kind == "gpr" or (kind in PREDICTORS and "sample_weight" in inspect.signature(PREDICTORS[kind].fit).parameters)
    if not takes:
        raise IdentificationError(f"--noise-model {noise}: the {kind} predictor takes no per-pose noise "
                                  "(gpr does, and a plugin predictor whose fit takes sample_weight)")
    return settle_place(model.robot, model.tool_mm, q_deg, history)


def kin_joint_columns(model: ErrorModel, prep: Prepared) -> np.ndarray:
    """d(measured position)/d(q_j) per degree, (N, 3, 6), by central differences of the model."""
    out = np.zeros((len(prep.ctx.q_deg), 3, 6))
    h = 1e-4
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        up = replace(prep, ctx=replace(prep.ctx, q_deg=prep.ctx.q_deg + dq))
        down = replace(prep, ctx=replace(prep.ctx, q_deg=prep.ctx.q_deg - dq))
        out[:, :, j] = (model.predict_prepared(up) - model.predict_prepared(down)) / (2 * h)
    return out


def fit_predictor(model: ErrorModel, meas: MeasurementSet, kind: str, source: MeasurementSet | None = None, seed: int = 0,
                  gp_options: dict | None = None, progress=None, noise: str = "none") -> ErrorModel:
    """Attach a data-driven predictor of the model's residual (a hybrid model; with no
    effects, a purely data-driven one). tr-gpr takes a source-region set as well.
    ``noise``: ``settle`` gives gpr one noise level per place after the last large move
    (by its marginal likelihood) and a plugin predictor whose ``fit`` takes
    ``sample_weight`` the weights 1 / each place's variance ratio in the residual
    (``postproc.model.noise_model``); the other predictors take no per-pose noise."""

    # Deferred: postproc.model.learn loads torch (seconds), needed only when a predictor is fitted.
    from .learn import (
        FEATURES,
        GPRPredictor,
        GridPredictor,
        PSOBPPredictor,
        Residual,
        TrGPRPredictor,
    )
    from .learn.features import GP_KINDS, HISTORY_KINDS, features

    if kind not in FEATURES and kind not in PREDICTORS:
        raise IdentificationError(f"unknown predictor '{kind}' (known: {', '.join([*FEATURES, *PREDICTORS])})")
    physics = _replace(model, residual=None)
    target = meas.measured_mm - physics.predict(meas)
    gp_options = dict(gp_options or {})  # the gpr's options; the other predictors take none
    feature_kind = FEATURES[kind] if kind in FEATURES else PREDICTORS[kind].features
    if kind == "gpr":
        feature_kind = gp_options.pop("features", None) or feature_kind
        if feature_kind not in GP_KINDS:
            raise IdentificationError(f"gpr features '{feature_kind}' are not one of {', '.join(GP_KINDS)}")
    reference = features(model.robot, model.tool_mm, meas.q_deg[:1], "position")[0] if feature_kind == "joints+disp" else None
    history = meas.path_history()  # (N, k, 6) the targets before each pose in measured order
    X = features(model.robot, model.tool_mm, meas.q_deg, feature_kind, reference, history)
    place = _noise_places(model, meas.q_deg, history, checked(noise), kind)
    if kind == "gpr":
        est = GPRPredictor(anisotropic=True, random_state=seed, **gp_options).fit(X, target, progress=progress, noise_groups=place)
    elif kind == "pso-bp":
        est = PSOBPPredictor(random_state=seed).fit(X, target, progress=progress)
    elif kind == "grid":
        est = GridPredictor().fit(X, target)
    elif kind in PREDICTORS and place is not None:
        est = PREDICTORS[kind](random_state=seed).fit(X, target, sample_weight=NoiseRatios.estimate(place, target, history.shape[1]).weights(place))
    elif kind in PREDICTORS:
        est = PREDICTORS[kind](random_state=seed).fit(X, target)
    else:
        if source is None:
            raise IdentificationError("tr-gpr needs a source-region measurement set (--source)")
        Xs = features(model.robot, model.tool_mm, source.q_deg, feature_kind)
        ys = source.measured_mm - physics.predict(source)
        est = TrGPRPredictor(random_state=seed).fit(X, target, Xs, ys)
    coverage = model.coverage
    if coverage is not None and feature_kind in HISTORY_KINDS:  # the predictor reads the path: record the moves it was measured with
        coverage = coverage.with_travels(path_travel_mm(model.robot, model.tool_mm, meas.q_deg, history))
    return _replace(model, residual=Residual(kind, feature_kind, est, reference), coverage=coverage)
