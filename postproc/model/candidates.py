"""Which catalog effect (or combination) the model is missing, judged against the noise floor.

Each candidate is added to the model as fitted, linearised there (``held_out``), and
cross-validated on the same folds as the model; its worth is how far it brings the
cross-validated RMS towards the noise floor:

    progress = (RMS_cv(model) - RMS_cv(model + candidate)) / (RMS_cv(model) - floor)

and how stable that is: the share of bootstrap resamples of the poses in which the
progress still reaches the threshold. A candidate is recommended only when both hold:
``MIN_PROGRESS`` of the way and ``MIN_STABILITY`` of the resamples. (For a term family
the message also says how often best-subset selection chose the same terms.) When no single
candidate is, the best few together are tried the same way (a combination).
"""

from __future__ import annotations

from dataclasses import dataclass
from dataclasses import replace as _replace

import numpy as np
from scipy import stats as sps

from postproc.progress import report, silent

from .effects import EffectSum, parse_effects
from .errormodel import ErrorModel
from .held_out import Linearised, held_out_miss, inside_bounds, linearise
from .identify import fit, free_mask, resolve_terms
from .measurements import MeasurementSet

#: a candidate must bring the cross-validated RMS this share of the way to the noise floor
MIN_PROGRESS = 0.20
#: ... in at least this share of bootstrap resamples of the poses
MIN_STABILITY = 0.80
BOOTSTRAP = 400
#: combinations of at most this many of the best candidates are tried
MAX_COMBINED = 3


@dataclass(frozen=True)
class Scored:
    """One candidate (or combination) as the data judge it."""

    spec: str  # the effects added, as fitted (a term family with the terms chosen)
    added: bool  # False: a term family for which the data support no term
    sq: np.ndarray  # (N,) held-out squared 3-D error with it added
    cv_rms_mm: float
    explained: float  # held-out share of the residual variance it removes
    progress: float  # share of the way from the model's CV RMS to the noise floor
    stability: float  # share of resamples in which the progress reaches MIN_PROGRESS
    p_value: float  # paired one-sided test of the per-pose held-out gain
    selection_note: str = ""  # how a term family's terms were chosen, and how often (shown, not gated:
    # which neighbouring order carries a harmonic may vary between resamples while the gain holds)

    @property
    def recommended(self) -> bool:
        return self.added and self.progress >= MIN_PROGRESS and self.stability >= MIN_STABILITY


def judge(spec: str, base_sq: np.ndarray, sq: np.ndarray, floor_mm: float, rng_seed: int, added: bool = True, note: str = "") -> Scored:
    """Score held-out squared errors ``sq`` against the model's ``base_sq`` (both (N,))."""
    base_rms, rms = float(np.sqrt(base_sq.mean())), float(np.sqrt(sq.mean()))
    gap = base_rms - floor_mm
    progress = (base_rms - rms) / gap if gap > 0 else 0.0
    idx = np.random.default_rng(rng_seed).integers(0, len(sq), size=(BOOTSTRAP, len(sq)))
    b_base, b_rms = np.sqrt(base_sq[idx].mean(axis=1)), np.sqrt(sq[idx].mean(axis=1))
    b_gap = b_base - floor_mm
    b_progress = np.where(b_gap > 0, (b_base - b_rms) / np.where(b_gap > 0, b_gap, 1.0), 0.0)
    stability = float(np.mean(b_progress >= MIN_PROGRESS))
    gain = base_sq - sq
    p = float(sps.ttest_1samp(gain, 0.0, alternative="greater").pvalue) if np.std(gain) > 0 else 1.0
    explained = max(0.0, 1.0 - sq.mean() / base_sq.mean()) if added else 0.0
    return Scored(spec, added, sq, rms, explained, progress if added else 0.0, stability if added else 0.0, p if added else 1.0, note)


def with_effects(model: ErrorModel, extra: EffectSum) -> ErrorModel:
    """The fitted model with more effects at their initial values (frames kept)."""
    grown = ErrorModel.create(model.robot, model.tool_mm, model.effects + extra)
    grown = grown.with_values({k: v for k, v in model.as_dict().items() if k in {p.name for p in grown.params}})
    return _replace(grown, base_rotation=model.base_rotation, base_translation=model.base_translation)


def score_candidates(model: ErrorModel, meas: MeasurementSet, names: list[str], base_sq: np.ndarray, fold_of: np.ndarray, floor_mm: float,
                     seed: int = 0, progress=silent) -> tuple[list[Scored], Scored | None, float]:
    """Every candidate scored (best first), the best combination of the top few when none
    is recommended alone (None when there is no combination to try), and the noise floor
    they were judged against (``floor_mm``, or the lowest held-out RMS when lower)."""
    scored = []
    for i, name in enumerate(names):
        report(progress, f"trying {name}", i, len(names) + 1)
        # A term family chooses its terms on the residual of the model as it is.
        effects, notes = resolve_terms(model.robot, model.tool_mm, model.effects + parse_effects(name), meas, prior=model, seed=seed)
        extra = EffectSum(tuple(e for e in effects if e.name not in set(model.effects.names())))
        note = "; ".join(n.split(": ", 1)[1] for n in notes)
        if not len(extra):
            scored.append(judge(name, base_sq, base_sq, floor_mm, seed, added=False, note=note))
            continue
        sq = _held_out_sq(linearise(with_effects(model, extra), meas), fold_of)
        scored.append(judge(extra.spec(), base_sq, sq, floor_mm, seed, note=note))
    # A held-out RMS is never below the noise (in expectation): a candidate that goes lower
    # than the floor's estimate shows the estimate is too high; judge them all against it.
    lowest = min((s.cv_rms_mm for s in scored if s.added), default=np.inf)
    if lowest < floor_mm:
        floor_mm = lowest
        scored = [judge(s.spec, base_sq, s.sq, floor_mm, seed, s.added, s.selection_note) for s in scored]
    scored = [confirm(model, meas, s, base_sq, fold_of, floor_mm, seed) if s.recommended else s for s in scored]
    scored.sort(key=lambda s: (-s.explained, s.p_value))
    report(progress, "trying combinations", len(names), len(names) + 1)
    return scored, _best_combination(model, meas, scored, base_sq, fold_of, floor_mm, seed), floor_mm


def confirm(model: ErrorModel, meas: MeasurementSet, scored: Scored, base_sq: np.ndarray, fold_of: np.ndarray, floor_mm: float, seed: int) -> Scored:
    """A candidate about to be recommended, scored again at the real fit with it added
    (started from the model): its parameters within their bounds, the rest refitted."""
    result = fit(model.robot, model.tool_mm, model.effects + parse_effects(scored.spec), meas, cv_folds=0, prior=model, seed=seed)
    free = inside_bounds(result.model, free_mask(result))
    sq = _held_out_sq(linearise(result.model, meas, free=free), fold_of)
    return judge(scored.spec, base_sq, sq, floor_mm, seed, note=scored.selection_note)


def _held_out_sq(lin: Linearised, fold_of: np.ndarray) -> np.ndarray:
    return np.sum(held_out_miss(lin, fold_of) ** 2, axis=1)


def _best_combination(model, meas, scored: list[Scored], base_sq, fold_of, floor_mm, seed) -> Scored | None:
    """The fewest of the best candidates that together are recommended, else all of the
    top ``MAX_COMBINED`` together (what the catalog can do at best)."""
    if any(s.recommended for s in scored):
        return None
    useful = [s for s in scored if s.added and s.explained > 0][:MAX_COMBINED]
    if len(useful) < 2:
        return None
    combined = None
    for k in range(2, len(useful) + 1):
        spec = ",".join(s.spec for s in useful[:k])
        sq = _held_out_sq(linearise(with_effects(model, parse_effects(spec)), meas), fold_of)
        combined = judge(spec, base_sq, sq, floor_mm, seed)
        if combined.recommended:
            combined = confirm(model, meas, combined, base_sq, fold_of, floor_mm, seed)
            if combined.recommended:
                break
    return combined
