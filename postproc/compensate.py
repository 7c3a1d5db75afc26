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
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import kinematics as kin
from .effects import consumers_of
from .errormodel import ErrorModel
from .errors import InputError, JobError
from .frames import invert_transform
from .ir import Kind, Toolpath

SINGULAR_DEG = 2.0  # within this many degrees of a wrist or elbow singularity: flagged
SHOULDER_MM = 20.0  # wrist centre closer than this to axis 1: flagged


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

    @property
    def failed(self) -> np.ndarray:
        return self.compensated & ~(self.converged & self.within_limits & ~self.singular & ~self.branch_changed)

    def failures(self) -> list[tuple[int, str]]:
        out = []
        for i in np.nonzero(self.failed)[0]:
            reasons = []
            if not self.within_limits[i]:
                reasons.append("out of reach or outside the joint limits")
            if self.singular[i]:
                reasons.append("near a singularity")
            if self.branch_changed[i]:
                reasons.append("would change IK branch")
            if not self.converged[i] and self.within_limits[i]:
                reasons.append(f"did not converge (residual {self.after_mm[i]:.4f} mm after {self.iterations[i]} iterations)")
            out.append((int(self.line[i]), "; ".join(reasons)))
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
        }


def _wrist_elbow_shoulder(robot, q: np.ndarray) -> np.ndarray:
    """True where q is within SINGULAR_DEG of a wrist or elbow singularity or the shoulder one."""
    p = robot.opw
    phi = kin.opw_angles(robot, q)
    wrist = np.abs(np.sin(phi[:, 4])) < np.sin(np.deg2rad(SINGULAR_DEG))
    elbow = np.abs(np.sin(phi[:, 2] + np.arctan2(p.a2, p.c3))) < np.sin(np.deg2rad(SINGULAR_DEG))
    radial, _ = kin.wrist_centre_in_arm_plane(robot, phi)
    shoulder = np.abs(radial) < SHOULDER_MM
    return wrist | elbow | shoulder


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
        sols = kin.ik(self.robot, flange)
        return kin.select_branch(self.robot, sols, branch_ref, q_ref)

    def actual(self, q: np.ndarray, rows: np.ndarray, order_q: np.ndarray | None = None) -> np.ndarray:
        """Predicted TCP (N, 3) of the program's tools at joints q (rows index the program)."""
        out = np.full((len(q), 3), np.nan)
        ok = ~np.isnan(q).any(axis=1)
        for t in np.unique(self.tool_index[rows]):
            sel = ok & (self.tool_index[rows] == t)
            if not sel.any():
                continue
            m = replace(self.model, tool_mm=self.tools[t][:3, 3])
            columns = {"temp": None if self.temp_c is None else np.full(int(sel.sum()), self.temp_c),
                       "force": None if self.force_rows is None else self.force_rows[rows][sel], "approach": None}
            if order_q is not None:
                # Columns the effects derive from the program's path (e.g. approach directions).
                for effect in m.effects:
                    columns.update({group: col[rows][sel] for group, col in effect.path_columns(order_q).items()})
            prep = m.prepare(q_deg=q[sel], force_n=columns["force"], approach=columns["approach"], temp_c=columns["temp"], time_s=None)
            out[sel] = m.predict_prepared(prep)
        return out


def _reference_joints(tp: Toolpath, robot, flange: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The joints the controller would use for each target as written: from the program's
    configuration data where it has some, else by continuity along the path."""
    notes: list[str] = []
    sols = kin.ik(robot, flange)
    conf = tp.conf[rows]
    q = np.full((len(rows), 6), np.nan)
    branch = np.full(len(rows), -1)
    if tp.dialect == "rapid":
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = kin.select_by_abb_conf(robot, sols[has], conf[has].astype(int))
    elif tp.dialect == "krl":
        has = ~np.isnan(conf[:, :2]).any(axis=1)
        if has.any():
            q[has], branch[has] = kin.select_by_kuka_status(robot, sols[has], conf[has, 0].astype(int), conf[has, 1].astype(int))
    missing = np.isnan(q).any(axis=1)
    if missing.any():
        if (~missing & ~np.isnan(conf).all(axis=1)).sum() < (~np.isnan(conf).all(axis=1)).sum():
            notes.append("some configuration data match no IK solution of the nominal model; those targets follow the path instead")
        # Without configuration data the controller keeps its branch along the path: the
        # branch of the first target nearest the middle of the joint ranges.
        start = np.clip(np.zeros(6), robot.lower_deg, robot.upper_deg)
        path_q, path_branch, _ = kin.select_path(robot, sols if missing.all() else sols[missing], start)  # (no copy of all 8 solutions)
        # Big steps between targets are the program's business; reachability is ours.
        usable = kin.within_limits(robot, path_q)
        q[missing] = np.where(usable[:, None], path_q, np.nan)
        branch[missing] = np.where(usable, path_branch, -1)
    return q, branch, notes


def compensate(
    tp: Toolpath,
    model: ErrorModel,
    *,
    tol_mm: float = 0.01,
    max_iter: int = 25,
    scheme: str = "broyden",
    temp_c: float | None = None,
    force_n=None,
    frames: dict | None = None,
    tools: dict | None = None,
    progress=lambda msg: None,
) -> tuple[Toolpath, Report]:
    """Compensated copy of a toolpath and the per-point report (see the module docstring)."""
    if scheme not in ("broyden", "seed000"):
        raise InputError(f"unknown compensation scheme '{scheme}' (broyden or seed000)")
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
    check_inputs(model, {"temp": temp_c, "force": force_n})

    arcs = np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW))
    if arcs.any():
        # Moving an arc's end points without its centre would change its radius (LinuxCNC,
        # for one, rejects such an arc): refuse rather than write a program that may not run.
        lines = ", ".join(str(v) for v in tp.line[arcs][:10])
        raise InputError(f"G2/G3 arcs on lines {lines}: arc centres are not compensated yet; linearise the arcs (or use R-format moves) first")
    written = tp
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    n = len(tp)
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
        raise InputError(f"targets on lines {lines} cannot be placed in the robot base frame (undefined point, frame or tool).{hint}")
    rows = np.nonzero(cart)[0]
    base = tp.base_poses()
    if np.isnan(tp.orientation[rows]).any():
        raise InputError("targets without an orientation (3-axis G-code) need one: convert the program for a robot first")
    target = base[rows]
    plant = _Plant(model, tp.tools, tp.tool, temp_c, _force_rows(n, rows, target, force_n))
    flange0 = target @ plant.inv_tools[tp.tool[rows]]
    q_ref, branch_ref, notes = _reference_joints(tp, robot, flange0, rows)
    order_q = np.zeros((n, 6))
    order_q[rows] = np.nan_to_num(q_ref)

    goal = target[:, :3, 3]
    progress("predicting the program as written")
    before = plant.actual(q_ref, rows, order_q) - goal
    within = ~np.isnan(q_ref).any(axis=1)

    cmd = goal.copy()
    err = before.copy()
    iterations = np.zeros(len(rows), dtype=int)
    converged = np.zeros(len(rows), dtype=bool)
    q_now = q_ref.copy()
    branch_now = branch_ref.copy()

    def evaluate(c, active):
        poses = target[active].copy()
        poses[:, :3, 3] = c
        q, b = plant.joints(poses, rows[active], q_ref[active], branch_ref[active])
        order_q[rows[active]] = np.where(np.isnan(q), order_q[rows[active]], q)
        return plant.actual(q, rows[active], order_q) - goal[active], q, b

    if scheme == "broyden":
        jac = np.repeat(np.eye(3)[None], len(rows), axis=0)
        active = within & ~np.isnan(err).any(axis=1)
        already = active & (np.linalg.norm(np.nan_to_num(err), axis=1) < tol_mm)
        converged[already] = True
        active &= ~already
        for it in range(max_iter):
            if not active.any():
                break
            progress(f"iteration {it + 1}: {int(active.sum())} points")
            idx = np.nonzero(active)[0]
            step = -np.linalg.solve(jac[idx], err[idx][..., None])[..., 0]
            new_cmd = cmd[idx] + step
            new_err, q, b = evaluate(new_cmd, active)
            iterations[idx] += 1
            lost = np.isnan(new_err).any(axis=1)
            y = new_err - err[idx]
            ss = np.einsum("ij,ij->i", step, step)
            upd = ~lost & (ss > 0)
            # Broyden: B += ((y - B s) s^T) / (s^T s)
            bs = np.einsum("nij,nj->ni", jac[idx], step)
            jac[idx[upd]] += np.einsum("ni,nj->nij", (y - bs)[upd], step[upd]) / ss[upd, None, None]
            keep = ~lost
            cmd[idx[keep]] = new_cmd[keep]
            err[idx[keep]] = new_err[keep]
            q_now[idx[keep]] = q[keep]
            branch_now[idx[keep]] = b[keep]
            within[idx[lost]] = False
            done = keep & ((np.sqrt(ss) < tol_mm) | (np.linalg.norm(np.nan_to_num(new_err), axis=1) < tol_mm))
            converged[idx[done]] = True
            active[idx[done | lost]] = False
    else:
        axis = target[:, :3, 2]  # the tool axis of each target
        axial = np.einsum("ij,ij->i", err, axis)
        # Across the tool axis: the first prediction's error is subtracted once (seed 000 step 2).
        cmd = goal - (err - axial[:, None] * axis)
        a_prev = np.zeros(len(rows))  # a0 = ap: no axial correction
        f_prev = axial
        a_now = -axial  # a1 = ap + e(a0), with e as (target - actual) along the axis
        active = within & ~np.isnan(err).any(axis=1)
        for it in range(max_iter):
            if not active.any():
                break
            idx = np.nonzero(active)[0]
            c = cmd[idx] + a_now[idx, None] * axis[idx]
            e, q, b = evaluate(c, active)
            iterations[idx] += 1
            lost = np.isnan(e).any(axis=1)
            f_now = np.einsum("ij,ij->i", e, axis[idx])
            denom = f_now - f_prev[idx]
            safe = np.abs(denom) > 1e-12
            a_next = np.where(safe, a_now[idx] - f_now * (a_now[idx] - a_prev[idx]) / np.where(safe, denom, 1.0), a_now[idx])
            keep = ~lost
            err[idx[keep]] = e[keep]
            q_now[idx[keep]] = q[keep]
            branch_now[idx[keep]] = b[keep]
            within[idx[lost]] = False
            done = keep & (np.abs(a_next - a_now[idx]) < tol_mm)
            converged[idx[done]] = True
            a_prev[idx], f_prev[idx] = a_now[idx], f_now
            a_now[idx] = np.where(done, a_now[idx], a_next)
            active[idx[done | lost]] = False
        cmd = cmd + a_now[:, None] * axis

    singular = np.zeros(len(rows), dtype=bool)
    ok_q = ~np.isnan(q_now).any(axis=1)
    singular[ok_q] = _wrist_elbow_shoulder(robot, q_now[ok_q])
    changed = within & (branch_now != branch_ref)

    # Commands back into each target's own frame.
    new_base = target.copy()
    new_base[:, :3, 3] = cmd
    local = invert_transform(tp.frames[tp.frame[rows]]) @ new_base
    position = tp.position.copy()
    position[rows] = local[:, :3, 3]

    full = lambda fill, values, dtype=float: _scatter(n, rows, fill, values, dtype)  # noqa: E731
    report = Report(
        line=tp.line,
        compensated=full(False, np.ones(len(rows), bool), bool),
        iterations=full(0, iterations, int),
        before_mm=full(np.nan, np.linalg.norm(before, axis=1)),
        after_mm=full(np.nan, np.linalg.norm(err, axis=1)),
        correction_mm=full(np.nan, np.linalg.norm(cmd - goal, axis=1)),
        converged=full(True, converged, bool),
        within_limits=full(True, within, bool),
        singular=full(False, singular, bool),
        branch_changed=full(False, changed, bool),
    )
    out = written.with_positions(position)
    if notes:
        out = replace(out, notes=out.notes + tuple(notes))
    return out, report


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


def _scatter(n, rows, fill, values, dtype):
    out = np.full(n, fill, dtype=dtype)
    out[rows] = values
    return out
