"""Where a model fails and which physical effect is missing.

1. Compare: residual statistics overall, per axis, and broken down by workspace region
   (theta1 sector, radius, height), each joint's angle, gravity torque, load,
   temperature, time and approach direction (binned means for the figures).
2. What the residual follows (``postproc.model.structure``): a smooth function of each variable
   and of each pair of them, its held-out share of the residual variance, Holm-corrected
   F tests; so a residual that depends on two variables together is still seen.
3. The noise floor every judgement is made against, from the data (``postproc.model.noise_floor``:
   repeats, else the residual of a flexible fit), unless the user states the noise.
4. What is missing (``postproc.model.candidates``): each catalog effect not in the model whose
   columns the data have is added to the fitted model and cross-validated on the same
   folds by a linearised refit (``postproc.model.held_out``). It is recommended only when it
   brings the cross-validated RMS at least 20 % of the way to the noise floor, in at least
   80 % of bootstrap resamples, and its per-pose gain passes a Holm-corrected paired test.
   When none does, the best few together are tried; when they do not either, the catalog
   is exhausted: the verdict names what the residual follows and points at writing the
   effect (``postproc effect new``), a data-driven predictor being the other way.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field

import numpy as np
from scipy import stats as sps

from postproc.progress import report, silent
from postproc.robot import kinematics as kin
from postproc.threads import small_matrices

from . import noise_floor as noise_floors
from .candidates import MIN_PROGRESS, MIN_STABILITY, Scored, score_candidates
from .effects import CATALOG, EffectSum, parse_effects
from .errormodel import ErrorModel
from .held_out import held_out_miss, inside_bounds, linearise, rms
from .identify import Stats, fit, fold_assignment, free_mask, nominal_model, refit_base, residuals
from .measurements import MeasurementSet
from .structure import Structure, find_structure, holm, named

ALPHA = 0.05
BINS = 5
#: the model is at the noise floor when its cross-validated RMS is within this factor of it
AT_FLOOR = 1.25


@dataclass(frozen=True)
class Breakdown:
    """Residual against one variable: bins, their mean residual (mm, per axis) and the test."""

    variable: str
    label: str
    unit: str
    edges: tuple[float, ...]
    centres: tuple[float, ...]
    counts: tuple[int, ...]
    mean_mm: tuple[tuple[float, float, float], ...]
    rms_mm: tuple[float, ...]
    eta2: float  # share of residual variance explained by the bin means
    p_value: float
    p_adjusted: float = 1.0

    @property
    def significant(self) -> bool:
        return self.p_adjusted < ALPHA


@dataclass(frozen=True)
class Candidate:
    effect: str  # spec, with the options the fit chose
    explained: float  # held-out share of the residual variance it removes
    rms_if_added_mm: float  # cross-validated RMS with it added
    p_value: float
    p_adjusted: float
    significant: bool  # recommended: far enough towards the floor, stable, and beyond noise
    message: str
    progress: float = 0.0  # share of the way from the model's CV RMS to the noise floor
    stability: float = 0.0  # share of resamples in which it still goes MIN_PROGRESS of the way

    def as_json(self) -> dict:
        return {"effect": self.effect, "explained": self.explained, "rms_if_added_mm": self.rms_if_added_mm, "cv_rms_mm": self.rms_if_added_mm,
                "progress_to_floor": self.progress, "stability": self.stability, "p_value": self.p_adjusted, "significant": self.significant,
                "message": self.message}


@dataclass(frozen=True)
class Diagnosis:
    stats: Stats
    cv_rms_mm: float
    noise_floor_mm: float
    breakdowns: tuple[Breakdown, ...]
    candidates: tuple[Candidate, ...]
    findings: tuple[str, ...]
    residual_mm: np.ndarray = field(repr=False)
    variables: dict = field(repr=False, default_factory=dict)
    structure: tuple[Structure, ...] = ()
    follows: Structure | None = None  # the variable or pair the residual follows, if any
    catalog_exhausted: bool = False
    combination: Candidate | None = None  # the best few candidates together, when none is enough alone
    noise: noise_floors.NoiseFloor | None = None

    def as_json(self) -> dict:
        return {
            "rms_mm": self.stats.rms_mm,
            "mean_mm": self.stats.mean_mm,
            "max_mm": self.stats.max_mm,
            "rms_axis_mm": list(self.stats.rms_axis_mm),
            "n": self.stats.n,
            "cv_rms_mm": self.cv_rms_mm,
            "noise_floor_mm": self.noise_floor_mm,
            "noise_floor": None if self.noise is None else self.noise.as_json(),
            "thresholds": {"progress_to_floor": MIN_PROGRESS, "stability": MIN_STABILITY, "alpha": ALPHA, "at_floor": AT_FLOOR},
            "candidates": [c.as_json() for c in self.candidates],
            "combination": None if self.combination is None else self.combination.as_json(),
            "catalog_exhausted": self.catalog_exhausted,
            "variables": list(self.follows.variables) if self.follows is not None else [],
            "follows": None if self.follows is None else self.follows.as_json(),
            "structure": [s.as_json() for s in self.structure if s.significant or len(s.variables) == 1],
            "findings": list(self.findings),
        }


def explanatory_variables(model: ErrorModel, meas: MeasurementSet) -> dict[str, tuple[str, str, np.ndarray, bool]]:
    """name -> (label, unit, values (N,), categorical) for every variable the data allow."""
    nominal = kin.fk(model.robot, meas.q_deg, tool=model.tool_mm)[:, :3, 3]
    out: dict[str, tuple[str, str, np.ndarray, bool]] = {
        "theta1_sector": ("theta1 sector (base rotation)", "deg", np.degrees(np.arctan2(nominal[:, 1], nominal[:, 0])), False),
        "radius": ("radius from axis 1", "mm", np.hypot(nominal[:, 0], nominal[:, 1]), False),
        "height": ("height", "mm", nominal[:, 2], False),
    }
    for j in range(6):
        out[f"q{j + 1}"] = (f"joint {j + 1} angle", "deg", meas.q_deg[:, j], False)
    torque = kin.gravity_torque(model.robot, meas.q_deg)
    for j in range(6):
        out[f"tau{j + 1}"] = (f"gravity torque on joint {j + 1}", "N*m", torque[:, j], False)
    if meas.force_n is not None:
        out["load"] = ("load |F|", "N", np.linalg.norm(meas.force_n, axis=1), False)
    if meas.temp_c is not None:
        out["temp"] = ("temperature", "degC", meas.temp_c, False)
    if meas.time_s is not None:
        out["time"] = ("time", "s", meas.time_s, False)
    if meas.approach is not None:
        for j in range(6):
            out[f"s{j + 1}"] = (f"approach direction of joint {j + 1}", "", meas.approach[:, j], True)
    return out


def _breakdown(name: str, label: str, unit: str, values: np.ndarray, categorical: bool, resid: np.ndarray) -> Breakdown | None:
    if categorical:
        levels = np.unique(values)
        groups = [values == v for v in levels]
        edges = tuple(float(v) for v in levels)
        centres = edges
    else:
        if np.ptp(values) <= 1e-9 * max(1.0, np.abs(values).max()):
            return None  # the variable does not vary: nothing to learn from it
        edges_arr = np.unique(np.quantile(values, np.linspace(0, 1, BINS + 1)))
        if len(edges_arr) < 3:
            return None
        idx = np.clip(np.searchsorted(edges_arr, values, side="right") - 1, 0, len(edges_arr) - 2)
        groups = [idx == b for b in range(len(edges_arr) - 1)]
        edges = tuple(float(v) for v in edges_arr)
        centres = tuple(float(values[g].mean()) if g.any() else float("nan") for g in groups)
    groups = [g for g in groups if g.sum() >= 2]
    if len(groups) < 2:
        return None
    p_axes = []
    between = total = 0.0
    for axis in range(3):
        samples = [resid[g, axis] for g in groups]
        p_axes.append(float(sps.f_oneway(*samples).pvalue) if np.var(resid[:, axis]) > 0 else 1.0)
        grand = resid[:, axis].mean()
        between += sum(len(s) * (s.mean() - grand) ** 2 for s in samples)
        total += float(np.sum((resid[:, axis] - grand) ** 2))
    p = min(1.0, 3 * np.nanmin(p_axes))  # Bonferroni over the three axes
    return Breakdown(
        variable=name,
        label=label,
        unit=unit,
        edges=edges,
        centres=centres,
        counts=tuple(int(g.sum()) for g in groups),
        mean_mm=tuple(tuple(float(v) for v in resid[g].mean(axis=0)) for g in groups),
        rms_mm=tuple(float(np.sqrt(np.mean(np.sum(resid[g] ** 2, axis=1)))) for g in groups),
        eta2=float(between / total) if total > 0 else 0.0,
        p_value=p,
    )


def candidate_effects(model: ErrorModel, meas: MeasurementSet) -> list[str]:
    """Catalog effects not in the model whose measurement columns the data have."""
    present = set(model.effects.names())
    return [name for name, cls in CATALOG.items() if name not in present and all(meas.has(group) for group in cls.needs)]


def _message(spec: str, scored: Scored) -> str:
    effects = parse_effects(spec).effects
    what = effects[0].describe_finding() if len(effects) == 1 else f"together, {spec}"
    text = (f"{what}; {spec} explains {100 * scored.explained:.0f}% of them, {100 * scored.progress:.0f}% of the way to the noise floor "
            f"in {100 * scored.stability:.0f}% of resamples")
    if scored.selection_note:
        text += f" ({scored.selection_note})"
    return text


def diagnose(
    model: ErrorModel,
    meas: MeasurementSet,
    *,
    folds: int = 5,
    seed: int = 0,
    noise_mm: float | None = None,
    candidates: list[str] | None = None,
    progress=silent,
    files: "Files | None" = None,
) -> Diagnosis:
    """Compare the model with measurements, find what the residual follows, rank the missing effects.

    ``noise_mm``: the measurement noise per axis when known; None estimates the noise floor
    from the data. ``files``: the model and measurement paths the findings' commands name
    (placeholders MODEL.json and MEAS.csv when not given)."""
    with small_matrices(3 * len(meas)):
        return _diagnose(model, meas, folds, seed, noise_mm, candidates, progress, files or Files())


def _diagnose(model, meas, folds, seed, noise_mm, candidates, progress, files) -> Diagnosis:
    miss = -residuals(model, meas)  # measured - predicted: what the model misses
    variables = explanatory_variables(model, meas)
    breakdowns = [b for name, (label, unit, values, cat) in variables.items() if (b := _breakdown(name, label, unit, values, cat, miss)) is not None]
    adjusted = holm([b.p_value for b in breakdowns]) if breakdowns else []
    breakdowns = [Breakdown(**{**b.__dict__, "p_adjusted": p}) for b, p in zip(breakdowns, adjusted)]
    breakdowns.sort(key=lambda b: (not b.significant, -b.eta2))

    names = candidate_effects(model, meas) if candidates is None else candidates
    steps = len(names) + 3
    report(progress, "refitting the model", 0, steps)
    base_fit = fit(model.robot, model.tool_mm, model.effects, meas, cv_folds=0, prior=model, seed=seed)
    base = linearise(base_fit.model, meas, free=inside_bounds(base_fit.model, free_mask(base_fit)))
    fold_of = fold_assignment(len(meas), folds, seed)
    base_sq = np.sum(held_out_miss(base, fold_of) ** 2, axis=1)
    cv_rms = float(np.sqrt(base_sq.mean()))
    report(progress, "looking for structure", 1, steps)
    structure = find_structure(variables, base.miss, fold_of)
    follows = named(structure)
    report(progress, "estimating the noise floor", 2, steps)
    noise = noise_floors.given(noise_mm) if noise_mm is not None else noise_floors.estimate(
        meas, base.miss, int(base.free.sum()), _focus(variables, structure))

    def step(message, done=None, total=None):
        report(progress, message, 3 + (done or 0), steps)

    scored, combined, floor = score_candidates(base_fit.model, meas, names, base_sq, fold_of, noise.floor_mm, seed, step)
    if floor < noise.floor_mm:
        noise = noise_floors.lowered(noise, floor, "held-out RMS of the model with " + min((s for s in scored if s.added), key=lambda s: s.cv_rms_mm).spec)
    ranked = _as_candidates(scored)
    combination = _as_candidates([combined])[0] if combined is not None else None
    at_floor = cv_rms <= AT_FLOOR * noise.floor_mm
    recommended = any(c.significant for c in ranked) or (combination is not None and combination.significant)
    exhausted = not at_floor and not recommended
    findings = _findings(structure, ranked, cv_rms, noise.floor_mm, files, model, follows=follows, exhausted=exhausted, combination=combination)
    if model.residual is not None:
        findings.append(with_command(
            f"The model's {model.residual.kind} predictor is in the comparison above; the candidate effects and the "
            "cross-validated RMS concern its physics part (the predictor is fitted on what the physics leaves).",
            files.evaluate_command()))
    return Diagnosis(Stats.of(miss), cv_rms, noise.floor_mm, tuple(breakdowns), tuple(ranked), tuple(findings), miss, variables,
                     tuple(structure), follows, exhausted, combination, noise)


def _focus(variables: dict, structure: list[Structure], count: int = 3) -> np.ndarray:
    """(N, k) the variables of the strongest significant structures (for the noise floor's smoother)."""
    names = list(dict.fromkeys(v for s in structure if s.significant for v in s.variables))[:count]
    return np.stack([variables[n][2] for n in names], axis=1) if names else np.zeros((len(next(iter(variables.values()))[2]), 0))


def _as_candidates(scored: list[Scored]) -> list[Candidate]:
    """Scored candidates as the report shows them; Holm over the candidates for the paired test."""
    adjusted = holm([s.p_value for s in scored]) if scored else []
    out = []
    for s, p_adj in zip(scored, adjusted):
        significant = s.recommended and p_adj < ALPHA
        if not s.added:
            message = f"{s.spec}: the data support no term ({s.selection_note})"
        else:
            message = _message(s.spec, s) + ("" if significant else
                                             f" (below {100 * MIN_PROGRESS:.0f}% of the way in {100 * MIN_STABILITY:.0f}% of resamples: leave it out)")
        out.append(Candidate(s.spec, s.explained, s.cv_rms_mm, s.p_value, p_adj, significant, message, s.progress, s.stability))
    return out


#: Between a finding's words and the command that acts on it (``split_command`` takes it apart).
COMMAND_MARK = " Run: "


@dataclass(frozen=True)
class Files:
    """The paths a finding's command names."""

    model: str = "MODEL.json"
    meas: str = "MEAS.csv"
    #: ' --plugins F ...' that the command itself was given (postproc.plugins.plugin_arguments):
    #: a suggested command that reads the model must load the same effects.
    plugins: str = ""

    def next_model(self) -> str:
        stem = self.model[:-5] if self.model.endswith(".json") else self.model
        return f"{stem}_next.json"

    def fit_command(self, spec: str) -> str:
        """Refit the model with one more effect (its terms as the diagnosis chose them)."""
        return f"postproc fit {_quote(self.meas)} --from {_quote(self.model)} --effects {_quote('+' + spec)} --cv 0 -o {_quote(self.next_model())}{self.plugins}"

    def predictor_command(self, model) -> str:
        """Keep the physics and learn what it leaves (a hybrid model)."""
        return f"postproc fit {_quote(self.meas)} --from {_quote(self.model)} --effects {_quote(model.effects.spec())} --predictor gpr --cv 0 -o {_quote(self.next_model())}{self.plugins}"

    def evaluate_command(self) -> str:
        return f"postproc evaluate {_quote(self.model)} {_quote(self.meas)}{self.plugins}"

    def use_command(self) -> str:
        """The model is as good as the data allow: compensate a program with it."""
        return f"postproc compensate PROGRAM --model {_quote(self.model)} -o PROGRAM_compensated{self.plugins}"

    @staticmethod
    def effect_new_command(variables: tuple[str, ...]) -> str:
        """Write the effect the catalog lacks (a template outside the package)."""
        return f"postproc effect new {'_'.join(variables) or 'my'}_effect"


def _quote(text: str) -> str:
    return shlex.quote(text)


def with_command(text: str, command: str) -> str:
    return f"{text.rstrip()}{COMMAND_MARK}{command}"


def split_command(finding: str) -> tuple[str, str]:
    """A finding's words and the command that acts on it."""
    text, _, command = finding.rpartition(COMMAND_MARK)
    return (text, command) if text else (finding, "")


def grouped_findings(findings) -> list[tuple[list[str], str]]:
    """Findings in order, those in a row that end in the same command grouped, so each
    command is printed once: ``[([text, ...], command), ...]`` (command "" for none)."""
    groups: list[tuple[list[str], str]] = []
    for finding in findings:
        text, command = split_command(finding)
        if groups and command and groups[-1][1] == command:
            groups[-1][0].append(text)
        else:
            groups.append(([text], command))
    return groups


#: The finding that offers a data-driven predictor as the other way starts so.
OTHER_WAY = "The other way:"


def _findings(structure, ranked, cv_rms, floor, files: Files, model, *, follows: Structure | None = None, exhausted: bool = False,
              combination: Candidate | None = None, noise_detail: str = "") -> list[str]:
    """Plain-language findings, each ending with the command that acts on it. Only a
    recommended candidate is ever suggested; when the catalog is exhausted the verdict
    names what the residual follows and points at writing the effect, a data-driven
    predictor being the other way (its own finding, starting with ``OTHER_WAY``)."""
    out = []
    recommended = [c for c in ranked if c.significant]
    together = combination if (not recommended and combination is not None and combination.significant) else None
    at_floor = cv_rms <= AT_FLOOR * floor
    if recommended:
        action = files.fit_command(recommended[0].effect)
    elif together is not None:
        action = files.fit_command(together.effect)
    elif at_floor:
        action = files.use_command()
    elif exhausted and follows is not None:
        action = files.effect_new_command(follows.variables)
    else:
        action = files.predictor_command(model)
    floor_words = f"noise floor {floor:.4f} mm" + (f" ({noise_detail})" if noise_detail else "")
    shown = follows if follows is not None else next((s for s in structure if s.significant), None)
    if shown is not None:
        why = (f"The residual follows {shown.name}: a smooth function of {'them' if len(shown.variables) > 1 else 'it'} explains "
               f"{100 * shown.explained:.0f}% of the held-out residual variance (p = {shown.p_adjusted:.1e}).")
        out.append(with_command(why, action))
    if recommended:
        best = recommended[0]
        out.append(with_command(best.message[0].upper() + best.message[1:] + f": add it (cross-validated RMS {cv_rms:.4f} -> {best.rms_if_added_mm:.4f} mm, {floor_words}).", action))
    elif together is not None:
        out.append(with_command(f"No catalog effect is enough alone, but {together.effect} together bring the cross-validated RMS {cv_rms:.4f} -> "
                                f"{together.rms_if_added_mm:.4f} mm, {100 * together.progress:.0f}% of the way to the {floor_words}: add them.", action))
    elif at_floor:
        out.append(with_command(f"No candidate explains the residual beyond noise. Cross-validated RMS {cv_rms:.4f} mm against a {floor_words} "
                                f"({cv_rms / floor:.2f} x): the model is as good as the data allow; use it.", action))
    else:
        best = max(ranked, key=lambda c: c.progress, default=None)
        best_words = f" (the best, {best.effect}, goes {100 * best.progress:.0f}% of the way in {100 * best.stability:.0f}% of resamples)" if best else ""
        text = (f"No candidate explains the residual beyond noise: no catalog effect, alone or with others, brings the cross-validated RMS "
                f"{cv_rms:.4f} mm {100 * MIN_PROGRESS:.0f}% of the way to the {floor_words} in {100 * MIN_STABILITY:.0f}% of resamples{best_words}. "
                "The catalog is exhausted")
        if follows is not None:
            text += (f": what is left follows {follows.name} ({100 * follows.explained:.0f}% of the held-out residual variance is a smooth "
                     f"function of {'them' if len(follows.variables) > 1 else 'it'}). Write the effect that depends on "
                     f"{' and '.join(follows.variables)} outside the package, then fit with it.")
        else:
            text += ": what is left follows none of the measured variables, alone or in pairs."
        out.append(with_command(text, action))
        if follows is not None:
            out.append(with_command(f"{OTHER_WAY} learn what is left with a data-driven predictor on top of the physics "
                                    "(it knows no physics and holds only inside the measured workspace).", files.predictor_command(model)))
    if not any(s.significant for s in structure):
        out.append(with_command("No variable, alone or in pairs, shows structure in the residual beyond chance.", action))
    return out


def ladder(
    robot,
    tool_mm,
    meas: MeasurementSet,
    steps: list[str] | None = None,
    *,
    folds: int = 5,
    seed: int = 0,
    noise_mm: float | None = None,
    validation: MeasurementSet | None = None,
    max_steps: int = 8,
    reregister: bool = False,
    progress=silent,
) -> list[dict]:
    """Fit a sequence of models, each adding the next effect; report the error per step.

    ``steps``: the effects in order; None lets diagnose choose the next one each time,
    starting from the nominal robot (with a base frame if the data are far from it), and
    stops when no candidate is recommended. ``reregister``: the validation set was measured
    from another tracker position; its measurement frame is registered anew (6 DOF, every
    other parameter kept) before each step's error is taken. The nominal row is the
    nominal robot registered onto the data, as fit, simulate and the report give it.
    """
    with small_matrices(3 * len(meas)):
        return _ladder(robot, tool_mm, meas, steps, folds, seed, noise_mm, validation, max_steps, reregister, progress)


def _ladder(robot, tool_mm, meas, steps, folds, seed, noise_mm, validation, max_steps, reregister, progress) -> list[dict]:
    rows = []
    current = EffectSum()
    fold_of = fold_assignment(len(meas), folds, seed)
    total = (len(steps) if steps is not None else max_steps) + 1

    def record(label: str, model: ErrorModel, cv_rms: float, train_model: ErrorModel | None = None):
        row = {"step": len(rows), "added": label, "effects": model.effects.spec(), "cv_rms_mm": cv_rms,
               "train_rms_mm": Stats.of(residuals(train_model or model, meas)).rms_mm}
        if validation is not None:
            val_st = Stats.of(residuals(refit_base(model, validation) if reregister or train_model is not None else model, validation))
            row["val_rms_mm"], row["val_mean_mm"], row["val_max_mm"] = val_st.rms_mm, val_st.mean_mm, val_st.max_mm
        rows.append(row)

    model = ErrorModel.create(robot, tool_mm, current)
    registered = nominal_model(robot, tool_mm, meas, registered=True)
    record("nominal", model, Stats.of(residuals(registered, meas)).rms_mm, train_model=registered)
    planned = list(steps) if steps is not None else None
    while len(rows) <= max_steps:
        if planned is not None:
            nxt = planned.pop(0) if planned else None
        else:
            report(progress, f"step {len(rows)}: diagnosing", len(rows), total)
            nxt = _diagnosed_step(model, meas, folds, seed, noise_mm, progress)
        if nxt is None:
            break
        report(progress, f"step {len(rows)}: adding {nxt}", len(rows), total)
        current = current + parse_effects(nxt)
        result = fit(robot, tool_mm, current, meas, cv_folds=0, prior=model if len(model.params) else None, seed=seed)
        current = result.model.effects
        model = result.model
        held = held_out_miss(linearise(model, meas, free=inside_bounds(model, free_mask(result))), fold_of)
        record(_step_label(nxt, current), model, rms(held))
    noise = noise_floors.given(noise_mm) if noise_mm is not None else noise_floors.estimate(meas, -residuals(model, meas), len(model.params))
    for row in rows:
        row["noise_floor_mm"] = noise.floor_mm
    report(progress, "done", total, total)
    return rows


def _diagnosed_step(model: ErrorModel, meas: MeasurementSet, folds: int, seed: int, noise_mm: float | None, progress) -> str | None:
    """The next effect for the ladder: the best first step from the nominal robot, else the
    recommended candidate (or combination) diagnose finds (None when there is none)."""
    if not len(model.effects):
        return _first_step(model.robot, model.tool_mm, meas, folds, seed)
    diag = diagnose(model, meas, folds=folds, seed=seed, noise_mm=noise_mm)
    best = [c for c in diag.candidates if c.significant]
    if best:
        return best[0].effect
    return diag.combination.effect if diag.combination is not None and diag.combination.significant else None


def _step_label(step: str, effects) -> str:
    """A ladder step as fitted: a term family without options shows the terms the fit chose."""
    if "[" in step or "," in step:
        return step
    effect = effects.get(step)
    return step if effect is None else effect.spec()


def _first_step(robot, tool_mm, meas, folds, seed) -> str:
    """From the nominal robot, the single effect with the lowest cross-validated error
    (among the effects the catalog marks as first steps: frames and geometry)."""
    fold_of = fold_assignment(len(meas), folds, seed)
    best, best_rms = None, np.inf
    for name in [name for name, cls in CATALOG.items() if cls.first_step]:
        result = fit(robot, tool_mm, parse_effects(name), meas, cv_folds=0, seed=seed)
        held = rms(held_out_miss(linearise(result.model, meas, free=inside_bounds(result.model, free_mask(result))), fold_of))
        if held < best_rms:
            best, best_rms = name, held
    return best
