"""Workpiece placement against force-induced error (seed 002 eq. 3 and 24).

The workpiece frame is base_T_wobj = Trans(x, y, z) Rz(theta); the program's targets stay
in it. For every candidate (x, y, theta) and every cutter-contact point the robot's joints
come from the analytic IK on the program's own configuration (ABB confdata, KUKA
Status/Turn, or path continuity where the program gives none: ``placement_branch``, by
default with the turn data re-derived for the moved workpiece as a re-post would); a
candidate is feasible when every Cartesian target is reachable inside the joint (and
coupling) limits and away from the wrist, elbow and shoulder singularities (eq. 3); the
reason of each infeasible one is kept. Its objective is the step-length weighted mean of
|n . C_tt F| over the path (``compliance``). The search is a grid of m1 x m2 x m3
candidates (eq. 24), vectorised over candidates x points in chunks that bound memory,
then a bounded Nelder-Mead refinement inside the best grid cell's neighbourhood.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from postproc.errors import InputError
from postproc.robot import kinematics as kin
from postproc.robot.robots import RobotModel

from . import compliance as comp
from .placement_branch import CONF_MODES, cell_reasons, program_postures

CHUNK_POSES = 120_000  # candidate x point poses per chunk: ~0.2 GB of scratch at most


@dataclass(frozen=True)
class PlacementProblem:
    """What a placement needs of a program, all in the workpiece frame (P Cartesian targets)."""

    robot: RobotModel
    local_tcp: np.ndarray  # (P, 4, 4) wobj_T_tcp
    flange_T_tcp: np.ndarray  # (P, 4, 4)
    force_local: np.ndarray  # (P, 3) N, cutting force on the tool, workpiece frame
    normal_local: np.ndarray  # (P, 3) surface normal, workpiece frame
    weights: np.ndarray  # (P,) eq. 2 step weights (0 off the cut)
    conf: np.ndarray  # (P, 4) the program's configuration data, NaN where none
    language: object  # the program's language: its controller's rules (controller.branch_from_conf) and its configuration-data notation (conf_of_joints, arm_conf_column)
    conf_applies: np.ndarray  # (P,) True where the controller takes the configuration data (the dialect's rule)
    compliance: np.ndarray  # (6,) joint compliance, rad/(N*m)
    line: np.ndarray  # (P,) program lines
    arm: np.ndarray  # (P,) the program's arm configuration (ABB cfx, KUKA Status) where its data apply, -1 else
    singular_deg: float = 5.0
    shoulder_mm: float = 50.0
    conf_mode: str = "rederive"  # or "keep" (placement_branch)

    def __post_init__(self):
        if self.conf_mode not in CONF_MODES:
            raise InputError(f"configuration data mode '{self.conf_mode}': expected one of {', '.join(CONF_MODES)}")


@dataclass(frozen=True)
class Evaluation:
    mean_mm: np.ndarray  # (M,) weighted mean |e_n|, NaN where infeasible
    feasible: np.ndarray  # (M,)
    reason: np.ndarray  # (M,) placement_branch reason code, 0 where feasible


def placement_frames(candidates: np.ndarray, z_mm: float) -> np.ndarray:
    """base_T_wobj (M, 4, 4) of candidates (M, 3) = (x mm, y mm, theta deg)."""
    cand = np.atleast_2d(np.asarray(candidates, dtype=float))
    t = np.radians(cand[:, 2])
    out = np.zeros((len(cand), 4, 4))
    out[:, 0, 0] = out[:, 1, 1] = np.cos(t)
    out[:, 0, 1], out[:, 1, 0] = -np.sin(t), np.sin(t)
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    out[:, 0, 3], out[:, 1, 3], out[:, 2, 3] = cand[:, 0], cand[:, 1], z_mm
    return out


def _chunk_errors(problem: PlacementProblem, frames: np.ndarray):
    """Per point normal errors (M, P), normal compliance (M, P) and reason code (M,), 0 where feasible.

    Reach, limits and singularities are settled first; the Jacobians and compliances are
    only computed for the candidates that passed (NaN elsewhere)."""
    m, p = len(frames), len(problem.local_tcp)
    tcp = frames[:, None] @ problem.local_tcp[None]  # (M, P, 4, 4)
    flange = tcp @ np.linalg.inv(problem.flange_T_tcp)[None]
    sols = kin.ik(problem.robot, flange.reshape(-1, 4, 4)).reshape(m, p, 8, 6)
    q, point_reason = program_postures(problem, sols)
    reason = cell_reasons(point_reason)
    feasible = reason == 0
    err = np.full((m, p), np.nan)
    cn = np.full((m, p), np.nan)
    if feasible.any():
        keep = np.nonzero(feasible)[0]
        rot = frames[keep, None, :3, :3]
        force = (rot @ problem.force_local[None, :, :, None])[..., 0].reshape(-1, 3)
        normal = (rot @ problem.normal_local[None, :, :, None])[..., 0].reshape(-1, 3)
        r = (tcp[keep, :, :3, 3] - flange[keep, :, :3, 3]).reshape(-1, 3)
        jv = comp.tcp_linear_jacobian(problem.robot, q[keep].reshape(-1, 6), r)
        e, c = comp.normal_error_and_compliance(jv, problem.compliance, force, normal)
        err[keep], cn[keep] = e.reshape(-1, p), c.reshape(-1, p)
    return err, cn, reason


def evaluate(problem: PlacementProblem, frames: np.ndarray, chunk_poses: int = CHUNK_POSES, progress=None) -> Evaluation:
    """Mean normal error of each workpiece frame (M, 4, 4): NaN where infeasible.
    ``progress(done, total)`` is called after each chunk."""
    frames = np.asarray(frames, dtype=float).reshape(-1, 4, 4)
    per = max(1, chunk_poses // max(len(problem.local_tcp), 1))
    mean = np.full(len(frames), np.nan)
    reason = np.zeros(len(frames), dtype=np.int8)
    for s in range(0, len(frames), per):
        err, _, why = _chunk_errors(problem, frames[s : s + per])
        reason[s : s + per] = why
        mean[s : s + per] = np.where(why == 0, comp.weighted_mean(np.nan_to_num(err), problem.weights), np.nan)
        if progress is not None:
            progress(min(s + per, len(frames)), len(frames))
    return Evaluation(mean, reason == 0, reason)


def path_errors(problem: PlacementProblem, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Normal error (P,) mm and normal compliance (P,) mm/N along the path at one frame, and feasibility."""
    err, cn, why = _chunk_errors(problem, np.asarray(frame, dtype=float).reshape(1, 4, 4))
    return err[0], cn[0], bool(why[0] == 0)


def placement_joints(problem: PlacementProblem, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joints (P, 6) the robot takes at each target with the workpiece at ``frame``, and their reason codes (P,)."""
    tcp = np.asarray(frame, dtype=float)[None] @ problem.local_tcp
    flange = tcp @ np.linalg.inv(problem.flange_T_tcp)
    sols = kin.ik(problem.robot, flange)[None]
    q, reason = program_postures(problem, sols)
    return q[0], reason[0]


def grid_axis(spec: tuple[float, float, float], name: str) -> np.ndarray:
    """Values start..stop (inclusive) in steps of step; a zero step or equal ends give one value."""
    start, stop, step = spec
    if stop < start:
        raise InputError(f"--search {name}: the range {start:g}:{stop:g} runs backwards")
    if step < 0 or (step == 0 and stop != start):
        raise InputError(f"--search {name}: the step must be > 0, got {step:g}")
    if stop == start:
        return np.array([start])
    count = int(math.floor((stop - start) / step + 1e-9)) + 1
    if count > 100_000:
        raise InputError(f"--search {name}: {count} values is too many")
    return start + step * np.arange(count)


@dataclass(frozen=True)
class SearchResult:
    xs: np.ndarray
    ys: np.ndarray
    thetas: np.ndarray
    grid_mean_mm: np.ndarray  # (nx, ny, nt), NaN where infeasible
    grid_reason: np.ndarray  # (nx, ny, nt) placement_branch reason codes, 0 where feasible
    grid_best: np.ndarray  # (3,) x, y, theta of the best grid candidate
    grid_best_mm: float
    best: np.ndarray  # (3,) after refinement
    best_mm: float
    evaluated: int


def search(problem: PlacementProblem, xs, ys, thetas, z_mm: float, refine: bool = True, chunk_poses: int = CHUNK_POSES,
           progress=None) -> SearchResult:
    """Grid search over xs x ys x thetas (mm, mm, deg), then bounded local refinement;
    ``progress(done, total)`` after each chunk of the grid."""
    xs, ys, thetas = (np.asarray(v, dtype=float) for v in (xs, ys, thetas))
    cand = np.stack(np.meshgrid(xs, ys, thetas, indexing="ij"), axis=-1).reshape(-1, 3)
    ev = evaluate(problem, placement_frames(cand, z_mm), chunk_poses, progress)
    grid = ev.mean_mm.reshape(len(xs), len(ys), len(thetas))
    why = ev.reason.reshape(grid.shape)
    if not ev.feasible.any():
        return SearchResult(xs, ys, thetas, grid, why, np.full(3, np.nan), math.nan, np.full(3, np.nan), math.nan, len(cand))
    k = int(np.nanargmin(ev.mean_mm))
    best, best_mm, evaluated = cand[k].copy(), float(ev.mean_mm[k]), len(cand)
    grid_best, grid_best_mm = best.copy(), best_mm
    if refine:
        best, best_mm, used = _refine(problem, cand[k], best_mm, (xs, ys, thetas), z_mm)
        evaluated += used
    return SearchResult(xs, ys, thetas, grid, why, grid_best, grid_best_mm, best, best_mm, evaluated)


def _refine(problem: PlacementProblem, start: np.ndarray, start_mm: float, axes, z_mm: float):
    """Bounded Nelder-Mead within one grid step of the start (and inside the search box)."""
    # Deferred: scipy.optimize is slow to import and the command line imports placement at start-up.
    from scipy.optimize import minimize

    steps = np.array([np.diff(a).min() if len(a) > 1 else 0.0 for a in axes])
    lo = np.maximum(start - steps, [a.min() for a in axes])
    hi = np.minimum(start + steps, [a.max() for a in axes])
    movable = hi > lo
    if not movable.any():
        return start, start_mm, 0
    count = [0]
    scale = np.where(movable, hi - lo, 1.0)

    def objective(u):
        cand = start.copy()
        cand[movable] = lo[movable] + u * scale[movable]
        count[0] += 1
        value = evaluate(problem, placement_frames(cand, z_mm)).mean_mm[0]
        return float(value) if np.isfinite(value) else 1e9

    u0 = (start[movable] - lo[movable]) / scale[movable]
    res = minimize(objective, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * int(movable.sum()),
                   options={"xatol": 1e-3, "fatol": 1e-9, "maxfev": 120})
    if res.fun < start_mm:
        best = start.copy()
        best[movable] = lo[movable] + res.x * scale[movable]
        return best, float(res.fun), count[0]
    return start, start_mm, count[0]
