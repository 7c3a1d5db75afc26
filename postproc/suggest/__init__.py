"""Suggest the poses to measure (issue 32): choose N candidate poses that identify a
model best, from the identification Jacobian of the model's own effects with the
parameters removed that ``fit`` removes (``postproc.model.identify.identifiability``).

``suggest_poses`` is the library entry point; ``postproc suggest-poses`` wraps it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from postproc.errors import InputError
from postproc.model.errormodel import ErrorModel
from postproc.model.identify import identifiability
from postproc.model.measurements import APPROACH, FORCES, MeasurementSet

from . import design
from .candidates import Candidates, load_state_order
from .targets import program_targets

DEFAULT_RANDOM_SHARE = 0.2  # a fifth of the poses drawn at random: robustness against a model that misses an effect
# ... but by default at most DEFAULT_RANDOM_MOST of them: on the simulated machining pass with a truth the model
# lacks an effect of (cyclic joint errors of 0.02 mm RMS at the targets), designs with random share 0, 0.1 and 0.2
# had the same true error at N = 32, 50 and 100 (within +-0.2 um of 8-12 um, 8 seeds, benchmarks/suggest_sim.py
# mismatch): no design from the model can remove an error the model lacks, so the random poses serve as a
# check where the program runs, and a few do that; beyond them each costs the design a chosen pose.
DEFAULT_RANDOM_MOST = 4
# The share is of the poses beyond the fewest fit accepts (random_count): those first poses are all
# needed to determine the model's parameters, and a random one among them costs most (the simulated
# machining pass, fitted: the design with 3-4 random poses of 14-18 had 5-9 % more error than with none, suggest_pass_noise.txt).
# With --program the random share is drawn from this fraction of the candidates, those nearest
# a target in joint space (at least 4 x the random poses): a model that misses an effect is
# then checked where the program runs (benchmarks/suggest.py: 1-3 points of the poses random
# selection needs better than drawing from the whole workspace, in the noise-only prediction).
NEAR_TARGETS_FRACTION = 0.1
DEFAULT_NOISE_MM = 0.02  # per axis, tracker + repeatability (spec/measurements.md)
CRITERION_NAMES = {"D": "D-optimal (O1: log det of the information)", "E": "E-optimal (O3: its smallest eigenvalue)",
                   "A": "A-optimal (trace of the parameter covariance)", "I": "I-optimal (mean predicted error variance at the program's targets, or over the candidates)"}
RANDOM_DRAWS = 8  # random designs averaged for the comparison curve

__all__ = ["Candidates", "Suggestion", "program_targets", "suggest_poses", "DEFAULT_RANDOM_SHARE", "DEFAULT_RANDOM_MOST", "DEFAULT_NOISE_MM"]


@dataclass(frozen=True)
class Suggestion:
    chosen: np.ndarray  # candidate rows, in measuring order
    ids: tuple[str, ...]
    criterion: str  # D, E, A or I
    n_random: int  # how many of the chosen were drawn at random
    expected_rms_mm: float  # predicted 3-D RMS of the identified model's error at the targets (or over the candidates)
    random_rms_mm: float  # the same for random designs of the same size (mean of RANDOM_DRAWS)
    random_equivalent_n: int | None  # poses random selection needs for expected_rms_mm (None: more than the curve spans)
    std: dict[str, float]  # expected standard error of each identified parameter, in its unit
    units: dict[str, str]  # each identified parameter's unit
    fixed: dict[str, str]  # parameters the candidates cannot separate, and why (as fit reports them)
    condition_number: float  # of the identification Jacobian of measured + chosen poses (columns in typical sizes)
    curve: tuple[tuple[int, float, float], ...]  # (N, expected RMS suggested, expected RMS random), mm
    swaps: int  # poses of the greedy design the refinement (exchange and restarts) replaced
    where: str  # what expected_rms_mm is measured over
    notes: tuple[str, ...] = field(default_factory=tuple)
    bound_rms_mm: float | None = None  # with a program: no design of N distinct new poses from the candidates (with the measured ones) predicts better

    def as_json(self) -> dict:
        return {"chosen": list(self.ids), "criterion": self.criterion, "expected_rms_mm": self.expected_rms_mm,
                "random_rms_mm": self.random_rms_mm, "random_equivalent_n": self.random_equivalent_n, "n_random": self.n_random,
                "condition_number": self.condition_number, "expected_std": self.std, "units": self.units, "fixed": self.fixed,
                "curve": [{"n": n, "expected_rms_mm": s, "random_rms_mm": r} for n, s, r in self.curve], "notes": list(self.notes),
                "bound_rms_mm": self.bound_rms_mm}


def suggest_poses(model: ErrorModel, candidates: Candidates, n: int, *, criterion: str = "D", targets_q: np.ndarray | None = None,
                  measured: MeasurementSet | None = None, random_share: float | None = None, noise_mm: float = DEFAULT_NOISE_MM,
                  seed: int = 0, progress: Callable[[str], None] | None = None) -> Suggestion:
    """Choose ``n`` of ``candidates`` to measure next, for the effects of ``model`` (its
    parameter values are where the Jacobian is taken: nominal, or a fitted model's).

    ``criterion``: D, E, A or I (the mean predicted error variance over the candidates); with
    ``targets_q`` (joints at a program's targets) the design minimises it there (I). ``measured``: the
    poses measured already (their information is counted; their ids are not chosen again).
    ``random_share``: the fraction drawn at random first (seeded), kept through the search, of the
    poses beyond the fewest fit accepts (``random_count``); None: DEFAULT_RANDOM_SHARE of them, at
    most DEFAULT_RANDOM_MOST poses (``default_random_count``); with ``targets_q`` drawn from the
    candidates nearest the targets (``NEAR_TARGETS_FRACTION``). The exchange restarts at small N
    (``design.refine``) draw from their own stream of the same seed.
    """
    say = progress or (lambda msg: None)
    criterion = _check_options(criterion, targets_q, n, random_share, noise_mm)
    say("identification Jacobian")
    info = _information(model, candidates, measured, targets_q, noise_mm)
    excluded = _measured_already(candidates, measured)
    available = int((~excluded).sum())
    k = info.problem.blocks.shape[-1]
    m = 0 if measured is None else len(measured)
    if n > available:
        raise InputError(f"-n {n}: only {available} candidate poses{' not measured yet' if m else ''} to choose from")
    least = fewest_poses(len(model.params), k)
    if n + m < least:
        raise InputError(f"-n {n}: {n + m} poses give {3 * (n + m)} equations; fit needs at least {3 * least} for the model's "
                         f"{len(model.params)} parameters ({k} of them identifiable from these candidates): choose at least {least - m}")
    rng = np.random.default_rng(seed)
    n_random = default_random_count(n, least - m) if random_share is None else random_count(random_share, n, least - m)
    pool = np.nonzero(~excluded)[0]
    if targets_q is not None and n_random:  # region-targeted: robustness where the program runs
        pool = near_targets(candidates.q_deg, targets_q, pool, max(4 * n_random, int(NEAR_TARGETS_FRACTION * len(pool))))
    fixed = rng.choice(pool, size=n_random, replace=False) if n_random else np.zeros(0, dtype=int)
    say(f"greedy search ({n} poses from {available})")
    greedy_order = design.greedy(info.problem, n, criterion, fixed, excluded, say=say)
    say("exchange refinement")
    restarts_rng = np.random.default_rng([seed, 1])  # its own stream: the random share and the curve's draws stay those of the seed
    final, swaps = design.refine(info.problem, greedy_order, criterion, n_random, restarts_rng, excluded, say=say)
    start = measured.q_deg[-1] if m else None
    forces = candidates.group(FORCES)
    order = final[load_state_order(candidates.q_deg[final], None if forces is None else forces[final], start)]
    return _summarise(info, candidates, order, greedy_order, criterion, n_random, swaps, excluded, rng, m)


def random_count(share: float, n: int, needed: int) -> int:
    """Random poses among n: ``share`` of those beyond the ``needed`` ones (the fewest fit
    accepts, less the poses measured already), rounded; none while n is at most that."""
    return int(round(share * max(n - max(needed, 0), 0)))


def default_random_count(n: int, needed: int) -> int:
    """The random poses of the default rule: DEFAULT_RANDOM_SHARE of those beyond the needed ones, at
    most DEFAULT_RANDOM_MOST (their share of n shrinks as 4 / n from N = 34 for 13 needed)."""
    return min(random_count(DEFAULT_RANDOM_SHARE, n, needed), DEFAULT_RANDOM_MOST)


def near_targets(q_deg: np.ndarray, targets_q: np.ndarray, pool: np.ndarray, size: int) -> np.ndarray:
    """The ``size`` candidates of ``pool`` nearest a target in joint space (degrees, Euclidean)."""
    dist, _ = cKDTree(np.asarray(targets_q, dtype=float)).query(q_deg[pool])
    return np.sort(pool[np.argsort(dist, kind="stable")[: min(size, len(pool))]])


SAME_POSE_DEG = 1e-3  # joints this close (each) are the same pose


def _measured_already(cands: Candidates, measured: MeasurementSet | None) -> np.ndarray:
    """(C,) True for candidates that are poses of the measured set: the same id with the same
    joints. The same id at other joints is refused: the joined CSVs would mix two poses."""
    out = np.zeros(len(cands), dtype=bool)
    if measured is None:
        return out
    _, c, m = np.intersect1d(np.asarray(cands.ids, dtype=str), np.asarray(measured.ids, dtype=str), return_indices=True)
    other = np.abs(cands.q_deg[c] - measured.q_deg[m]).max(axis=1) > SAME_POSE_DEG
    if other.any():
        k = int(np.argmax(other))
        raise InputError(f"{cands.source}: candidate id '{cands.ids[c[k]]}' is the id of another pose in {measured.source} "
                         f"(line {measured.line_of(m[k])}); ids must name one pose")
    out[c] = True
    return out


def fewest_poses(n_params: int, n_identifiable: int) -> int:
    """The fewest poses fit accepts: 3 equations each for all parameters, more than the identifiable ones."""
    return max(-(-n_params // 3), n_identifiable // 3 + 1)


def _check_options(criterion: str, targets_q, n: int, random_share: float, noise_mm: float) -> str:
    if criterion not in (*design.CRITERIA, "I"):
        raise InputError(f"--criterion: '{criterion}' is not one of D, E, A, I")
    if n < 1:
        raise InputError("-n must be at least 1")
    if random_share is not None and not 0.0 <= random_share < 1.0:
        raise InputError(f"--random-share: {random_share:g} must be at least 0 and below 1")
    if not noise_mm > 0:
        raise InputError(f"--noise: {noise_mm:g} mm must be positive")
    return "I" if targets_q is not None else criterion


@dataclass(frozen=True)
class _Information:
    problem: design.Problem
    free: np.ndarray  # (P,) identifiable parameters of the model
    fixed: dict[str, str]
    scale: np.ndarray  # (K,) typical size of each identifiable parameter
    names: tuple[str, ...]
    units: dict[str, str]
    evaluation: np.ndarray  # (T, 3, K) position Jacobian (mm per typical size) where expected_rms_mm is taken
    where: str
    region: bool  # evaluated at a program's targets


def _information(model: ErrorModel, cands: Candidates, measured: MeasurementSet | None, targets_q, noise_mm: float) -> _Information:
    """Per-candidate information blocks, the prior of the measured poses, the target Jacobian."""
    _require_columns(model, cands, measured, targets_q)
    parts = [cands.q_deg] + ([] if measured is None else [measured.q_deg])
    groups = {name: _group(cands, measured, name) for name in _COLUMNS}
    prep = model.prepare(q_deg=np.vstack(parts), force_n=groups["force"], approach=groups["approach"], temp_c=groups["temp"], time_s=groups["t"])
    free, fixed = identifiability(model, prep, np.ones(len(model.params), dtype=bool))
    _, jac = model.evaluate(prep)
    scale = np.array([p.scale for p in model.params])[free]
    jac = jac[:, :, free] * scale
    c = len(cands)
    blocks = jac[:c] / noise_mm
    prior = np.einsum("cik,cil->kl", jac[c:], jac[c:]) / noise_mm**2 if measured is not None else None
    if targets_q is not None:
        _, tjac = model.evaluate(model.prepare(q_deg=np.asarray(targets_q, dtype=float)))
        evaluation, where = tjac[:, :, free] * scale, f"the program's {len(targets_q)} targets"
    else:
        evaluation, where = jac[:c], f"the {c} candidate poses"
    problem = design.Problem.of(blocks, prior, evaluation)
    kept = [p for p, f in zip(model.params, free) if f]
    return _Information(problem, free, fixed, scale, tuple(p.name for p in kept), {p.name: p.unit for p in kept}, evaluation, where,
                        targets_q is not None)


_COLUMNS = {"force": FORCES, "approach": APPROACH, "temp": ("temp",), "t": ("t",)}


_FIELD = {"force": "force_n", "approach": "approach", "temp": "temp_c", "t": "time_s"}


def _group(cands: Candidates, measured: MeasurementSet | None, name: str):
    """A column group over candidates then measured poses; None where either lacks it
    (then no effect needs it: ``_require_columns`` has checked)."""
    mine = cands.group(_COLUMNS[name])
    if mine is None:
        return None
    mine = mine[:, 0] if mine.shape[1] == 1 else mine
    if measured is None:
        return mine
    theirs = getattr(measured, _FIELD[name])
    return None if theirs is None else np.concatenate([mine, theirs])


def _require_columns(model: ErrorModel, cands: Candidates, measured, targets_q) -> None:
    """Effects that need forces, approach directions or temperature need them for every pose."""
    for effect in model.effects:
        for group in effect.needs:
            cols = ",".join(_COLUMNS[group])
            if cands.group(_COLUMNS[group]) is None:
                raise InputError(f"{cands.source}: effect '{effect.name}' needs column(s) {cols} for each candidate (the values it will be "
                                 "measured with); add them to the candidates CSV")
            if measured is not None and not measured.has(group):
                raise InputError(f"{measured.source}: effect '{effect.name}' needs column(s) {cols}, which the measured set lacks")
            if targets_q is not None:
                raise InputError(f"--program: effect '{effect.name}' needs {cols} at the program's targets, which a program does not give; "
                                 "leave --program out or the effect out")


def _covariance(problem: design.Problem, info: np.ndarray) -> np.ndarray:
    return np.linalg.inv(info + problem.ridge * np.eye(len(info)))


def _expected_rms(info_: _Information, cov: np.ndarray) -> float:
    """3-D RMS over the evaluation points of the predicted position error's standard deviation, mm."""
    return float(np.sqrt(np.sum(info_.problem.weight * cov)))  # trace(G^T G / T  cov): weight is symmetric


def _summarise(info_: _Information, cands: Candidates, order, greedy_order, criterion, n_random, swaps, excluded, rng, m) -> Suggestion:
    problem = info_.problem
    full = problem.information(order)
    cov = _covariance(problem, full)
    expected = _expected_rms(info_, cov)
    std = {name: float(s * np.sqrt(max(cov[i, i], 0.0))) for i, (name, s) in enumerate(zip(info_.names, info_.scale))}
    eig = np.linalg.eigvalsh(full)
    cond = float(np.sqrt(eig[-1] / eig[0])) if eig[0] > 0 else float("inf")
    curve = _curve(info_, greedy_order, order, excluded, rng, m)
    random_same = next((r for nn, _, r in curve if nn == len(order)), float("nan"))
    equivalent = next((nn for nn, _, r in curve if r <= expected), None)
    notes = []
    if cands.rounded_deg > 0:
        notes.append(f"candidate joints rounded to 4 decimals (the precision of the robot program), by at most {cands.rounded_deg:.2g} deg")
    bound = None
    if info_.region:  # the I-optimal bound for len(order) new distinct poses (each measured once, as the design's are), on top of the measured ones
        bound = float(np.sqrt(max(design.relaxed_i_design(problem, len(order), excluded=excluded).lower_bound, 0.0)))
    return Suggestion(chosen=order, ids=tuple(cands.ids[i] for i in order), criterion=criterion, n_random=n_random, bound_rms_mm=bound,
                      expected_rms_mm=expected, random_rms_mm=float(random_same), random_equivalent_n=equivalent, std=std, units=info_.units,
                      fixed=info_.fixed, condition_number=cond, curve=curve, swaps=swaps, where=info_.where, notes=tuple(notes))


def _curve(info_: _Information, greedy_order, final, excluded, rng, m: int) -> tuple[tuple[int, float, float], ...]:
    """Expected RMS against N: the suggested design's prefixes (in the greedy order; the
    refined design at its own N) and random designs (mean of RANDOM_DRAWS), from the
    smallest N that can identify the parameters to 4 N (as far as the candidates go)."""
    problem = info_.problem
    k = problem.blocks.shape[-1]
    n = len(final)
    pool = np.nonzero(~excluded)[0]
    low = max(fewest_poses(len(info_.free), k) - m, 1)
    top = min(len(pool), 4 * n)
    grid = np.unique(np.concatenate([np.geomspace(low, top, 24).round().astype(int), [n]]))
    grid = grid[(grid >= low) & (grid <= top)]
    draws = [rng.permutation(pool) for _ in range(RANDOM_DRAWS)]
    rows = []
    for g in grid:
        if g == n:
            suggested = _expected_rms(info_, _covariance(problem, problem.information(final)))
        elif g < n:
            suggested = _expected_rms(info_, _covariance(problem, problem.information(greedy_order[:g])))
        else:
            suggested = float("nan")
        rand = float(np.mean([_expected_rms(info_, _covariance(problem, problem.information(d[:g]))) for d in draws]))
        rows.append((int(g), suggested, rand))
    return tuple(rows)
