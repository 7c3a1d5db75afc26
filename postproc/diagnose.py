"""Where a model fails and which physical effect is missing.

1. Compare: residual statistics overall, per axis, and broken down by workspace region
   (theta1 sector, radius, height), each joint's angle, load, temperature, time and
   approach direction.
2. Where it fails: for every variable, a one-way analysis of variance of the residual
   across bins of that variable; p-values Holm-corrected over all variables, so noise is
   not reported as structure.
3. What is missing: each catalog effect not in the model whose columns the data have is
   added and the *whole* model refitted; k-fold held-out errors (the same folds for all)
   give the fraction of residual variance it explains and the RMS with it added. A paired
   one-sided test on the per-pose held-out squared errors, Holm-corrected over the
   candidates, says whether the gain is beyond noise.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field

import numpy as np
from scipy import stats as sps

from . import kinematics as kin
from .effects import CATALOG, EffectSum, parse_effects
from .errormodel import ErrorModel
from .identify import Stats, cross_validation_errors, fit, free_mask, refit_base, residuals
from .measurements import MeasurementSet

ALPHA = 0.05
MIN_EXPLAINED = 0.02  # a candidate must remove at least 2 % of the held-out residual variance
BINS = 5


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
    explained: float
    rms_if_added_mm: float
    p_value: float
    p_adjusted: float
    significant: bool
    message: str


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

    def as_json(self) -> dict:
        return {
            "rms_mm": self.stats.rms_mm,
            "mean_mm": self.stats.mean_mm,
            "max_mm": self.stats.max_mm,
            "rms_axis_mm": list(self.stats.rms_axis_mm),
            "n": self.stats.n,
            "cv_rms_mm": self.cv_rms_mm,
            "noise_floor_mm": self.noise_floor_mm,
            "candidates": [
                {
                    "effect": c.effect,
                    "explained": c.explained,
                    "rms_if_added_mm": c.rms_if_added_mm,
                    "p_value": c.p_adjusted,
                    "significant": c.significant,
                    "message": c.message,
                }
                for c in self.candidates
            ],
            "structure": [
                {"variable": b.variable, "eta2": b.eta2, "p_value": b.p_adjusted, "significant": b.significant}
                for b in self.breakdowns
            ],
            "findings": list(self.findings),
        }


def holm(p_values: list[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (family-wise error control), in the input order."""
    p = np.asarray(p_values, dtype=float)
    m = len(p)
    order = np.argsort(p)
    adjusted = np.empty(m)
    running = 0.0
    for rank, idx in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[idx]))
        adjusted[idx] = running
    return adjusted.tolist()


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
    if meas.force_n is not None:
        out["load"] = ("load |F|", "N", np.linalg.norm(meas.force_n, axis=1), False)
    if meas.temp_c is not None:
        out["temperature"] = ("temperature", "degC", meas.temp_c, False)
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


def _message(spec: str, explained: float) -> str:
    effect = parse_effects(spec).effects[0]
    return f"{effect.describe_finding()}; {spec} explains {100 * explained:.0f}% of them"


def diagnose(
    model: ErrorModel,
    meas: MeasurementSet,
    *,
    folds: int = 5,
    seed: int = 0,
    noise_mm: float = 0.02,
    candidates: list[str] | None = None,
    progress=lambda msg: None,
    files: "Files | None" = None,
) -> Diagnosis:
    """Compare the model with measurements, find structure, rank the missing effects.

    ``files``: the model and measurement paths the findings' commands name (placeholders
    MODEL.json and MEAS.csv when not given)."""
    resid = residuals(model, meas)  # predicted - measured
    miss = -resid  # measured - predicted: what the model misses
    variables = explanatory_variables(model, meas)
    breakdowns = [b for name, (label, unit, values, cat) in variables.items() if (b := _breakdown(name, label, unit, values, cat, miss)) is not None]
    adjusted = holm([b.p_value for b in breakdowns]) if breakdowns else []
    breakdowns = [Breakdown(**{**b.__dict__, "p_adjusted": p}) for b, p in zip(breakdowns, adjusted)]
    breakdowns.sort(key=lambda b: (not b.significant, -b.eta2))

    progress("refitting the model with cross-validation")
    base_fit = fit(model.robot, model.tool_mm, model.effects, meas, cv_folds=0, prior=model, seed=seed)
    base_err = cross_validation_errors(base_fit.model, meas, free_mask(base_fit), folds, seed=seed)
    base_sq = np.sum(base_err**2, axis=1)
    base_mse = float(base_sq.mean())

    names = candidate_effects(model, meas) if candidates is None else candidates
    ranked = _rank_candidates(model, meas, names, base_fit.model, base_sq, folds, seed, progress)

    floor = float(noise_mm * np.sqrt(3.0))
    cv_rms = float(np.sqrt(base_mse))
    files = files or Files()
    findings = _findings(breakdowns, ranked, cv_rms, floor, files, model)
    if model.residual is not None:
        findings.append(with_command(
            f"The model's {model.residual.kind} predictor is in the comparison above; the candidate effects and the "
            "cross-validated RMS concern its physics part (the predictor is fitted on what the physics leaves).",
            files.evaluate_command()))
    return Diagnosis(Stats.of(miss), cv_rms, floor, tuple(breakdowns), tuple(ranked), tuple(findings), miss, variables)


def _rank_candidates(model: ErrorModel, meas: MeasurementSet, names: list[str], base: ErrorModel, base_sq: np.ndarray, folds: int, seed: int, progress) -> list[Candidate]:
    """Add each candidate to the whole model, refit, and compare held-out errors pose by pose
    with the model as it is (paired one-sided test, Holm-corrected over the candidates)."""
    base_mse = float(base_sq.mean())
    raw = []
    for name in names:
        progress(f"trying {name}")
        result = fit(model.robot, model.tool_mm, model.effects + parse_effects(name), meas, cv_folds=0, prior=base, seed=seed)
        added = [e for e in result.model.effects if e.name not in set(model.effects.names())]
        if not added:  # e.g. a term family when the data support no term
            raw.append((name, 0.0, float(np.sqrt(base_mse)), 1.0, ""))
            continue
        err = cross_validation_errors(result.model, meas, free_mask(result), folds, seed=seed)
        sq = np.sum(err**2, axis=1)
        mse = float(sq.mean())
        gain = base_sq - sq
        p = float(sps.ttest_1samp(gain, 0.0, alternative="greater").pvalue) if np.std(gain) > 0 else 1.0
        chosen_how = "".join(f" ({n.split('how often they were chosen: ', 1)[1]}" for n in result.notes if "how often they were chosen: " in n)
        raw.append((added[0].spec(), 1.0 - mse / base_mse, float(np.sqrt(mse)), p, chosen_how))  # terms a fit chose, with their stability
    adjusted = holm([r[3] for r in raw]) if raw else []
    ranked = []
    for (spec, explained, rms, p, chosen_how), p_adj in zip(raw, adjusted):
        significant = p_adj < ALPHA and explained >= MIN_EXPLAINED
        verdict = "" if significant else " (not beyond noise: leave it out)"
        ranked.append(Candidate(spec, max(0.0, explained), rms, p, p_adj, significant, _message(spec, max(0.0, explained)) + chosen_how + verdict))
    ranked.sort(key=lambda c: (-c.explained, c.p_adjusted))
    return ranked


#: Between a finding's words and the command that acts on it (``split_command`` takes it apart).
COMMAND_MARK = " Run: "


@dataclass(frozen=True)
class Files:
    """The paths a finding's command names."""

    model: str = "MODEL.json"
    meas: str = "MEAS.csv"

    def next_model(self) -> str:
        stem = self.model[:-5] if self.model.endswith(".json") else self.model
        return f"{stem}_next.json"

    def fit_command(self, spec: str) -> str:
        """Refit the model with one more effect (its terms as the diagnosis chose them)."""
        return f"postproc fit {_quote(self.meas)} --from {_quote(self.model)} --effects {_quote('+' + spec)} --cv 0 -o {_quote(self.next_model())}"

    def predictor_command(self, model) -> str:
        """Keep the physics and learn what it leaves (a hybrid model)."""
        return f"postproc fit {_quote(self.meas)} --from {_quote(self.model)} --effects {_quote(model.effects.spec())} --predictor gpr --cv 0 -o {_quote(self.next_model())}"

    def evaluate_command(self) -> str:
        return f"postproc evaluate {_quote(self.model)} {_quote(self.meas)}"

    def use_command(self) -> str:
        """The model is as good as the data allow: compensate a program with it."""
        return f"postproc compensate PROGRAM --model {_quote(self.model)} -o PROGRAM_compensated"


def _quote(text: str) -> str:
    return shlex.quote(text)


def with_command(text: str, command: str) -> str:
    return f"{text.rstrip()}{COMMAND_MARK}{command}"


def split_command(finding: str) -> tuple[str, str]:
    """A finding's words and the command that acts on it."""
    text, _, command = finding.rpartition(COMMAND_MARK)
    return (text, command) if text else (finding, "")


def _findings(breakdowns, ranked, cv_rms, floor, files: Files, model) -> list[str]:
    """Plain-language findings, each ending with the command that acts on it. Only a
    significant candidate is ever recommended; structure with no significant candidate
    behind it points at a data-driven predictor, never at an effect."""
    out = []
    significant = [c for c in ranked if c.significant]
    at_floor = cv_rms < 1.25 * floor
    if significant:
        action = files.fit_command(significant[0].effect)
    elif at_floor:
        action = files.use_command()
    else:
        action = files.predictor_command(model)
    structured = [b for b in breakdowns if b.significant]
    for b in structured[:4]:
        axis = int(np.argmax(np.abs(np.array(b.mean_mm)).max(axis=0)))
        spread = np.ptp(np.array(b.mean_mm)[:, axis])
        why = f"residual {'xyz'[axis]} varies with {b.label} (bin means span {spread:.3f} mm, {100 * b.eta2:.0f}% of residual variance, p = {b.p_adjusted:.1e})"
        if significant:
            hint = f"; of the catalog's effects, {significant[0].effect} explains the most of the residual."
        elif at_floor:
            hint = "; the model is within the noise floor all the same, nothing to add."
        else:
            hint = "; no catalog effect explains it beyond noise, a data-driven predictor may."
        out.append(with_command(why + hint, action))
    if significant:
        best = significant[0]
        out.append(with_command(best.message[0].upper() + best.message[1:] + f": add it (cross-validated RMS {cv_rms:.4f} -> {best.rms_if_added_mm:.4f} mm).", action))
    else:
        text = (
            f"No candidate explains the residual beyond noise. Cross-validated RMS {cv_rms:.4f} mm against a noise floor of "
            f"{floor:.4f} mm ({cv_rms / floor:.2f} x)"
        )
        text += ": the model is as good as the data allow; use it." if at_floor else ": what is left is not in the catalog; learn it with a data-driven predictor."
        out.append(with_command(text, action))
    if not structured:
        out.append(with_command("No variable shows structure in the residual beyond chance.", action))
    return out


def ladder(
    robot,
    tool_mm,
    meas: MeasurementSet,
    steps: list[str] | None = None,
    *,
    folds: int = 5,
    seed: int = 0,
    noise_mm: float = 0.02,
    validation: MeasurementSet | None = None,
    max_steps: int = 8,
    reregister: bool = False,
    progress=lambda msg: None,
) -> list[dict]:
    """Fit a sequence of models, each adding the next effect; report the error per step.

    ``steps``: the effects in order; None lets diagnose choose the next one each time,
    starting from the nominal robot (with a base frame if the data are far from it), and
    stops when no candidate is significant. ``reregister``: the validation set was measured
    from another tracker position; its measurement frame is registered anew (6 DOF, every
    other parameter kept) before each step's error is taken.
    """
    rows = []
    current = EffectSum()
    model = ErrorModel.create(robot, tool_mm, current)

    def record(label: str, model: ErrorModel, cv_rms: float):
        row = {"step": len(rows), "added": label, "effects": model.effects.spec(), "cv_rms_mm": cv_rms, "train_rms_mm": Stats.of(residuals(model, meas)).rms_mm}
        if validation is not None:
            val_st = Stats.of(residuals(refit_base(model, validation) if reregister else model, validation))
            row["val_rms_mm"], row["val_mean_mm"], row["val_max_mm"] = val_st.rms_mm, val_st.mean_mm, val_st.max_mm
        rows.append(row)

    nominal_err = residuals(model, meas)
    record("nominal", model, float(np.sqrt(np.mean(np.sum(nominal_err**2, axis=1)))))
    planned = list(steps) if steps is not None else None
    while len(rows) <= max_steps:
        if planned is not None:
            nxt = planned.pop(0) if planned else None
        else:
            progress(f"step {len(rows)}: diagnosing")
            nxt = _diagnosed_step(model, meas, folds, seed, noise_mm, progress)
        if nxt is None:
            break
        progress(f"step {len(rows)}: adding {nxt}")
        current = current + parse_effects(nxt)
        result = fit(robot, tool_mm, current, meas, cv_folds=0, prior=model if len(model.params) else None, seed=seed)
        current = result.model.effects
        err = cross_validation_errors(result.model, meas, free_mask(result), folds, seed=seed)
        model = result.model
        record(_step_label(nxt, current), model, float(np.sqrt(np.mean(np.sum(err**2, axis=1)))))
    return rows


def _diagnosed_step(model: ErrorModel, meas: MeasurementSet, folds: int, seed: int, noise_mm: float, progress) -> str | None:
    """The next effect for the ladder: the best first step from the nominal robot, else the
    most significant candidate diagnose finds (None when none is significant)."""
    if not len(model.effects):
        return _first_step(model.robot, model.tool_mm, meas, folds, seed)
    diag = diagnose(model, meas, folds=folds, seed=seed, noise_mm=noise_mm, progress=progress)
    best = [c for c in diag.candidates if c.significant]
    return best[0].effect if best else None


def _step_label(step: str, effects) -> str:
    """A ladder step as fitted: a term family without options shows the terms the fit chose."""
    if "[" in step:
        return step
    effect = effects.get(step)
    return step if effect is None else effect.spec()


def _first_step(robot, tool_mm, meas, folds, seed) -> str:
    """From the nominal robot, the single effect with the lowest cross-validated error
    (among the effects the catalog marks as first steps: frames and geometry)."""
    best, best_rms = None, np.inf
    for name in [name for name, cls in CATALOG.items() if cls.first_step]:
        result = fit(robot, tool_mm, parse_effects(name), meas, cv_folds=0, seed=seed)
        err = cross_validation_errors(result.model, meas, free_mask(result), folds, seed=seed)
        rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
        if rms < best_rms:
            best, best_rms = name, rms
    return best
