"""A robot's error model: nominal kinematics plus a sum of effects with parameter values.

``ErrorModel.predict`` gives where the measured point really is for commanded joints;
``ErrorModel.evaluate`` also gives the analytic Jacobian with respect to every parameter
(the identification Jacobian), from the frames of the perturbed chain:
d p / d theta_i = z_{i-1} x (p - o_{i-1}), d p / d d_i = z_{i-1}, d p / d a_i = x_i,
d p / d alpha_i = x_i x (p - o_i); joint-space effects enter through d p / d theta.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from . import kinematics as kin
from .effects import Context, EffectSpecError, EffectSum, Param
from .effects.backlash import approach_from_order
from .effects.base_frame import rotvec_to_matrix
from .errors import MeasurementError
from .measurements import MeasurementSet
from .robots import RobotModel

_GROUP_COLUMNS = {"force": "fx, fy, fz", "approach": "s1..s6", "temp": "temp", "t": "t"}


@dataclass(frozen=True)
class Prepared:
    """Everything about a measurement set that does not depend on the parameter values."""

    ctx: Context
    bases: tuple[tuple[np.ndarray, np.ndarray], ...]  # (basis (N, 6, Pe) deg/unit, parameter indices)
    delta_t: np.ndarray | None  # (N,) temperature minus the thermal reference
    approach_inferred: bool


@dataclass(frozen=True)
class ErrorModel:
    robot: RobotModel
    tool_mm: np.ndarray  # (3,) nominal measured point in the flange frame
    effects: EffectSum
    values: np.ndarray  # (P,) parameter values, order of ``params``
    params: tuple[Param, ...]
    base_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))  # R0 of the base-frame registration
    base_translation: np.ndarray = field(default_factory=lambda: np.zeros(3))  # t0
    residual: object | None = None  # a data-driven predictor of what the effects leave (postproc.learn.Residual)

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

    def prepare(self, meas: MeasurementSet | None = None, *, q_deg=None, force_n=None, approach=None, temp_c=None, time_s=None) -> Prepared:
        """Compute what the effects need from the data; a missing column is a clear error."""
        if meas is not None:
            q_deg, force_n, approach, temp_c, time_s = meas.q_deg, meas.force_n, meas.approach, meas.temp_c, meas.time_s
            source = meas.source
        else:
            source = "<arrays>"
        q = np.asarray(q_deg, dtype=float)
        present = {"force": force_n is not None, "approach": approach is not None, "temp": temp_c is not None, "t": time_s is not None}
        for effect in self.effects:
            for group in effect.needs:
                if not present[group]:
                    raise MeasurementError(source, 1, _GROUP_COLUMNS[group].split(",")[0], f"effect '{effect.name}' needs column(s) {_GROUP_COLUMNS[group]}, which the data lack")
        inferred = False
        if approach is None and self.effects.get("backlash") is not None:
            approach = approach_from_order(q)
            inferred = True
        force_torque = None
        if force_n is not None:
            jac = kin.jacobian(self.robot, q, tool=self.tool_mm)
            force_torque = np.einsum("nij,ni->nj", jac[:, :3], np.asarray(force_n, dtype=float)) / 1000.0
        ctx = Context(q_deg=q, gravity_torque=None, force_torque=force_torque, approach=approach, temp_c=temp_c, time_s=time_s)
        bases = []
        for effect in self.effects:
            if effect.kind == "joint":
                idx = np.array([self.index(p.name) for p in effect.params(self.robot)], dtype=int)
                bases.append((effect.joint_basis(ctx, self.robot), idx))
        thermal = self.effects.get("thermal")
        delta_t = None if thermal is None else np.asarray(temp_c, dtype=float) - thermal.reference_c
        return Prepared(ctx, tuple(bases), delta_t, inferred)

    # ------------------------------------------------------------------ geometry

    def _geometry(self, prep: Prepared, values: np.ndarray):
        """DH angles (N, 6) deg, d, a ((6,) or (N, 6)) mm, alpha (6,) deg, tool (3,), base (R, t)."""
        robot = self.robot
        q = prep.ctx.q_deg
        dq = np.zeros_like(q)
        for basis, idx in prep.bases:
            dq += np.einsum("njp,p->nj", basis, values[idx])
        theta = (q + dq) * robot.joint_sign + robot.theta0_deg
        d, a, alpha = robot.d_mm.copy(), robot.a_mm.copy(), robot.alpha_deg.copy()
        if self.effects.get("geometric") is not None:
            geo = np.array([[values[self.index(f"geometric.{k}{i + 1}")] for k in ("dtheta", "dd", "da", "dalpha")] for i in range(6)])
            theta = theta + geo[:, 0]
            d, a, alpha = d + geo[:, 1], a + geo[:, 2], alpha + geo[:, 3]
        if prep.delta_t is not None:
            grow = 1.0 + values[self.index("thermal.alpha")] * prep.delta_t[:, None]
            d, a = d[None, :] * grow, a[None, :] * grow
        tool = self.tool_mm.copy()
        if self.effects.get("tool_offset") is not None:
            tool = tool + np.array([values[self.index(f"tool_offset.d{ax}")] for ax in "xyz"])
        rot, trans = self.base_rotation, self.base_translation
        if self.effects.get("base_frame") is not None:
            r = np.array([values[self.index(f"base_frame.r{ax}")] for ax in "xyz"])
            t = np.array([values[self.index(f"base_frame.t{ax}")] for ax in "xyz"])
            rot, trans = rotvec_to_matrix(r) @ rot, trans + t
        return theta, d, a, alpha, tool, rot, trans

    def predict_prepared(self, prep: Prepared, values: np.ndarray | None = None) -> np.ndarray:
        """Predicted measured positions (N, 3) in the measurement frame: the effects, plus the
        data-driven residual predictor when the model has one (a hybrid model)."""
        values = self.values if values is None else values
        theta, d, a, alpha, tool, rot, trans = self._geometry(prep, values)
        pos = kin.forward_dh(theta, d, a, alpha, tool=tool)[:, :3, 3] @ rot.T + trans
        if self.residual is not None:
            pos = pos + self.residual.predict(self.robot, self.tool_mm, prep.ctx.q_deg)
        return pos

    def predict(self, meas: MeasurementSet) -> np.ndarray:
        return self.predict_prepared(self.prepare(meas))

    def evaluate(self, prep: Prepared, values: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted positions (N, 3) and their Jacobian (N, 3, P) with respect to every parameter."""
        values = self.values if values is None else values
        robot = self.robot
        theta, d, a, alpha, tool, rot, trans = self._geometry(prep, values)
        rots, origins = kin.frames_dh(theta, d, a, alpha)
        p = origins[:, 6] + rots[:, 6] @ tool  # TCP in the robot base frame
        z_prev = rots[:, :6, :, 2]  # z_{i-1}, (N, 6, 3)
        o_prev = origins[:, :6]
        x_i = rots[:, 1:, :, 0]  # x_i
        o_i = origins[:, 1:]
        d_theta = np.cross(z_prev, p[:, None] - o_prev)  # per radian, (N, 6, 3)
        d_d = z_prev
        d_a = x_i
        d_alpha = np.cross(x_i, p[:, None] - o_i)
        n = len(p)
        jac = np.zeros((n, 3, len(self.params)))
        deg = np.pi / 180.0
        if self.effects.get("geometric") is not None:
            for i in range(6):
                jac[:, :, self.index(f"geometric.dtheta{i + 1}")] = d_theta[:, i] * deg
                grow = 1.0 if prep.delta_t is None else (1.0 + values[self.index("thermal.alpha")] * prep.delta_t)[:, None]
                jac[:, :, self.index(f"geometric.dd{i + 1}")] = d_d[:, i] * grow
                jac[:, :, self.index(f"geometric.da{i + 1}")] = d_a[:, i] * grow
                jac[:, :, self.index(f"geometric.dalpha{i + 1}")] = d_alpha[:, i] * deg
        for basis, idx in prep.bases:
            # d p / d param = sum_i d p / d theta_i * sign_i * (pi/180) * basis_i
            jac[:, :, idx] += np.einsum("nic,ni,nip->ncp", d_theta, np.broadcast_to(robot.joint_sign * deg, (n, 6)), basis)
        if prep.delta_t is not None:
            d_base = np.broadcast_to(d, (n, 6)) / (1.0 + values[self.index("thermal.alpha")] * prep.delta_t)[:, None]
            a_base = np.broadcast_to(a, (n, 6)) / (1.0 + values[self.index("thermal.alpha")] * prep.delta_t)[:, None]
            growth = np.einsum("nic,ni->nc", d_d, d_base) + np.einsum("nic,ni->nc", d_a, a_base)
            jac[:, :, self.index("thermal.alpha")] = growth * prep.delta_t[:, None]
        if self.effects.get("tool_offset") is not None:
            for k, ax in enumerate("xyz"):
                jac[:, :, self.index(f"tool_offset.d{ax}")] = rots[:, 6, :, k]
        # Into the measurement frame.
        jac = np.einsum("ij,njp->nip", rot, jac)
        measured = p @ rot.T + trans
        if self.effects.get("base_frame") is not None:
            for k, ax in enumerate("xyz"):
                unit = np.zeros(3)
                unit[k] = 1.0
                jac[:, :, self.index(f"base_frame.t{ax}")] = unit
                # A small rotation about axis k turns v = R p by (e_k x v).
                jac[:, :, self.index(f"base_frame.r{ax}")] = np.cross(unit, measured - trans) * deg
        return measured, jac

    # ---------------------------------------------------------------- summaries

    def base_transform(self) -> tuple[np.ndarray, np.ndarray]:
        """Total robot-base -> measurement-frame transform (R, t): registration and base_frame parameters."""
        if self.effects.get("base_frame") is None:
            return self.base_rotation, self.base_translation
        r = np.array([self.value(f"base_frame.r{ax}") for ax in "xyz"])
        t = np.array([self.value(f"base_frame.t{ax}") for ax in "xyz"])
        return rotvec_to_matrix(r) @ self.base_rotation, self.base_translation + t

    def nominal(self) -> "ErrorModel":
        """The same robot and tool with no effects (what the controller assumes)."""
        return ErrorModel.create(self.robot, self.tool_mm, EffectSum())


def require_resolved(effects: EffectSum) -> None:
    harmonics = effects.get("joint_harmonics")
    if harmonics is not None and not harmonics.resolved:
        raise EffectSpecError("joint_harmonics without options must be resolved by a fit before the model is evaluated")
