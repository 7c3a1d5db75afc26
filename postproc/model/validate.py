"""Evaluation protocols: how well a model fitted on some poses predicts poses it has not seen.

A single training or random-split figure flatters a model on data whose poses come in
groups: the ~20 orientations of one grid point, the poses of one measuring session, the
two arm configurations of one probe pose. Each protocol here holds out a whole group, so
the figure is the error on poses the fit could not have interpolated:

- ``random``: a random share of the poses (the optimistic reference);
- ``points``: every k-th commanded position with all its orientations (column ``point``);
- ``sessions``: each measuring session in turn (column ``session``, else gaps in ``t``);
  each held-out session's rigid offset is reported, and a session that moves as a whole
  is flagged;
- ``series``: another series (another tracker placement): the 6-DOF tracker frame is
  re-registered on one half of its commanded positions and scored on the other half, and
  the other way round, against that series' own training ceiling (the same effects
  fitted on it).

Every protocol reports the error (mean, median, p95, max, RMS of the 3-D error, mm) and
the distance of each test pose to the nearest training pose in joint space (rad): a model
is only tested where the test poses lie near what it was fitted on.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from postproc.errors import InputError, MeasurementError
from postproc.robot.robots import RobotModel

from .effects import EffectSum
from .errormodel import ErrorModel
from .identify import fit, fit_predictor, refit_base, residuals
from .measurements import MeasurementSet, group_column
from .session_offsets import with_session_offsets

PROTOCOLS = ("random", "points", "sessions", "series")
SESSION_GAP_S = 1800.0  # a pause of more than 30 min between two poses starts a new session
# A held-out session "moves as a whole" when the translation of the rigid motion that best
# explains its residual is at least this share of its mean error and at least this many
# times the median over the sessions (a tracker bump or a re-homed arm, not the region:
# on Series A the one such session, 17 July 11:17, has 0.42 mm against a median 0.07).
MOVE_SHARE = 0.5
MOVE_RATIO = 2.0
MIN_SESSION_POSES = 10  # smaller sessions are too few to score alone; they stay in training


@dataclass(frozen=True)
class ErrorSummary:
    n: int
    mean_mm: float
    median_mm: float
    p95_mm: float
    max_mm: float
    rms_mm: float

    @classmethod
    def of(cls, norms: np.ndarray) -> "ErrorSummary":
        return cls(n=int(norms.size), mean_mm=float(norms.mean()), median_mm=float(np.median(norms)),
                   p95_mm=float(np.percentile(norms, 95)), max_mm=float(norms.max()), rms_mm=float(np.sqrt(np.mean(norms**2))))


@dataclass(frozen=True)
class DistanceSummary:
    """Joint-space distance (rad, Euclidean over the six joints) of each test pose to its nearest training pose."""

    median_rad: float
    p95_rad: float
    max_rad: float

    @classmethod
    def of(cls, dist: np.ndarray) -> "DistanceSummary":
        return cls(median_rad=float(np.median(dist)), p95_rad=float(np.percentile(dist, 95)), max_rad=float(dist.max()))


@dataclass(frozen=True)
class SessionOffset:
    """A held-out session's residual explained by one rigid motion of its poses."""

    session: int
    n: int
    mean_mm: float  # mean 3-D error of the session, held out
    offset_mm: float  # the rigid motion's translation at the session's centroid (norm)
    rotation_mdeg: float  # and its rotation (norm, millidegrees)
    mean_after_mm: float  # mean 3-D error with the rigid motion removed
    moves_as_whole: bool


@dataclass(frozen=True)
class ProtocolResult:
    protocol: str
    description: str
    folds: int
    n_train: int  # poses in the (largest) training set
    error: ErrorSummary
    distance: DistanceSummary
    sessions: tuple[SessionOffset, ...] = ()
    ceiling: ErrorSummary | None = None  # series: the same effects fitted on the test series itself
    notes: tuple[str, ...] = field(default_factory=tuple)

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class FitSpec:
    """What each fold fits: physics effects, and optionally a predictor on their residual (hybrid)."""

    robot: RobotModel
    tool_mm: np.ndarray
    effects: EffectSum
    predictor: str | None = None
    gp_options: dict | None = None
    seed: int = 0
    noise: str = "none"  # the training poses' noise model (postproc.model.noise_model): none or settle
    session_offsets: bool = False  # each session's frame shift estimated and taken out (postproc.model.session_offsets)


def fit_model(spec: FitSpec, meas: MeasurementSet, say: Callable[[str], None]) -> ErrorModel:
    model = fit(spec.robot, spec.tool_mm, spec.effects, meas, cv_folds=0, seed=spec.seed, progress=say, noise=spec.noise).model
    if spec.session_offsets:
        model = with_session_offsets(model, meas)
    if spec.predictor is None:
        return model
    say(f"fitting the {spec.predictor} predictor on {len(meas)} poses")
    return fit_predictor(model, meas, spec.predictor, seed=spec.seed, gp_options=spec.gp_options,
                         progress=lambda done, total, msg: say(f"{msg} ({done}/{total})"), noise=spec.noise)


def with_order_columns(effects: EffectSum, meas: MeasurementSet) -> MeasurementSet:
    """Columns an effect infers from the row order (the approach directions of backlash),
    and the targets before each pose (a predictor's --gp-features tcp+joints+travel),
    taken from the whole set before it is split: a subset's rows are no longer consecutive."""
    meas = replace(meas, previous_q_deg=meas.path_history())
    for effect in effects:
        columns = effect.path_columns(meas.q_deg)
        if "approach" in columns and meas.approach is None:
            meas = replace(meas, approach=columns["approach"])
    return meas


def joint_distance(train_q_deg: np.ndarray, test_q_deg: np.ndarray) -> np.ndarray:
    """Distance (rad) of each test pose to its nearest training pose in joint space."""
    dist, _ = cKDTree(np.radians(train_q_deg)).query(np.radians(test_q_deg))
    return dist


def session_ids(meas: MeasurementSet) -> np.ndarray:
    """The 'session' column, else sessions split where the time column 't' pauses > 30 min."""
    if "session" in meas.extra:
        return group_column(meas, "session", "")
    if meas.time_s is None:
        raise MeasurementError(meas.source, 1, "session", "column missing: the sessions protocol needs a 'session' column or a time column 't'")
    order = np.argsort(meas.time_s, kind="stable")
    starts = np.r_[True, np.diff(meas.time_s[order]) > SESSION_GAP_S]
    ids = np.empty(len(meas), dtype=np.int64)
    ids[order] = np.cumsum(starts) - 1
    return ids


def every_kth_group(ids: np.ndarray, every: int) -> np.ndarray:
    """Test mask: the rows of every ``every``-th group (groups in ascending id order)."""
    if every < 2:
        raise InputError(f"--every must be at least 2 (hold out one group in every k), got {every}")
    groups, inverse = np.unique(ids, return_inverse=True)
    if len(groups) < every:
        raise InputError(f"{len(groups)} groups: too few to hold out one in every {every}")
    return (inverse.ravel() % every) == every - 1


def random_mask(n: int, fraction: float, seed: int) -> np.ndarray:
    if not 0.0 < fraction < 1.0:
        raise InputError(f"--fraction must lie between 0 and 1, got {fraction:g}")
    test = np.zeros(n, dtype=bool)
    test[np.random.default_rng(seed).permutation(n)[: max(1, int(round(fraction * n)))]] = True
    return test


def rigid_offset(pred_mm: np.ndarray, resid_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares small rigid motion (translation at the centroid, rotation vector in rad)
    that best explains ``resid`` at the points ``pred``; returns (coefficients, what is left)."""
    centred = pred_mm - pred_mm.mean(axis=0)
    jac = np.zeros((len(pred_mm), 3, 6))
    jac[:, :, :3] = np.eye(3)
    for k, axis in enumerate(np.eye(3)):
        jac[:, :, 3 + k] = np.cross(axis, centred)
    coef, *_ = np.linalg.lstsq(jac.reshape(-1, 6), resid_mm.reshape(-1), rcond=None)
    return coef, resid_mm - jac @ coef


def _held_out(spec: FitSpec, meas: MeasurementSet, test: np.ndarray, say) -> tuple[ErrorModel, np.ndarray, np.ndarray]:
    """Fit on the rows not in ``test``; (model, residual of the test rows, their joint distance)."""
    meas = with_order_columns(spec.effects, meas)
    train = meas.subset(~test)
    if len(train) == 0 or not test.any():
        raise InputError("a protocol fold has no training or no test poses")
    model = fit_model(spec, train, say)
    held = meas.subset(test)
    return model, residuals(model, held), joint_distance(train.q_deg, held.q_deg)


def run_random(spec: FitSpec, meas: MeasurementSet, fraction: float = 0.2, seed: int = 0, say=lambda m: None) -> ProtocolResult:
    test = random_mask(len(meas), fraction, seed)
    _, resid, dist = _held_out(spec, meas, test, say)
    return ProtocolResult("random", f"{test.sum()} random poses held out ({fraction:.0%}, seed {seed})", 1, int((~test).sum()),
                          ErrorSummary.of(np.linalg.norm(resid, axis=1)), DistanceSummary.of(dist))


def run_points(spec: FitSpec, meas: MeasurementSet, every: int = 5, say=lambda m: None) -> ProtocolResult:
    ids = group_column(meas, "point", "the points protocol holds out whole commanded positions")
    test = every_kth_group(ids, every)
    _, resid, dist = _held_out(spec, meas, test, say)
    points = len(np.unique(ids[test]))
    return ProtocolResult("points", f"one in every {every} commanded positions held out with all its poses ({points} positions, {test.sum()} poses)",
                          1, int((~test).sum()), ErrorSummary.of(np.linalg.norm(resid, axis=1)), DistanceSummary.of(dist))


def _session_offset(session: int, pred: np.ndarray, resid: np.ndarray) -> tuple[int, int, float, float, float, float]:
    coef, left = rigid_offset(pred, resid)
    return (session, len(resid), float(np.linalg.norm(resid, axis=1).mean()), float(np.linalg.norm(coef[:3])),
            float(np.degrees(np.linalg.norm(coef[3:])) * 1000.0), float(np.linalg.norm(left, axis=1).mean()))


def flag_moving(rows: list[tuple[int, int, float, float, float, float]]) -> tuple[SessionOffset, ...]:
    """Flag the sessions whose rigid offset is large against the others' and against their own error."""
    typical = float(np.median([r[3] for r in rows]))
    return tuple(SessionOffset(*r, moves_as_whole=bool(r[3] >= MOVE_RATIO * typical and r[3] >= MOVE_SHARE * r[2]))
                 for r in rows)


def run_sessions(spec: FitSpec, meas: MeasurementSet, say=lambda m: None) -> ProtocolResult:
    ids = session_ids(meas)
    sessions, counts = np.unique(ids, return_counts=True)
    scored = sessions[counts >= MIN_SESSION_POSES]
    if len(scored) < 2:
        raise InputError(f"{meas.source}: the sessions protocol needs at least two sessions of {MIN_SESSION_POSES} poses or more, found {len(scored)}")
    norms, dists, offsets, n_train = [], [], [], 0
    for k, session in enumerate(scored):
        say(f"session {k + 1}/{len(scored)} held out")
        test = ids == session
        model, resid, dist = _held_out(spec, meas, test, say)
        norms.append(np.linalg.norm(resid, axis=1))
        dists.append(dist)
        offsets.append(_session_offset(int(session), model.predict(meas.subset(test)), resid))
        n_train = max(n_train, int((~test).sum()))
    skipped = int(counts[counts < MIN_SESSION_POSES].sum())
    notes = (f"{skipped} poses in sessions of fewer than {MIN_SESSION_POSES} poses are never held out (always trained on)",) if skipped else ()
    return ProtocolResult("sessions", f"each of {len(scored)} sessions held out in turn", len(scored), n_train,
                          ErrorSummary.of(np.concatenate(norms)), DistanceSummary.of(np.concatenate(dists)), flag_moving(offsets), notes=notes)


def halves(meas: MeasurementSet) -> np.ndarray:
    """Mask of the first half: every other commanded position ('point'), else every other row."""
    if "point" in meas.extra:
        return every_kth_group(group_column(meas, "point", ""), 2)
    return np.arange(len(meas)) % 2 == 1


def run_series(spec: FitSpec, meas: MeasurementSet, other: MeasurementSet, say=lambda m: None) -> ProtocolResult:
    """Fit on ``meas``; re-register the frame on one half of ``other``, score the other half, both ways."""
    if len(other) < 12:
        raise InputError(f"{other.source}: the series protocol re-registers 6 DOF on half of the set and needs at least 12 poses, it has {len(other)}")
    model = fit_model(spec, meas, say)
    other = with_order_columns(spec.effects, other)
    first = halves(other)
    norms = []
    for register, score in ((first, ~first), (~first, first)):
        say("re-registering the tracker frame on one half of the other series")
        framed = refit_base(model, other.subset(register))
        norms.append(np.linalg.norm(residuals(framed, other.subset(score)), axis=1))
    say(f"the ceiling: the same model fitted on {len(other)} poses of the other series")
    ceiling_model = fit_model(spec, other, say)
    ceiling = ErrorSummary.of(np.linalg.norm(residuals(ceiling_model, other), axis=1))
    return ProtocolResult("series", f"fitted on {len(meas)} poses; frame registered on half of {other.source}'s commanded positions, scored on the other half, both ways",
                          2, len(meas), ErrorSummary.of(np.concatenate(norms)), DistanceSummary.of(joint_distance(meas.q_deg, other.q_deg)),
                          ceiling=ceiling)


def result_lines(result: ProtocolResult) -> list[str]:
    """The protocol's figures as plain text lines (what `postproc validate` prints)."""
    e, d = result.error, result.distance
    lines = [f"protocol {result.protocol}: {result.description}",
             f"  3-D error of {e.n} held-out poses: mean {e.mean_mm:.3f}  median {e.median_mm:.3f}  p95 {e.p95_mm:.3f}  max {e.max_mm:.3f}  RMS {e.rms_mm:.3f} mm",
             f"  nearest training pose (joint space, {result.n_train} training poses): median {d.median_rad:.3f}  p95 {d.p95_rad:.3f}  max {d.max_rad:.3f} rad"]
    if result.ceiling is not None:
        c = result.ceiling
        lines.append(f"  ceiling (the same model fitted on the test series itself, training error): mean {c.mean_mm:.3f}  median {c.median_mm:.3f}  p95 {c.p95_mm:.3f}  max {c.max_mm:.3f} mm")
    if result.sessions:
        lines.append("  session  poses  mean mm  rigid offset mm  rotation mdeg  mean without it mm")
        for s in result.sessions:
            flag = "  <- moves as a whole" if s.moves_as_whole else ""
            lines.append(f"  {s.session:7d}  {s.n:5d}  {s.mean_mm:7.3f}  {s.offset_mm:15.3f}  {s.rotation_mdeg:13.1f}  {s.mean_after_mm:18.3f}{flag}")
    lines.extend(f"  note: {note}" for note in result.notes)
    return lines
