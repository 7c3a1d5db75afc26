"""Pre-compensation: rewrite every target so the robot's predicted actual TCP lands on it.

The controller solves the nominal kinematics: a command c becomes joints q = IK(c) on the
program's configuration branch, and the robot's TCP really goes to model(q). For each
target p we look for the command c with model(IK(c)) = p:

- ``broyden`` (default): full 3-D position, a secant/Broyden quasi-Newton iteration per
  point (a 3x3 Jacobian estimate starting at identity, rank-one updated), vectorised over
  all points, re-solving IK at every iteration on the target's original branch;
- ``seed000``: seed 000's scheme (eq. 10-15) — the error across the tool axis is
  subtracted once, and the depth along the tool axis is found by the secant iteration
  from a0 = ap, a1 = ap + e(a0).

Both stop a point when its correction changes by less than the tolerance (0.01 mm by
default); ``broyden`` also stops a point as soon as its predicted residual is below the
tolerance (including a target already within it as written: 0 iterations), which saves
the evaluation that would only confirm a sub-tolerance step. Orientation is kept as programmed (the model predicts position). Points that
do not converge, leave the joint limits, come near a singularity or would change IK
branch are reported with their program lines; the caller must not write such a program.

The controller's rules (which configuration data apply and the branch they name, where its
interpolation is not exact, where an arc ends) come from the ``controller`` object the
caller gives: this module imports no language (``postproc.jobs.compensate`` is the public entry
that gives the program's own).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache, wraps

import numpy as np
from threadpoolctl import ThreadpoolController

from postproc.errors import InputError, JobError
from postproc.model import fast_model
from postproc.model.effects import consumers_of
from postproc.model.errormodel import ErrorModel
from postproc.model.path_history import path_travel_mm, previous_targets
from postproc.programs import arcs
from postproc.programs.ir import Kind, Toolpath
from postproc.robot import kinematics as kin
from postproc.robot import posture
from postproc.robot.frames import invert_transform

from . import segments


@lru_cache(maxsize=1)
def _blas_threads() -> ThreadpoolController:
    return ThreadpoolController()  # finding the BLAS libraries takes ~1 ms: once per process


def _one_blas_thread(fn):
    """``fn`` run with one BLAS thread: compensation's products are of thin matrices
    ((N, 3) @ (3, 3)), where OpenBLAS's second thread costs more CPU (spinning) than it
    saves (~1.7 us a point on the stream benchmark), and the stream's worker processes are
    the parallelism. Threaded or not, OpenBLAS splits a product by rows: the same numbers."""

    @wraps(fn)
    def one_thread(*args, **kwargs):
        with _blas_threads().limit(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return one_thread


class CompensationError(JobError):
    """Some targets cannot be compensated; ``report`` lists them with their lines."""

    def __init__(self, message: str, report: "Report"):
        self.report = report
        super().__init__(message)


@dataclass(frozen=True)
class Report:
    line: np.ndarray
    compensated: np.ndarray  # (N,) bool: targets the engine moved (joint targets are not)
    iterations: np.ndarray
    before_mm: np.ndarray  # predicted 3-D error of the program as written
    after_mm: np.ndarray  # predicted 3-D error of the compensated program
    correction_mm: np.ndarray  # how far each target was moved
    converged: np.ndarray
    within_limits: np.ndarray
    singular: np.ndarray
    branch_changed: np.ndarray
    posture: np.ndarray | None = None  # (N,) POSTURE_* code, 0 where the controller's posture is fine
    path_mm: np.ndarray | None = None  # (N,) predicted largest distance from the intended path on the segment into the target
    path_limit_mm: float | None = None  # --max-deviation: a segment straying further fails
    end_joints: np.ndarray | None = None  # (6,) the posture the controller holds at the last Cartesian target as written (postproc.jobs.stream carries it on)
    outside_region: dict[int, str] | None = None  # target index -> why it lies outside the model's measured region (postproc.model.coverage); None: not checked
    detail: "PathDetail | None" = None  # per-target vectors for the --report page (compensate(detail=True))

    @property
    def failed(self) -> np.ndarray:
        fine = self.converged & self.within_limits & ~self.singular & ~self.branch_changed
        if self.posture is not None:
            fine &= self.posture == 0
        if self.path_limit_mm is not None and self.path_mm is not None:
            fine &= ~(self.path_mm > self.path_limit_mm)
        if self.outside_region:
            fine[list(self.outside_region)] = False
        return self.compensated & ~fine

    def failures(self) -> list[tuple[int, str]]:
        out = []
        for i in np.nonzero(self.failed)[0]:
            reasons = []
            if self.posture is not None and self.posture[i]:
                reasons.append(_POSTURE_TEXT[int(self.posture[i])])
            if not self.within_limits[i] and (self.posture is None or self.posture[i] not in (POSTURE_CONF, POSTURE_START)):
                reasons.append("out of reach or outside the joint limits")
            if self.singular[i]:
                reasons.append("near a singularity")
            if self.branch_changed[i]:
                reasons.append("would change IK branch")
            if self.path_limit_mm is not None and self.path_mm is not None and self.path_mm[i] > self.path_limit_mm:
                reasons.append(f"on the segment into it the predicted path strays {self.path_mm[i]:.4f} mm from the intended one "
                               f"(over --max-deviation {self.path_limit_mm:g} mm; --subdivide adds targets on straight segments and splits CIRC / MoveC arcs)")
            if self.outside_region and i in self.outside_region:
                reasons.append(self.outside_region[i] + " (--allow-extrapolation compensates it all the same)")
            if not self.converged[i] and self.within_limits[i]:
                reasons.append(f"did not converge (residual {self.after_mm[i]:.4f} mm after {self.iterations[i]} iterations)")
            out.append((int(self.line[i]), "; ".join(reasons)))
        return out

    def failures_at(self, tp: Toolpath) -> list[tuple[str, str]]:
        """``failures`` with each target's ``file:line:column`` in ``tp`` (the program compensated):
        the column of its first number, or 1 where its numbers are elsewhere (a named point)."""
        failed = np.nonzero(self.failed)[0].tolist()
        return [(f"{tp.sources[int(tp.file[i])].path}:{tp.line[i]}:{column}", reason)
                for i, column, (_, reason) in zip(failed, self.failure_columns(tp), self.failures())]

    def failure_columns(self, tp: Toolpath) -> list[int]:
        """The column in ``tp``'s text of each failed target, in the order of ``failures``."""
        out = []
        for i in np.nonzero(self.failed)[0].tolist():
            doc = tp.sources[int(tp.file[i])]
            spans = tp.spans[i]
            here = spans[(spans[:, 0] == tp.file[i]) & (spans[:, 1] >= 0), 1]
            line_start = _line_offset(doc.text, int(tp.line[i]))
            line_end = doc.text.find("\n", line_start) % (len(doc.text) + 1)
            inside = here[(here >= line_start) & (here < line_end)]
            named = doc.text.upper().find(tp.target_name[i].upper(), line_start, line_end) if tp.target_name[i] else -1
            out.append(int(inside.min()) - line_start + 1 if len(inside) else (named - line_start + 1 if named >= 0 else 1))
        return out

    def summary(self) -> dict:
        c = self.compensated
        it = self.iterations[c]

        def stats(v):
            v = v[c & np.isfinite(v)]
            return {"rms_mm": float(np.sqrt(np.mean(v**2))) if len(v) else None, "max_mm": float(v.max()) if len(v) else None}

        return {
            "targets": int(len(self.line)),
            "compensated": int(c.sum()),
            "predicted_before": stats(self.before_mm),
            "predicted_after": stats(self.after_mm),
            "iterations_median": float(np.median(it)) if len(it) else None,
            "iterations_max": int(it.max()) if len(it) else None,
            "max_correction_mm": float(np.nanmax(self.correction_mm[c])) if c.any() else None,
            "failed": int(self.failed.sum()),
            "path": self._path_summary(),
        }

    def _path_summary(self) -> dict | None:
        """Largest predicted distance from the intended path between targets, and where."""
        if self.path_mm is None or not np.isfinite(self.path_mm).any():
            return None
        i = int(np.nanargmax(self.path_mm))
        return {"max_mm": float(self.path_mm[i]), "line": int(self.line[i]), "segments": int(np.isfinite(self.path_mm).sum()),
                "over_tolerance": int((self.path_mm > PATH_TOLERANCE_MM).sum()), "tolerance_mm": PATH_TOLERANCE_MM}


class _Plant:
    """The robot as compensation sees it: command poses -> joints on a branch -> predicted TCP."""

    def __init__(self, model: ErrorModel, tools: np.ndarray, tool_index: np.ndarray, temp_c, force_rows):
        self.model = model
        self.robot = model.robot
        self.tools = tools
        self.tool_index = tool_index
        self.temp_c = temp_c
        self.force_rows = force_rows  # (rows of the program, 3) N in the base frame, or None
        self.inv_tools = np.linalg.inv(tools)

    def joints(self, tcp_poses: np.ndarray, rows: np.ndarray, q_ref: np.ndarray, branch_ref: np.ndarray):
        flange = tcp_poses @ self.inv_tools[self.tool_index[rows]]
        return kin.branch_joints(self.robot, flange, branch_ref, q_ref)

    def actual(self, q: np.ndarray, rows: np.ndarray, order_q: np.ndarray | None = None) -> np.ndarray:
        """Predicted TCP (N, 3) of the program's tools at joints q (rows index the program)."""
        out = np.full((len(q), 3), np.nan)
        ok = ~np.isnan(q).any(axis=1)
        for t in np.unique(self.tool_index[rows]):
            sel = ok & (self.tool_index[rows] == t)
            if not sel.any():
                continue
            m = replace(self.model, tool_mm=self.tools[t][:3, 3])
            if self.temp_c is None and self.force_rows is None:
                fast = fast_model.compiled_positions(m, q[sel])  # the common physics model, compiled (bit for bit the same)
                if fast is not None:
                    out[sel] = fast
                    continue
            columns = {"temp": None if self.temp_c is None else np.full(int(sel.sum()), self.temp_c),
                       "force": None if self.force_rows is None else self.force_rows[rows][sel], "approach": None}
            if order_q is not None:
                # Columns the effects derive from the program's path (e.g. approach directions).
                for effect in m.effects:
                    columns.update({group: col[rows][sel] for group, col in effect.path_columns(order_q).items()})
            # The targets before each one in program order (a residual predictor that reads them).
            reads_history = order_q is not None and getattr(m.residual, "reads_history", False)
            history = previous_targets(order_q)[rows][sel] if reads_history else None
            prep = m.prepare(q_deg=q[sel], force_n=columns["force"], approach=columns["approach"], temp_c=columns["temp"], time_s=None,
                             previous_q_deg=history)
            out[sel] = m.predict_prepared(prep)
        return out


def _reference_joints(tp: Toolpath, robot, flange: np.ndarray, rows: np.ndarray, controller, start_q=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """The joints and branch the controller takes for each Cartesian target as written, by
    its rules (``controller``: ``conf_applies``, ``branch_from_conf``; postproc.robot.posture):
    joint targets and configuration data that apply set the posture, every other target
    carries it. Also returns, per Cartesian target, why the controller could not take that
    posture (POSTURE_* codes, 0 where it can)."""
    n = len(tp)
    sols = posture.Solutions(robot, flange, rows, n)  # IK as far as the rules read it: one branch of most targets
    cartesian = np.zeros(n, dtype=bool)
    cartesian[rows] = True
    by_conf = controller.conf_applies(tp) & cartesian
    anchor_q = np.full((n, 6), np.nan)
    if by_conf.any():
        anchor_q[by_conf] = controller.branch_of_targets(robot, sols.all(np.nonzero(by_conf)[0]), tp, np.nonzero(by_conf)[0])[0]
    joint_targets = (tp.kind == Kind.ABSJ) & ~np.isnan(tp.joints).any(axis=1)
    anchor_q[joint_targets] = tp.joints[joint_targets]
    carried = posture.carry(robot, sols, by_conf | joint_targets, anchor_q, start_q, lines=tp.line)
    problem = np.zeros(n, dtype=int)
    problem[by_conf & np.isnan(anchor_q).any(axis=1)] = POSTURE_CONF
    if start_q is None and not getattr(controller, "start_posture_assumed", True):
        problem[cartesian & (carried.set_by < 0)] = POSTURE_START  # the rule needs the joints the program starts from
    q = np.where(problem[:, None] != 0, np.nan, carried.q)
    usable = ~np.isnan(q).any(axis=1) & kin.within_limits(robot, np.nan_to_num(q))
    branch = np.where(usable, carried.branch, -1)
    q[~usable] = np.nan
    return q[rows], branch[rows], problem[rows], list(carried.notes)


PATH_TOLERANCE_MM = 0.02  # segments straying further between targets are counted in the summary
PATH_MIN_LENGTH_MM = 5.0  # shorter segments are not sampled for the path between targets

# What may keep the controller from the posture its rules give (Report.posture):
POSTURE_CONF = 1  # the configuration data match no IK solution of the nominal robot
POSTURE_PATH = 3  # the straight line to the compensated target passes a singularity or leaves reach
POSTURE_START = 4  # before any target that sets the posture, under a controller whose rule needs the start joints
_POSTURE_TEXT = {
    POSTURE_START: "the controller takes the IK solution nearest the joints the robot is in, and before this target the program "
                   "sets none (no joint target yet): give the robot's joints at the start with --start-joints",
    POSTURE_CONF: "its configuration data match no IK solution of the nominal robot: the controller would stop there "
                  "(write the configuration the robot takes, or let it choose: KRL LIN, RAPID ConfL\\Off / ConfJ\\Off)",
    POSTURE_PATH: "the controller's straight line to the compensated target passes near a singularity or leaves reach on its posture",
}


@_one_blas_thread
def compensate(
    tp: Toolpath,
    model: ErrorModel,
    *,
    controller,
    tol_mm: float = 0.01,
    max_iter: int = 25,
    scheme: str = "broyden",
    temp_c: float | None = None,
    force_n=None,
    frames: dict | None = None,
    tools: dict | None = None,
    start_joints=None,
    force_per_target=None,
    max_deviation_mm: float | None = None,
    progress=lambda msg: None,
    reference: Reference | None = None,
    allow_extrapolation: bool = False,
    detail: bool = False,
) -> tuple[Toolpath, Report]:
    """Compensated copy of a toolpath and the per-point report (see the module docstring).
    ``reference``: ``reference_postures`` of the same program, frames, tools and start joints.
    Targets outside the region the model was measured in fail unless ``allow_extrapolation``.
    ``detail``: the report also carries the per-target vectors of ``PathDetail``.
    ``controller``: the rules of the controller that runs the program (a ``postproc.programs.controller.Controller``:
    ``conf_applies``, ``branch_from_conf``, ``inexact_interpolation``, ``arc_ends_at_target``);
    ``postproc.jobs.compensate.compensate`` takes those of the program's language by default."""
    if scheme not in _SCHEMES:
        raise InputError(f"unknown compensation scheme '{scheme}' (broyden or seed000)")
    _require_usable_model(model)
    # force_n and force_per_target never come together: CompensationRequest refuses it (request.py).
    _require_process_inputs(model, temp_c, force_n if force_per_target is None else force_per_target)
    arcs.refuse_uncompensable(tp)
    inexact = controller.inexact_interpolation(tp)
    if inexact and max_deviation_mm is not None:  # it promises the path between targets: not where the controller leaves the interpolation
        raise InputError(f"{inexact} (--max-deviation)")
    written = tp
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    _refuse_unplaced(tp)
    problem = _Problem.of(tp, model, controller, temp_c, force_n, start_joints, force_per_target, reference)
    progress("predicting the program as written")
    before = problem.predicted_error_as_written()
    solution = _SCHEMES[scheme](problem, before, tol_mm, max_iter, progress)
    arc_fit = arcs.fit(problem, solution, tol_mm, max_iter, _solve_broyden, progress)  # G2/G3 centres (postproc.programs.arcs)
    report = _report(problem, before, solution)
    progress("predicting the path between targets")
    path = _path_deviation(problem, solution, controller)
    arc_fit.put_deviation(path, problem.rows)
    report = replace(report, path_mm=_scatter(len(tp), problem.rows, np.nan, path, float), path_limit_mm=max_deviation_mm,
                     end_joints=problem.q_ref[-1].copy() if len(problem.rows) else None,
                     outside_region=None if allow_extrapolation else _outside_region(problem, solution, model),
                     detail=PathDetail.of(problem, before, solution) if detail else None)
    out = arc_fit.apply(written.with_positions(problem.positions_for(solution.cmd)))
    notes = tuple(problem.notes) + ((f"{inexact}: the distances reported between targets assume exact interpolation",) if inexact else ())
    if notes:
        out = replace(out, notes=out.notes + notes)
    return out, report




@dataclass(frozen=True)
class PathDetail:
    """Per target of the program (NaN for joint targets): where it is programmed, the
    model's predicted error of the program as written and compensated (predicted TCP minus
    target), and the joints of the compensated command. For ``postproc.report``."""

    goal_mm: np.ndarray  # (N, 3) base frame
    before_mm: np.ndarray  # (N, 3)
    after_mm: np.ndarray  # (N, 3)
    joints_deg: np.ndarray  # (N, 6)

    @classmethod
    def of(cls, problem: "_Problem", before: np.ndarray, sol: "_Solution") -> "PathDetail":
        n, rows = len(problem.tp), problem.rows

        def full(values):
            out = np.full((n, values.shape[1]), np.nan)
            out[rows] = values
            return out

        return cls(full(problem.goal), full(before), full(sol.err), full(sol.q))


@dataclass
class Reference:
    """The joints and branch the controller takes at each Cartesian target as written, why it
    could not where it cannot, and the notes (``_reference_joints``)."""

    q: np.ndarray
    branch: np.ndarray
    posture_problem: np.ndarray
    notes: list
    target: np.ndarray | None = None  # (Cartesian targets, 4, 4) their poses in the base frame, as compensate needs them

    @property
    def end_joints(self) -> np.ndarray | None:
        """``Report.end_joints``: the posture at the last Cartesian target as written."""
        return self.q[-1].copy() if len(self.q) else None


def reference_postures(tp: Toolpath, model: ErrorModel, *, controller, frames: dict | None = None, tools: dict | None = None,
                       start_joints=None, **_options) -> Reference:
    """What ``compensate(tp, model, ...)`` computes first (the postures of the program as
    written, by ``controller``'s rules), without compensating; given back to it as
    ``reference`` it is not computed again. It depends on the targets as written only, so postproc.jobs.stream carries its end
    posture to the next chunk while this one is compensated in another process."""
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    _refuse_unplaced(tp)  # as compensate: an InputError, not a posture of NaN
    rows = np.nonzero(tp.kind != Kind.ABSJ)[0]
    target = _rows_of(tp.base_poses(), rows)
    flange = target @ np.linalg.inv(tp.tools)[tp.tool[rows]]  # as _Problem.of and _Plant
    return Reference(*_reference_joints(tp, model.robot, flange, rows, controller, start_joints), target=target)


def _rows_of(per_target: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """per_target[rows], without a copy where rows are all of them (a long program without joint targets)."""
    return per_target if len(rows) == len(per_target) else per_target[rows]


def _require_usable_model(model: ErrorModel) -> None:
    """Compensation solves the nominal IK and needs the model in the robot's base frame."""
    robot = model.robot
    if not robot.has_analytic_ik:
        raise InputError(f"robot '{robot.name}' has no analytic IK: compensation needs an ortho-parallel arm")
    rot, trans = model.base_transform()
    angle = np.degrees(np.arccos(np.clip((np.trace(rot) - 1) / 2, -1, 1)))
    if angle > 5.0 or np.linalg.norm(trans) > 100.0:
        raise InputError(
            f"the model's measurement frame is {np.linalg.norm(trans):.0f} mm and {angle:.1f} deg away from the robot base "
            "(a tracker frame?): compensation needs a model whose measurements are in the robot's base frame"
        )


def _require_process_inputs(model: ErrorModel, temp_c, force_n) -> None:
    """An effect that needs a process input (temperature, force) may not run without it,
    and an input no effect of the model consumes is an error, not a no-op."""
    check_inputs(model, {"temp": temp_c, "force": force_n})


def _refuse_unplaced(tp: Toolpath) -> None:
    """Every Cartesian target must be placed in the base frame (point, frame and tool known)."""
    cart = tp.kind != Kind.ABSJ
    unplaced = cart & ~(tp.placed() & ~np.isnan(tp.position).any(axis=1))
    if unplaced.any():
        i = np.nonzero(unplaced)[0]
        missing = sorted({tp.frame_names[tp.frame[j]] for j in i if tp.frame_known is not None and not tp.frame_known[tp.frame[j]]})
        missing_tools = sorted({tp.tool_names[tp.tool[j]] for j in i if tp.tool_known is not None and not tp.tool_known[tp.tool[j]]})
        hint = ""
        if missing or missing_tools:
            hint = " Define " + ", ".join([f"frame {m} (--frame {m}=X,Y,Z,A,B,C)" for m in missing] + [f"tool {m} (--tool {m}=X,Y,Z,A,B,C)" for m in missing_tools]) + "."
        lines = ", ".join(str(v) for v in tp.line[i][:10])
        # the reader's notes on those targets say why (a note starts with its file:line)
        places = {f"{tp.sources[int(tp.file[j])].path}:{int(tp.line[j])}:" for j in i}
        why = [n for n in tp.notes if any(n.startswith(p) for p in places)][:3]
        raise InputError(f"targets on lines {lines} cannot be placed in the robot base frame (undefined point, frame or tool).{hint}"
                         + "".join(f"\n  {n}" for n in why))
    if np.isnan(tp.orientation[np.nonzero(cart)[0]]).any():
        raise InputError("targets without an orientation (3-axis G-code) need one: convert the program for a robot first")


class _Problem:
    """The Cartesian targets of one program and the robot that must reach them."""

    def __init__(self, tp: Toolpath, plant: _Plant, rows: np.ndarray, target: np.ndarray, q_ref, branch_ref, posture_problem, notes):
        self.tp, self.plant, self.rows, self.target = tp, plant, rows, target
        self.goal = target[:, :3, 3]
        self.q_ref, self.branch_ref, self.notes = q_ref, branch_ref, notes
        self.posture_problem = posture_problem
        # Joints of every target in program order (backlash depends on the approach direction).
        self.order_q = np.zeros((len(tp), 6))
        joint_targets = (tp.kind == Kind.ABSJ) & ~np.isnan(tp.joints).any(axis=1)
        self.order_q[joint_targets] = tp.joints[joint_targets]  # the joints the arm passes through there
        self.order_q[rows] = np.nan_to_num(q_ref)

    @classmethod
    def of(cls, tp: Toolpath, model: ErrorModel, controller, temp_c, force_n, start_joints=None, force_per_target=None,
           reference: Reference | None = None) -> "_Problem":
        rows = np.nonzero(tp.kind != Kind.ABSJ)[0]
        target = reference.target if reference is not None and reference.target is not None else _rows_of(tp.base_poses(), rows)
        force_rows = _force_rows(len(tp), rows, target, force_n) if force_per_target is None else np.asarray(force_per_target, dtype=float)
        plant = _Plant(model, tp.tools, tp.tool, temp_c, force_rows)
        if reference is None:
            flange = target @ plant.inv_tools[tp.tool[rows]]
            reference = Reference(*_reference_joints(tp, model.robot, flange, rows, controller, start_joints))
        q_ref, branch_ref, posture_problem, notes = reference.q, reference.branch, reference.posture_problem, reference.notes
        return cls(tp, plant, rows, target, q_ref, branch_ref, posture_problem, notes)

    def straight_segments_blocked(self, cmd: np.ndarray, q: np.ndarray, branch: np.ndarray, margins=None) -> np.ndarray:
        """(Cartesian targets,) True where the nominal controller's straight line from the
        previous target (compensated, or a joint target as written) to this compensated one
        cannot be driven on the carried posture. ``margins``: ``posture.singularity_margins``
        of q where the caller has them (the report does)."""
        tp, rows, robot = self.tp, self.rows, self.plant.robot
        n = len(tp)
        # Joints (and their singularity margins) of every program row where the robot will be.
        q_all = np.full((n, 6), np.nan)
        q_all[rows] = q
        margins = posture.singularity_margins(robot, q) if margins is None else margins
        margins_all = [np.full(n, np.nan) for _ in margins]
        for whole, part in zip(margins_all, margins):
            whole[rows] = part
        joint_rows = np.nonzero((tp.kind == Kind.ABSJ) & ~np.isnan(tp.joints).any(axis=1))[0]
        if joint_rows.size:
            q_all[joint_rows] = tp.joints[joint_rows]
            for whole, part in zip(margins_all, posture.singularity_margins(robot, tp.joints[joint_rows])):
                whole[joint_rows] = part
        prev = rows - 1
        check = (tp.kind[rows] == Kind.LINEAR) & (prev >= 0) & ~np.isnan(q).any(axis=1)
        check[check] &= ~np.isnan(q_all[prev[check]]).any(axis=1)
        sub = np.nonzero(check)[0]
        check[sub] &= ~posture.clearly_regular(robot, q_all[prev[sub]], q[sub], [m[prev[sub]] for m in margins_all], [m[rows[sub]] for m in margins_all])
        blocked = np.zeros(len(rows), dtype=bool)
        for idx in _chunks(np.nonzero(check)[0]):
            start, end = self._flange_at(prev[idx], cmd), self._flange_at(rows[idx], cmd)
            reason = posture.check_linear_segments(robot, start, end, branch[idx], q_all[prev[idx]])
            blocked[idx] = reason != 0
        return blocked

    def _flange_at(self, program_rows: np.ndarray, cmd: np.ndarray) -> np.ndarray:
        """Flange poses (M, 4, 4) where the robot will be at these program rows: a Cartesian
        target at its command ``cmd``, a joint target at its joints (NaN where it has none)."""
        tp = self.tp
        out = np.full((len(program_rows), 4, 4), np.nan)
        at = np.searchsorted(self.rows, program_rows)
        cartesian = (at < len(self.rows)) & (self.rows[np.minimum(at, len(self.rows) - 1)] == program_rows)
        poses = self.target[at[cartesian]].copy()
        poses[:, :3, 3] = cmd[at[cartesian]]
        out[cartesian] = poses @ self.plant.inv_tools[tp.tool[program_rows[cartesian]]]
        joint = ~cartesian & (tp.kind[program_rows] == Kind.ABSJ) & ~np.isnan(tp.joints[program_rows]).any(axis=1)
        if joint.any():
            out[joint] = kin.fk(self.plant.robot, tp.joints[program_rows[joint]])
        return out

    def predicted_error_as_written(self) -> np.ndarray:
        return self.plant.actual(self.q_ref, self.rows, self.order_q) - self.goal

    def evaluate(self, commands: np.ndarray, active: np.ndarray):
        """Predicted error, joints and branch of the targets ``active`` commanded at ``commands``."""
        rows = self.rows[active]
        poses = self.target[active].copy()
        poses[:, :3, 3] = commands
        q, b = self.plant.joints(poses, rows, self.q_ref[active], self.branch_ref[active])
        self.order_q[rows] = np.where(np.isnan(q), self.order_q[rows], q)
        return self.plant.actual(q, rows, self.order_q) - self.goal[active], q, b

    def positions_for(self, cmd: np.ndarray) -> np.ndarray:
        """Target positions (all rows, each in its own frame) for base-frame commands ``cmd``."""
        new_base = self.target.copy()
        new_base[:, :3, 3] = cmd
        local = invert_transform(self.tp.frames)[self.tp.frame[self.rows]] @ new_base  # each frame inverted once
        position = self.tp.position.copy()
        position[self.rows] = local[:, :3, 3]
        return position


@dataclass
class _Solution:
    """Iteration state per Cartesian target."""

    cmd: np.ndarray
    err: np.ndarray
    q: np.ndarray
    branch: np.ndarray
    within: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray

    @classmethod
    def start(cls, problem: _Problem, before: np.ndarray) -> "_Solution":
        n = len(problem.rows)
        return cls(problem.goal.copy(), before.copy(), problem.q_ref.copy(), problem.branch_ref.copy(),
                   ~np.isnan(problem.q_ref).any(axis=1), np.zeros(n, dtype=int), np.zeros(n, dtype=bool))

    def accept(self, idx: np.ndarray, keep: np.ndarray, err: np.ndarray, q: np.ndarray, branch: np.ndarray) -> None:
        """Take the new error and joints of the points ``idx[keep]``; the others left the workspace."""
        self.err[idx[keep]] = err[keep]
        self.q[idx[keep]] = q[keep]
        self.branch[idx[keep]] = branch[keep]
        self.within[idx[~keep]] = False


def _solve_broyden(problem: _Problem, before: np.ndarray, tol_mm: float, max_iter: int, progress) -> _Solution:
    """Full 3-D position: secant / Broyden iteration per point, vectorised over points."""
    sol = _Solution.start(problem, before)
    jac = np.repeat(np.eye(3)[None], len(problem.rows), axis=0)
    active = sol.within & ~np.isnan(sol.err).any(axis=1)
    already = active & (np.linalg.norm(np.nan_to_num(sol.err), axis=1) < tol_mm)
    sol.converged[already] = True
    active &= ~already
    for it in range(max_iter):
        if not active.any():
            break
        progress(f"iteration {it + 1}: {int(active.sum())} points")
        idx = np.nonzero(active)[0]
        # The first step is the error itself (the estimate starts at identity: no solve).
        step = -sol.err[idx] if it == 0 else -np.linalg.solve(jac[idx], sol.err[idx][..., None])[..., 0]
        new_cmd = sol.cmd[idx] + step
        new_err, q, b = problem.evaluate(new_cmd, active)
        sol.iterations[idx] += 1
        keep = ~np.isnan(new_err).any(axis=1)
        ss = np.einsum("ij,ij->i", step, step)
        done = keep & ((np.sqrt(ss) < tol_mm) | (np.linalg.norm(np.nan_to_num(new_err), axis=1) < tol_mm))
        go_on = keep & ~done & (ss > 0)  # only the points that iterate again need their estimate updated
        if go_on.any():
            _broyden_update(jac, idx[go_on], step[go_on], (new_err - sol.err[idx])[go_on], ss[go_on])
        sol.cmd[idx[keep]] = new_cmd[keep]
        sol.accept(idx, keep, new_err, q, b)
        sol.converged[idx[done]] = True
        active[idx[done | ~keep]] = False
    return sol


def _broyden_update(jac, idx, step, y, ss) -> None:
    """Broyden's rank-one update B += ((y - B s) s^T) / (s^T s) of the points ``idx``."""
    bs = np.einsum("nij,nj->ni", jac[idx], step)
    jac[idx] += np.einsum("ni,nj->nij", y - bs, step) / ss[:, None, None]


def _solve_seed000(problem: _Problem, before: np.ndarray, tol_mm: float, max_iter: int, progress) -> _Solution:
    """Seed 000 (eq. 10-15): across the tool axis the first error is subtracted once; along
    it, a secant iteration on the depth from a0 = ap, a1 = ap + e(a0)."""
    sol = _Solution.start(problem, before)
    axis = problem.target[:, :3, 2]  # the tool axis of each target
    axial = np.einsum("ij,ij->i", sol.err, axis)
    across = problem.goal - (sol.err - axial[:, None] * axis)
    a_prev = np.zeros(len(problem.rows))  # a0 = ap: no axial correction
    f_prev = axial
    a_now = -axial  # a1 = ap + e(a0), with e as (target - actual) along the axis
    active = sol.within & ~np.isnan(sol.err).any(axis=1)
    for _ in range(max_iter):
        if not active.any():
            break
        idx = np.nonzero(active)[0]
        e, q, b = problem.evaluate(across[idx] + a_now[idx, None] * axis[idx], active)
        sol.iterations[idx] += 1
        keep = ~np.isnan(e).any(axis=1)
        f_now = np.einsum("ij,ij->i", e, axis[idx])
        a_next = _secant_step(a_prev[idx], a_now[idx], f_prev[idx], f_now)
        sol.accept(idx, keep, e, q, b)
        done = keep & (np.abs(a_next - a_now[idx]) < tol_mm)
        sol.converged[idx[done]] = True
        a_prev[idx], f_prev[idx] = a_now[idx], f_now
        a_now[idx] = np.where(done, a_now[idx], a_next)
        active[idx[done | ~keep]] = False
    sol.cmd = across + a_now[:, None] * axis
    return sol


def _secant_step(a_prev, a_now, f_prev, f_now):
    """Next depth of the secant iteration (kept where the two errors are equal)."""
    denom = f_now - f_prev
    safe = np.abs(denom) > 1e-12
    return np.where(safe, a_now - f_now * (a_now - a_prev) / np.where(safe, denom, 1.0), a_now)


_SCHEMES = {"broyden": _solve_broyden, "seed000": _solve_seed000}


def _report(problem: _Problem, before: np.ndarray, sol: _Solution) -> Report:
    robot, rows, n = problem.plant.robot, problem.rows, len(problem.tp)
    margins = posture.singularity_margins(robot, sol.q)  # once, for the targets and the segments into them
    singular = posture.near_singular_margins(*margins) & ~np.isnan(sol.q).any(axis=1)
    changed = sol.within & (sol.branch != problem.branch_ref)
    posture_problem = problem.posture_problem.copy()
    blocked = problem.straight_segments_blocked(sol.cmd, sol.q, sol.branch, margins)
    posture_problem[(posture_problem == 0) & blocked] = POSTURE_PATH
    full = lambda fill, values, dtype=float: _scatter(n, rows, fill, values, dtype)  # noqa: E731
    return Report(
        line=problem.tp.line,
        compensated=full(False, np.ones(len(rows), bool), bool),
        iterations=full(0, sol.iterations, int),
        before_mm=full(np.nan, np.linalg.norm(before, axis=1)),
        after_mm=full(np.nan, np.linalg.norm(sol.err, axis=1)),
        correction_mm=full(np.nan, np.linalg.norm(sol.cmd - problem.goal, axis=1)),
        converged=full(True, sol.converged, bool),
        within_limits=full(True, sol.within, bool),
        singular=full(False, singular, bool),
        branch_changed=full(False, changed, bool),
        posture=full(0, posture_problem, int),
    )


def _outside_region(problem: _Problem, sol: _Solution, model: ErrorModel) -> dict[int, str] | None:
    """{target index: why it lies outside the region the model was measured in}: its joints
    where the model predicts them (the compensated command's, or the target's as written where
    there is none) and its TCP. None where the model records no region. (A dict, not a column:
    nearly always empty, and postproc.jobs.stream sends every chunk's report between processes.)"""
    if model.coverage is None:
        return None
    q = np.where(np.isnan(sol.q), problem.q_ref, sol.q)
    travel = None
    if model.coverage.travel_log1p is not None:  # the predictor reads the path: the program's moves must be like the measured ones
        travel = path_travel_mm(model.robot, model.tool_mm, q, previous_targets(problem.order_q)[problem.rows])
    outside = model.coverage.outside(q, problem.goal, travel)
    return {int(problem.rows[i]): outside.reason(int(i), model.coverage) for i in np.nonzero(outside.mask)[0]}


def _path_deviation(problem: _Problem, sol: _Solution, controller) -> np.ndarray:
    """Per Cartesian target: the largest predicted distance of the robot from the intended
    path on the segment into it (straight for LIN, the arc for a CIRC end point), with the
    controller interpolating the compensated commands; NaN where there is no such segment."""
    tp, rows = problem.tp, problem.rows
    kind = tp.kind[rows]
    follows = np.zeros(len(rows), dtype=bool)
    follows[1:] = rows[1:] == rows[:-1] + 1  # the previous motion is a Cartesian target too
    commands = problem.target.copy()
    commands[:, :3, 3] = sol.cmd
    goal = problem.goal
    deviation = np.full(len(rows), np.nan)
    length = np.zeros(len(rows))
    length[1:] = np.linalg.norm(np.diff(goal, axis=0), axis=1)
    # The robot's error varies smoothly, so a segment's departure from its chord grows with
    # the square of its length: 0.1 mm on 600 mm segments (tests/test_path_deviation.py) is
    # under 1e-5 mm at PATH_MIN_LENGTH_MM. Shorter segments are not sampled (NaN).
    long_enough = length >= PATH_MIN_LENGTH_MM
    for lin in _chunks(np.nonzero((kind == Kind.LINEAR) & follows & long_enough)[0]):
        actual = _predicted_samples(problem, sol, segments.linear_samples(commands[lin - 1], commands[lin]), lin)
        deviation[lin] = segments.distance_to_segments(actual, goal[lin - 1], goal[lin]).max(axis=1)
    arc = np.nonzero((kind == Kind.CIRC_END) & follows & np.roll(follows, 1) & (np.roll(kind, 1) == Kind.CIRC_VIA))[0]
    arc = arc[arc >= 2]
    if arc.size:  # the controller reads each arc's line (KRL's CA): only where there are arcs
        arc = arc[controller.arc_ends_at_target(tp)[rows[arc]]]
    for arc in _chunks(arc):
        actual = _predicted_samples(problem, sol, segments.arc_samples(commands[arc - 2], commands[arc - 1], commands[arc]), arc)
        deviation[arc] = segments.distance_to_circles(actual, goal[arc - 2], goal[arc - 1], goal[arc]).max(axis=1)
    return deviation


SEGMENT_CHUNK = 50_000  # segments sampled at once: memory bounded whatever the program's length


def _chunks(idx: np.ndarray):
    """``idx`` in pieces of SEGMENT_CHUNK (none when empty)."""
    for start in range(0, len(idx), SEGMENT_CHUNK):
        yield idx[start : start + SEGMENT_CHUNK]


def _predicted_samples(problem: _Problem, sol: _Solution, commanded: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Predicted TCP (M, K, 3) where the controller's interpolated commands (M, K, 4, 4) on
    the segments into targets ``idx`` put the robot (their end target's posture and tool)."""
    m, k = commanded.shape[:2]
    rows = np.repeat(problem.rows[idx], k)
    flange = commanded.reshape(-1, 4, 4) @ problem.plant.inv_tools[problem.tp.tool[rows]]
    q, _ = kin.branch_joints(problem.plant.robot, flange, np.repeat(sol.branch[idx], k), np.repeat(sol.q[idx], k, axis=0))
    return problem.plant.actual(q, rows, problem.order_q).reshape(m, k, 3)


# The inputs effects may consume at compensation time: (what it is, the option giving it).
_INPUTS = {"temp": ("the cell temperature in degC", "--temp"), "force": ("the process force (tool frame, N)", "--force fx,fy,fz")}


def check_inputs(model: ErrorModel, given: dict) -> None:
    """Every input an effect of the model consumes must be given, and every input given
    must be consumed by an effect of the model: an option that would change nothing is an error."""
    for effect in model.effects:
        for group in effect.consumes:
            if given.get(group) is None:
                what, option = _INPUTS[group]
                raise InputError(f"the model's {effect.name} effect needs {what}: give {option}")
    for group, value in given.items():
        if value is not None and not model.effects.consuming(group):
            what, option = _INPUTS[group]
            users = ", ".join(consumers_of(group)) or "none in the catalog"
            raise InputError(
                f"{option.split()[0]}: the model ({model.effects.spec()}) has no effect that uses {what} (effects that do: {users}); "
                f"fit one, e.g. 'postproc fit MEAS.csv --robot ... --from MODEL.json --effects +{users.split(', ')[0]} -o MODEL2.json', or leave the option out"
            )


def _force_rows(n: int, rows: np.ndarray, target: np.ndarray, force_tool_n) -> np.ndarray | None:
    """A constant tool-frame force as a base-frame force (n, 3) at every Cartesian target."""
    if force_tool_n is None:
        return None
    out = np.zeros((n, 3))
    out[rows] = target[:, :3, :3] @ np.asarray(force_tool_n, dtype=float).reshape(3)
    return out


def _line_offset(text: str, line: int) -> int:
    """Offset of the first character of 1-based ``line`` of ``text``."""
    at = 0
    for _ in range(line - 1):
        at = text.find("\n", at) + 1
        if at == 0:
            return len(text)
    return at


def _scatter(n, rows, fill, values, dtype):
    out = np.full(n, fill, dtype=dtype)
    out[rows] = values
    return out


def predicted_positions(tp: Toolpath, model: ErrorModel, *, controller, frames: dict | None = None, tools: dict | None = None,
                        start_joints=None, temp_c: float | None = None, force_n=None) -> tuple[np.ndarray, np.ndarray, list]:
    """Where ``model`` puts the TCP when ``controller`` runs the program as written: the
    program rows of its Cartesian targets, (M, 3) TCP positions in the robot base frame, mm,
    on the postures the controller's rules give (NaN where it cannot reach a target), and
    for each target why not (None where it can). Run with a validation model (or a simulated
    robot's truth), it tells where a compensated program will cut before it runs."""
    _require_usable_model(model)
    _require_process_inputs(model, temp_c, force_n)
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    _refuse_unplaced(tp)
    problem = _Problem.of(tp, model, controller, temp_c, force_n, start_joints)
    positions = problem.plant.actual(problem.q_ref, problem.rows, problem.order_q)
    why = [None if not np.isnan(p).any() else _POSTURE_TEXT.get(int(code), "out of reach or outside the joint limits")
           for p, code in zip(positions, problem.posture_problem)]
    return problem.rows, positions, why
