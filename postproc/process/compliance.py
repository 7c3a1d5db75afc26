"""Force-induced error of a robot cutting (seed 002 eq. 1-2 and 18-23), vectorised over points.

Cartesian compliance from joint stiffness: C = J Kq^-1 J^T (eq. 18-19, the compensation
stiffness Kc neglected as in the seed); its translational block C_tt (mm/N) turns a
cutting force F (N) into the tool deflection dX_t = C_tt F (mm, eq. 22-23; moments and the
rotational deflection neglected, as the seed does). The normal error is e_n = n . dX_t
with n the surface normal at the cutter-contact point (eq. 1), and the path's mean normal
error weighs each point by the path length around it (eq. 2).
"""

from __future__ import annotations

import numpy as np

from postproc.robot import kinematics as kin
from postproc.robot.robots import RobotModel


def joint_compliance(robot: RobotModel, model=None) -> np.ndarray:
    """Joint compliances (6,) in rad/(N*m): a fitted model's identified ``compliance.c1..c6``
    when it has them (joint_compliance / external_load effects), else 1 / k of the robot file."""
    identified = None if model is None else identified_compliance(model)
    return identified if identified is not None else 1.0 / np.asarray(robot.stiffness_nm_per_rad, dtype=float)


def identified_compliance(model) -> np.ndarray | None:
    """The joint compliances a fitted model identified (through whichever effect models
    joint stiffness), None where it has none."""
    values = model.as_dict()
    for effect in model.effects:
        found = effect.joint_compliance(values)
        if found is not None:
            return found
    return None


def tcp_linear_jacobian(robot: RobotModel, q_deg: np.ndarray, flange_to_tcp_base: np.ndarray) -> np.ndarray:
    """Linear rows (N, 3, 6), mm/rad, of the TCP Jacobian: the flange's plus omega x r, with
    r (N, 3) the flange-to-TCP vector in the base frame (so one call serves any mix of tools)."""
    jac = kin.jacobian(robot, q_deg)
    lin, ang = jac[:, :3, :], jac[:, 3:, :]
    return lin + np.cross(ang, flange_to_tcp_base[:, None, :], axisa=1, axisb=2, axisc=1)


def translational_compliance(jac_linear: np.ndarray, compliance_rad_per_nm: np.ndarray) -> np.ndarray:
    """C_tt (N, 3, 3) in mm/N = J_v diag(c) J_v^T, c in rad/(N*m) (1e-3 rad/(N*mm))."""
    c = np.asarray(compliance_rad_per_nm, dtype=float) * 1e-3
    return np.einsum("nik,k,njk->nij", jac_linear, c, jac_linear)


def normal_error(c_tt: np.ndarray, force_base: np.ndarray, normal_base: np.ndarray) -> np.ndarray:
    """e_n = n . (C_tt F) (mm), over leading axes: c_tt (..., 3, 3), force and normal (..., 3)."""
    return np.einsum("...i,...ij,...j->...", normal_base, c_tt, force_base)


def normal_compliance(c_tt: np.ndarray, normal_base: np.ndarray) -> np.ndarray:
    """n^T C_tt n (mm/N): the seed's normal compliance (eq. 26), the error per newton along n."""
    return np.einsum("...i,...ij,...j->...", normal_base, c_tt, normal_base)


def normal_error_and_compliance(jac_linear, compliance_rad_per_nm, force_base, normal_base):
    """e_n = n^T C_tt F and n^T C_tt n without forming C_tt: with a_k = n . J_k and
    b_k = F . J_k (J_k the k-th column of J_v), n^T J diag(c) J^T F = sum_k c_k a_k b_k."""
    c = np.asarray(compliance_rad_per_nm, dtype=float) * 1e-3
    a = np.einsum("ni,nik->nk", normal_base, jac_linear)
    b = np.einsum("ni,nik->nk", force_base, jac_linear)
    return (a * b) @ c, (a * a) @ c


def step_weights(positions: np.ndarray, cutting: np.ndarray) -> np.ndarray:
    """Weights (N,) of eq. 2: each cutting step's length, split half to either end point.

    A step counts when both its ends are cutting-move targets (``cutting`` True): the
    approach from a rapid or joint move and the points it starts from weigh nothing. Where
    no step has length (a single point), cutting points weigh 1.
    """
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1) * (cutting[1:] & cutting[:-1])
    weights = np.zeros(len(positions))
    weights[1:] += steps / 2.0
    weights[:-1] += steps / 2.0
    if weights.sum() <= 0:
        weights = cutting.astype(float)
    return weights


def weighted_mean(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Mean of |values| over the last axis weighted by ``weights`` (eq. 2); NaN rows stay NaN."""
    total = weights.sum()
    return (np.abs(values) * weights).sum(axis=-1) / total
