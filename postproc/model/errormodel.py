"""A robot's error model: nominal kinematics plus a sum of effects with parameter values.

``ErrorModel.predict`` gives where the measured point really is for commanded joints;
``ErrorModel.evaluate`` also gives the analytic Jacobian with respect to every parameter
(the identification Jacobian), from the frames of the perturbed chain:
d p / d theta_i = z_{i-1} x (p - o_{i-1}), d p / d d_i = z_{i-1}, d p / d a_i = x_i,
d p / d alpha_i = x_i x (p - o_i). Effects enter by kind (see ``postproc.model.effects.base``):
joint offsets and DH changes through the derivatives of the DH table (chain rule over the
geometry effects in their stage order), tool and Cartesian terms directly, the base
transform last. This module never asks which effect it is dealing with.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from postproc.errors import MeasurementError
from postproc.robot import kinematics as kin
from postproc.robot.frames import rotvec_to_matrix  # noqa: F401  (re-exported: older callers import it from here)
from postproc.robot.robots import RobotModel

from .effects import DH, Context, Effect, EffectSpecError, EffectSum, Param
from .effects.base import DH_CHANNELS
from .measurements import MeasurementSet
from .path_history import previous_targets
from .session_offsets import session_column

_GROUP_COLUMNS = {"force": "fx, fy, fz", "approach": "s1..s6", "temp": "temp", "t": "t"}
_DEG = np.pi / 180.0
_ANGLES = {"theta": _DEG, "d": 1.0, "a": 1.0, "alpha": _DEG}  # DH channel unit -> radians / mm


@dataclass(frozen=True)
class Prepared:
    """Everything about a measurement set that does not depend on the parameter values."""

    ctx: Context
    data: tuple  # per effect of the model, in its order: what Effect.prepare returned
    indices: tuple[np.ndarray, ...]  # per effect: the indices of its parameters in the model
    kinds: tuple[str, ...]  # per effect: its kind
    notes: tuple[str, ...] = ()  # columns the effects inferred (e.g. approach directions from the row order)
    sessions: np.ndarray | None = None  # (N,) measuring session ids, where the model has session offsets and the data the column

    @property
    def approach_inferred(self) -> bool:
        return bool(self.notes)

    @property
    def bases(self) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
        """(basis (N, 6, Pe) deg/unit, parameter indices) of the joint-space effects."""
        return tuple((d, i) for d, i, k in zip(self.data, self.indices, self.kinds) if k == "joint")


@dataclass(frozen=True)
class ErrorModel:
    robot: RobotModel
    tool_mm: np.ndarray  # (3,) nominal measured point in the flange frame
    effects: EffectSum
    values: np.ndarray  # (P,) parameter values, order of ``params``
    params: tuple[Param, ...]
    base_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))  # R0 of the base-frame registration
    base_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))  # t0
    residual: object | None = None  # a data-driven predictor of what the effects leave (postproc.model.learn.Residual)
    coverage: object | None = None  # the region it was fitted on (postproc.model.coverage.Coverage); None: unknown
    # each measuring session's frame shift (postproc.model.session_offsets.SessionOffsets): added to
    # predictions of measurements of those sessions, never to a program's (it has no session)
    session_offsets: object | None = None

    # ------------------------------------------------------------------ building

    @classmethod
    def create(cls, robot: RobotModel, tool_mm, effects: EffectSum, values: dict[str, float] | None = None) -> "ErrorModel":
        params: list[Param] = []
        seen = set()
        for effect in effects:
            for p in effect.params(robot):
                if p.name not in seen:
                    seen.add(p.name)
                    params.append(p)
        vals = np.array([p.initial for p in params], dtype=float)
        model = cls(robot, np.asarray(tool_mm, dtype=float).reshape(3), effects, vals, tuple(params))
        return model.with_values(values or {})

    def index(self, name: str) -> int:
        for i, p in enumerate(self.params):
            if p.name == name:
                return i
        raise KeyError(name)

    def indices_of(self, effect: Effect) -> np.ndarray:
        """Indices of one effect's parameters in this model (shared parameters included)."""
        return np.array([self.index(p.name) for p in effect.params(self.robot)], dtype=int)

    def owner(self, param_name: str) -> Effect:
        """The first effect of the model that declares a parameter."""
        return next(e for e in self.effects if any(p.name == param_name for p in e.params(self.robot)))

    def value(self, name: str, default: float = 0.0) -> float:
        try:
            return float(self.values[self.index(name)])
        except KeyError:
            return default

    def with_values(self, values: dict[str, float]) -> "ErrorModel":
        new = self.values.copy()
        for name, v in values.items():
            try:
                new[self.index(name)] = v
            except KeyError:
                continue  # a parameter of an effect this model does not have
        return replace(self, values=new)

    def with_vector(self, values: np.ndarray) -> "ErrorModel":
        return replace(self, values=np.asarray(values, dtype=float).copy())

    def as_dict(self) -> dict[str, float]:
        return {p.name: float(v) for p, v in zip(self.params, self.values)}

    # ----------------------------------------------------------------- data side

    def prepare(self, meas: MeasurementSet | None = None, *, q_deg=None, force_n=None, approach=None, temp_c=None, time_s=None,
                previous_q_deg=None) -> Prepared:
        """Compute what the effects need from the data; a missing column is a clear error.
        ``previous_q_deg`` (N, k, 6): the targets before each pose in path order, for a
        residual predictor that reads them; absent, the rows' own order is the path."""
        sessions = None
        if meas is not None:
            q_deg, force_n, approach, temp_c, time_s = meas.q_deg, meas.force_n, meas.approach, meas.temp_c, meas.time_s
            previous_q_deg = meas.previous_q_deg
            source = meas.source
            if self.session_offsets is not None:
                sessions = session_column(meas, required=False)
        else:
            source = "<arrays>"
        q = np.asarray(q_deg, dtype=float)
        if previous_q_deg is None and getattr(self.residual, "reads_history", False):
            previous_q_deg = previous_targets(q)  # a measurement file's rows are in the order they were measured
        present = {"force": force_n is not None, "approach": approach is not None, "temp": temp_c is not None, "t": time_s is not None}
        for effect in self.effects:
            for group in effect.needs:
                if not present[group]:
                    raise MeasurementError(source, 1, _GROUP_COLUMNS[group].split(",")[0], f"effect '{effect.name}' needs column(s) {_GROUP_COLUMNS[group]}, which the data lack")
        force_torque = None
        if force_n is not None:
            jac = kin.jacobian(self.robot, q, tool=self.tool_mm)
            force_torque = np.einsum("nij,ni->nj", jac[:, :3], np.asarray(force_n, dtype=float)) / 1000.0
        ctx = Context(q_deg=q, gravity_torque=None, force_torque=force_torque, approach=approach, temp_c=temp_c, time_s=time_s,
                      tool_mm=self.tool_mm, force_n=None if force_n is None else np.asarray(force_n, dtype=float),
                      previous_q_deg=previous_q_deg)
        notes = []
        for effect in self.effects:
            ctx, note = effect.complete(ctx)
            if note:
                notes.append(note)
        data = tuple(effect.prepare(ctx, self.robot) for effect in self.effects)
        return Prepared(ctx, data, tuple(self.indices_of(e) for e in self.effects),
                        tuple(e.kind for e in self.effects), tuple(notes), sessions)

    def _parts(self, prep: Prepared, kind: str):
        """(effect, prepared data, parameter indices) of the model's effects of one kind."""
        parts = [(e, d, i) for e, d, i in zip(self.effects, prep.data, prep.indices) if e.kind == kind]
        return sorted(parts, key=lambda part: part[0].stage) if kind == "geometry" else parts

    # ------------------------------------------------------------------ geometry

    def _dh(self, prep: Prepared, values: np.ndarray) -> DH:
        """The per-pose DH table with the joint-space effects, before the geometry effects."""
        robot = self.robot
        q = prep.ctx.q_deg
        dq = np.zeros_like(q)
        for _, basis, idx in self._parts(prep, "joint"):
            dq += np.einsum("njp,p->nj", basis, values[idx])
        shape = q.shape
        return DH((q + dq) * robot.joint_sign + robot.theta0_deg, np.broadcast_to(robot.d_mm, shape),
                  np.broadcast_to(robot.a_mm, shape), np.broadcast_to(robot.alpha_deg, shape))

    def _geometry(self, prep: Prepared, values: np.ndarray, dh: DH | None = None):
        """The perturbed DH table, tool (3,) and base transform (R, t)."""
        dh = self._dh(prep, values) if dh is None else dh
        for effect, data, idx in self._parts(prep, "geometry"):
            dh = effect.apply_dh(dh, values[idx], data)
        tool = self.tool_mm.copy()
        for effect, _, idx in self._parts(prep, "tool"):
            tool = tool + effect.tool_basis() @ values[idx]
        rot, trans = self.base_rotation, self.base_translation
        for effect, _, idx in self._parts(prep, "base"):
            r, t = effect.transform(values[idx])
            rot, trans = r @ rot, trans + t
        return dh, tool, rot, trans

    def _displacement(self, prep: Prepared, values: np.ndarray) -> np.ndarray | float:
        """Cartesian effects' displacement of the measured point, robot base frame (N, 3) mm."""
        out = 0.0
        for _, basis, idx in self._parts(prep, "cartesian"):
            out = out + np.einsum("ncp,p->nc", basis, values[idx])
        return out

    def predict_prepared(self, prep: Prepared, values: np.ndarray | None = None) -> np.ndarray:
        """Predicted measured positions (N, 3) in the measurement frame: the effects, plus the
        data-driven residual predictor when the model has one (a hybrid model)."""
        values = self.values if values is None else values
        dh, tool, rot, trans = self._geometry(prep, values)
        pos = kin.forward_dh(dh.theta, dh.d, dh.a, dh.alpha, tool=tool)[:, :3, 3] + self._displacement(prep, values)
        pos = pos @ rot.T + trans
        if self.residual is not None:
            pos = pos + self.residual.predict(self.robot, self.tool_mm, prep.ctx.q_deg, prep.ctx.previous_q_deg)
        if self.session_offsets is not None and prep.sessions is not None:
            pos = pos + self.session_offsets.at(prep.sessions)
        return pos

    def predict(self, meas: MeasurementSet) -> np.ndarray:
        return self.predict_prepared(self.prepare(meas))

    def _dh_jacobian(self, prep: Prepared, values: np.ndarray, dh: DH) -> dict[str, list]:
        """d(DH channel)/d(parameters) by the chain rule, as blocks per channel: (parameter
        indices, (N, 6, Pe) or constant (6, Pe)) — only the columns an effect touches."""
        blocks: dict[str, list] = {ch: [] for ch in DH_CHANNELS}
        for _, basis, idx in self._parts(prep, "joint"):
            blocks["theta"].append((idx, self.robot.joint_sign[None, :, None] * basis))
        for effect, data, idx in self._parts(prep, "geometry"):
            scale, own = effect.dh_derivatives(dh, values[idx], data)
            for ch, factor in scale.items():
                blocks[ch] = [(i, np.asarray(factor)[..., None] * block) for i, block in blocks[ch]]
            for ch, derivative in own.items():
                blocks[ch].append((idx, derivative))
            dh = effect.apply_dh(dh, values[idx], data)
        return blocks

    def evaluate(self, prep: Prepared, values: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted positions (N, 3) and their Jacobian (N, 3, P) with respect to every parameter."""
        values = self.values if values is None else values
        dh0 = self._dh(prep, values)
        blocks = self._dh_jacobian(prep, values, dh0)
        dh, tool, rot, trans = self._geometry(prep, values, dh0)
        rots, origins = kin.frames_dh(dh.theta, dh.d, dh.a, dh.alpha)
        p = origins[:, 6] + rots[:, 6] @ tool  # measured point in the robot base frame
        z_prev, o_prev = rots[:, :6, :, 2], origins[:, :6]  # z_{i-1}, o_{i-1}
        x_i, o_i = rots[:, 1:, :, 0], origins[:, 1:]
        d_point = {"theta": np.cross(z_prev, p[:, None] - o_prev), "d": z_prev, "a": x_i, "alpha": np.cross(x_i, p[:, None] - o_i)}
        n = len(p)
        jac = np.zeros((n, 3, len(self.params)))
        for ch in DH_CHANNELS:
            per_unit = np.ascontiguousarray((d_point[ch] * _ANGLES[ch]).transpose(0, 2, 1))  # (N, 3, 6)
            for idx, block in blocks[ch]:
                # d p / d params = d p / d channel_i . d channel_i / d params (a GEMM for constant blocks).
                if block.ndim == 2:
                    jac[:, :, _columns(idx)] += (per_unit.reshape(-1, 6) @ block).reshape(n, 3, -1)
                else:
                    jac[:, :, _columns(idx)] += np.matmul(per_unit, block)
        for effect, _, idx in self._parts(prep, "tool"):
            jac[:, :, _columns(idx)] += np.einsum("nij,jp->nip", rots[:, 6], effect.tool_basis())
        for _, basis, idx in self._parts(prep, "cartesian"):
            jac[:, :, _columns(idx)] += basis
        p = p + self._displacement(prep, values)
        jac = np.matmul(rot, jac)  # into the measurement frame
        measured = p @ rot.T + trans
        for effect, _, idx in self._parts(prep, "base"):
            jac[:, :, idx] = effect.base_jacobian(measured - trans, values[idx])
        return measured, jac

    # ---------------------------------------------------------------- summaries

    def base_transform(self) -> tuple[np.ndarray, np.ndarray]:
        """Total robot-base -> measurement-frame transform (R, t): registration and base-frame parameters."""
        rot, trans = self.base_rotation, self.base_translation
        for effect in self.effects.of_kind("base"):
            r, t = effect.transform(self.values[self.indices_of(effect)])
            rot, trans = r @ rot, trans + t
        return rot, trans

    def nominal(self) -> "ErrorModel":
        """The same robot and tool with no effects (what the controller assumes)."""
        return ErrorModel.create(self.robot, self.tool_mm, EffectSum())


def _columns(idx: np.ndarray):
    """A run of consecutive parameter indices as a slice (an in-place view), else the indices."""
    if len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def require_resolved(effects: EffectSum) -> None:
    for effect in effects:
        if not effect.resolved:
            raise EffectSpecError(f"{effect.spec()} leaves its terms to a fit, which chooses them from measurements: "
                                  "name the terms (e.g. joints=2;orders=17) to evaluate or simulate it")
