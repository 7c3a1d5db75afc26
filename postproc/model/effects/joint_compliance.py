"""Joint deflection under gravity (and payload): delta q_i = c_i tau_g,i(q) (seed 001 eq. 4-8).

The compliances c_i = 1 / k_i (rad/(N*m)) are identified, starting from the robot file's
stiffness. They are shared with ``external_load``: one joint has one stiffness.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import gravity_torque

from .base import Context, Effect, EffectSpecError, Param

COMPLIANCE_IDENTIFIABILITY = (
    "A compliance is identified only where the data load its joint: joint 1's gravity torque is zero on a level "
    "base and joint 6's with the tool on its axis, so those stay at the data sheet's value. Gravity moves joints "
    "2 and 3 together: a constant part of their deflection is absorbed by the joint zero offsets (geometric.dtheta)."
)


def compliance_params(robot) -> list[Param]:
    return [
        # A joint cannot be more than 20 times softer than its data sheet, nor negative.
        Param(f"compliance.c{i + 1}", "rad/(N*m)", 1.0 / k, 1.0 / k, initial=1.0 / k, lower=0.0, upper=20.0 / k)
        for i, k in enumerate(robot.stiffness_nm_per_rad)
    ]


def identified_compliance(values: dict[str, float]) -> np.ndarray | None:
    """The compliances c1..c6 among a model's values, None where the model has none."""
    names = [f"compliance.c{i + 1}" for i in range(6)]
    return np.array([values[n] for n in names], dtype=float) if all(n in values for n in names) else None


def draw_compliance(param: Param, rng: np.random.Generator) -> float:
    # A real robot's joints are as stiff as its data sheet says, give or take 15 % (one sigma).
    return param.initial * (1.0 + 0.15 * rng.standard_normal())


def diagonal_basis(torque_nm: np.ndarray) -> np.ndarray:
    """(N, 6, 6) degrees of joint deflection per unit compliance: delta q_i = c_i tau_i."""
    basis = np.zeros((len(torque_nm), 6, 6))
    idx = np.arange(6)
    basis[:, idx, idx] = np.rad2deg(torque_nm)
    return basis


class JointCompliance(Effect):
    name = "joint_compliance"
    kind = "joint"
    summary = "the joints give under the arm's own weight (and a payload): deflection = torque / stiffness"
    finding = "residuals follow the gravity torque on the joints"
    identifiability = COMPLIANCE_IDENTIFIABILITY

    payload_dependent = True  # the deflection changes with the load the flange carries

    def __init__(self, payload_kg: float | None = None, payload_com_mm=(0.0, 0.0, 0.0)):
        # None: the fit was not told the load it was measured with (the load then hides in
        # the compliances); a number, 0 included, is the payload the model was fitted at.
        self.payload_kg = None if payload_kg is None else float(payload_kg)
        self.payload_com_mm = tuple(float(v) for v in payload_com_mm)

    @property
    def stated_payload_kg(self) -> float | None:
        return self.payload_kg

    def options(self) -> dict:
        if self.payload_kg is None:
            return {}
        return {"payload": self.payload_kg, "payload_com": list(self.payload_com_mm)}

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "JointCompliance":
        unknown = set(opts) - {"payload", "payload_com"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: payload, payload_com)")
        try:
            mass = float(opts["payload"]) if "payload" in opts else None
            com = [float(v) for v in opts.get("payload_com", "0,0,0").split(",")]
        except ValueError:
            raise EffectSpecError(f"{cls.name}: payload is a mass in kg and payload_com three numbers in mm") from None
        if len(com) != 3 or (mass is not None and not mass >= 0):
            raise EffectSpecError(f"{cls.name}: payload_com needs x,y,z in mm (flange frame) and payload >= 0 kg")
        return cls(mass, com)

    def joint_compliance(self, values):
        return identified_compliance(values)

    def params(self, robot) -> list[Param]:
        return compliance_params(robot)

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        return diagonal_basis(gravity_torque(robot, ctx.q_deg, self.payload_kg or 0.0, self.payload_com_mm))

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        return draw_compliance(param, rng)
