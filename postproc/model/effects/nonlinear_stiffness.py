"""Joint stiffness that depends on the load: soft near zero torque, stiffer beyond a knee.

Strain-wave (harmonic drive) and cycloidal reducers are not linear springs: their
torsional stiffness grows with the transmitted torque. Manufacturers give it as a
piecewise-linear curve, K1 below T1, K2 up to T2, K3 beyond (Harmonic Drive AG, CSG/CSD
component-set catalogues, "Torsional stiffness"; the measured curves and a physical model
are in Tuttle & Seering, "A nonlinear model of a harmonic drive gear transmission", IEEE
Trans. Robotics and Automation 12(3), 1996, 368-374, and Taghirad & Belanger, "Modeling
and parameter identification of harmonic drive systems", ASME J. Dyn. Syst. Meas. Control
120(4), 1998, 439-444). With ``joint_compliance``'s linear part c_i (the stiff slope) this
effect adds the two-slope part:

    delta q_i = c_i tau_i + s_i sat(tau_i, T_i),   sat(tau, T) = clip(tau, -T, T)

so the slope is c_i + s_i below the knee T_i and c_i above it; s_i >= 0 (rad/(N*m)) is the
extra compliance of the soft region, linear in the model for a fixed knee. The knee is an
option (``knee=...`` in N*m, one per joint); by default a fixed share of the largest
gravity torque the joint sees anywhere in its range (the catalogues put T1 at 10-30 % of
the rated torque; the arm's own weight uses a good part of the rating), computed from the
robot file alone so a model file means the same curve wherever it is used.
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import gravity_torque

from .base import Context, Effect, EffectSpecError, Param, parse_int_list

KNEE_SHARE = 0.3  # default knee: this share of the joint's largest gravity torque
DEFAULT_JOINTS = (2, 3)


def largest_gravity_torque(robot) -> np.ndarray:
    """(6,) N*m: the largest |gravity torque| of each joint over its range (within +-170 deg),
    on a fixed quasi-random sample (deterministic: the knee must not depend on a seed)."""
    lower = np.maximum(np.asarray(robot.lower_deg, dtype=float), -170.0)
    upper = np.minimum(np.asarray(robot.upper_deg, dtype=float), 170.0)
    unit = (np.arange(1, 4097)[:, None] * (np.sqrt([2, 3, 5, 7, 11, 13]) % 1.0)) % 1.0  # Weyl (Kronecker) sequence
    return np.abs(gravity_torque(robot, lower + unit * (upper - lower))).max(axis=0)


class NonlinearStiffness(Effect):
    name = "nonlinear_stiffness"
    payload_dependent = True  # gravity bends the arm more under a heavier load
    kind = "joint"
    summary = "the joints' reducers are softer under small loads than under large ones (two-slope torsional stiffness)"
    finding = "residuals follow the gravity torque with a knee: the joints give more per N*m under light load than under heavy load"
    identifiability = (
        "Below the knee the extra compliance s_i has the shape of the linear compliance c_i: if no pose of the data "
        "loads joint i beyond its knee the two cannot be separated, the compliance is kept and s_i fixed at zero. "
        "A constant part of sat(tau) is absorbed by the joint zero offsets (geometric.dtheta), like the linear part's. "
        "Joints whose gravity torque is zero (joint 1 on a level base) carry nothing to identify."
    )

    def __init__(self, joints: tuple[int, ...] = DEFAULT_JOINTS, knee_nm: tuple[float, ...] | None = None):
        self.joints = tuple(sorted(set(joints)))
        if knee_nm is not None and len(knee_nm) != len(self.joints):
            raise EffectSpecError(f"{self.name}: give one knee per joint ({len(self.joints)}), got {len(knee_nm)}")
        self.knee_nm = None if knee_nm is None else tuple(float(v) for v in knee_nm)

    @classmethod
    def from_options(cls, opts: dict[str, str]) -> "NonlinearStiffness":
        unknown = set(opts) - {"joints", "knee"}
        if unknown:
            raise EffectSpecError(f"{cls.name}: unknown option(s) {', '.join(sorted(unknown))} (known: joints, knee)")
        joints = parse_int_list(cls.name, "joints", opts.get("joints", ",".join(map(str, DEFAULT_JOINTS))), 1, 6)
        knee = None
        if "knee" in opts:
            try:
                knee = tuple(float(v) for v in opts["knee"].split(","))
            except ValueError:
                raise EffectSpecError(f"{cls.name}: knee is one torque in N*m per joint, got '{opts['knee']}'") from None
            if any(not np.isfinite(v) or v <= 0 for v in knee):
                raise EffectSpecError(f"{cls.name}: every knee must be a positive torque in N*m, got '{opts['knee']}'")
        return cls(joints, knee)

    def options(self) -> dict:
        out: dict = {}
        if self.joints != DEFAULT_JOINTS:
            out["joints"] = list(self.joints)
        if self.knee_nm is not None:
            out["knee"] = list(self.knee_nm)
        return out

    def knees(self, robot) -> np.ndarray:
        """(len(joints),) N*m: the knee torque of each modelled joint."""
        if self.knee_nm is not None:
            return np.asarray(self.knee_nm)
        return KNEE_SHARE * largest_gravity_torque(robot)[np.asarray(self.joints) - 1]

    def params(self, robot) -> list[Param]:
        # Catalogue curves put the soft slope at 1/3 to 1/2 of the stiff one: s_i ~ c_i to 2 c_i.
        stiffness = np.asarray(robot.stiffness_nm_per_rad, dtype=float)
        return [Param(f"{self.name}.s{j}", "rad/(N*m)", 1.0 / stiffness[j - 1], 1.0 / stiffness[j - 1], lower=0.0, upper=20.0 / stiffness[j - 1]) for j in self.joints]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        tau = gravity_torque(robot, ctx.q_deg)
        basis = np.zeros((len(ctx.q_deg), 6, len(self.joints)))
        for p, (j, knee) in enumerate(zip(self.joints, self.knees(robot))):
            basis[:, j - 1, p] = np.rad2deg(np.clip(tau[:, j - 1], -knee, knee))
        return basis

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        # A reducer's soft region: as compliant again as its stiff slope, give or take 30 %.
        return abs(param.typical * (1.0 + 0.3 * rng.standard_normal()))
