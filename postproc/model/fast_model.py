"""Compiled prediction for the common physics model: the compensation loop's hot path.

Compensation predicts the TCP of every target at least twice (as written, then once per
iteration). For a model made of joint compliance under gravity, DH errors (``geometric``),
tool and base terms (``tool_offset``, ``base_frame``, any tool or base effect) and nothing
else, ``compiled_positions`` does in one compiled pass per pose what
``ErrorModel.prepare`` + ``predict_prepared`` do in several NumPy passes over (N, 6, 6)
and (N, 6) temporaries: the gravity torque from the nominal DH frames, the deflection
dq = c * tau, the perturbed DH angles and the flange pose. The arithmetic is the generic
path's, operation for operation (the same compiled DH chain and gravity sums, the same
order of IEEE additions and products, NumPy's deg2rad / rad2deg constants), so the result
is bit for bit the same (tests/test_fast_model.py); any other model returns None and the
caller takes the generic path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from postproc.robot.dh import dh_rows, run_chunked, tool_transform
from postproc.robot.kinematics import GRAVITY

from .effects.geometric import Geometric
from .effects.joint_compliance import JointCompliance

_DEG2RAD = math.pi / 180.0  # numpy's deg2rad: x * (pi / 180)
_RAD2DEG = 180.0 / math.pi  # numpy's rad2deg: x * (180 / pi)


@njit(cache=True, nogil=True, inline="always")
def _chain(theta, d, a, ca, sa, keep, rots, origins, flange, p):
    """``dh._dh_kernel`` for one pose (theta (6,) radians, constant d, a and the cosines and
    sines of alpha computed once), operation for operation: frames 0..6 into rots (7, 3, 3)
    and origins (7, 3) when ``keep``, else the flange pose into flange[p]."""
    c00, c01, c02 = 1.0, 0.0, 0.0
    c10, c11, c12 = 0.0, 1.0, 0.0
    c20, c21, c22 = 0.0, 0.0, 1.0
    px, py, pz = 0.0, 0.0, 0.0
    for i in range(6):
        ct, st = math.cos(theta[i]), math.sin(theta[i])
        n0x, n0y, n0z = c00 * ct + c10 * st, c01 * ct + c11 * st, c02 * ct + c12 * st
        r1x, r1y, r1z = c10 * ct - c00 * st, c11 * ct - c01 * st, c12 * ct - c02 * st
        n1x, n1y, n1z = r1x * ca[i] + c20 * sa[i], r1y * ca[i] + c21 * sa[i], r1z * ca[i] + c22 * sa[i]
        n2x, n2y, n2z = c20 * ca[i] - r1x * sa[i], c21 * ca[i] - r1y * sa[i], c22 * ca[i] - r1z * sa[i]
        px += d[i] * c20 + a[i] * n0x
        py += d[i] * c21 + a[i] * n0y
        pz += d[i] * c22 + a[i] * n0z
        c00, c01, c02 = n0x, n0y, n0z
        c10, c11, c12 = n1x, n1y, n1z
        c20, c21, c22 = n2x, n2y, n2z
        if keep:
            f = i + 1
            rots[f, 0, 0], rots[f, 1, 0], rots[f, 2, 0] = c00, c01, c02
            rots[f, 0, 1], rots[f, 1, 1], rots[f, 2, 1] = c10, c11, c12
            rots[f, 0, 2], rots[f, 1, 2], rots[f, 2, 2] = c20, c21, c22
            origins[f, 0], origins[f, 1], origins[f, 2] = px, py, pz
    if not keep:
        flange[p, 0, 0], flange[p, 1, 0], flange[p, 2, 0] = c00, c01, c02
        flange[p, 0, 1], flange[p, 1, 1], flange[p, 2, 1] = c10, c11, c12
        flange[p, 0, 2], flange[p, 1, 2], flange[p, 2, 2] = c20, c21, c22
        flange[p, 0, 3], flange[p, 1, 3], flange[p, 2, 3] = px, py, pz
        flange[p, 3, 0], flange[p, 3, 1], flange[p, 3, 2], flange[p, 3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True, nogil=True)
def _compliant_flange_kernel(q, sign, theta0, comp, geo_theta, d, a, alpha, d_geo, a_geo, alpha_geo,
                             masses, com_local, frame_of, owner, g, out):
    """Flange poses out (N, 4, 4) of joints q (N, 6) (degrees) deflected by gravity:
    theta_g = deg2rad(q sign + theta0) -> tau (``kinematics._gravity_pose`` on the nominal
    chain d, a, alpha) -> dq = rad2deg(tau sign) c -> theta = deg2rad((q + dq) sign + theta0
    + geo_theta) on the perturbed chain d_geo, a_geo, alpha_geo (``dh._dh_kernel``)."""
    rots = np.zeros((7, 3, 3))
    origins = np.zeros((7, 3))
    rots[0, 0, 0], rots[0, 1, 1], rots[0, 2, 2] = 1.0, 1.0, 1.0
    origin_m = np.empty((7, 3))
    ca, sa = np.cos(alpha), np.sin(alpha)
    ca_geo, sa_geo = np.cos(alpha_geo), np.sin(alpha_geo)
    c = np.empty(3)
    theta_g = np.empty(6)
    tau = np.empty(6)
    theta = np.empty(6)
    for p in range(q.shape[0]):
        for i in range(6):
            theta_g[i] = (q[p, i] * sign[i] + theta0[i]) * _DEG2RAD
        _chain(theta_g, d, a, ca, sa, True, rots, origins, out, p)
        for i in range(7):
            for k in range(3):
                origin_m[i, k] = origins[i, k] / 1000.0
        # tau_i = z_i . sum_{l loads i} (c_l - o_i) x m_l g, as kinematics._gravity_pose.
        for i in range(6):
            tau[i] = 0.0
        for l in range(len(masses)):
            f = frame_of[l]
            for k in range(3):
                c[k] = (origins[f, k] + rots[f, k, 0] * com_local[l, 0] + rots[f, k, 1] * com_local[l, 1] + rots[f, k, 2] * com_local[l, 2]) / 1000.0
            fx, fy, fz = masses[l] * g[0], masses[l] * g[1], masses[l] * g[2]
            for i in range(owner[l] + 1):
                rx = c[0] - origin_m[i, 0]
                ry = c[1] - origin_m[i, 1]
                rz = c[2] - origin_m[i, 2]
                mx = ry * fz - rz * fy
                my = rz * fx - rx * fz
                mz = rx * fy - ry * fx
                tau[i] += rots[i, 0, 2] * mx + rots[i, 1, 2] * my + rots[i, 2, 2] * mz
        for i in range(6):
            dq = ((tau[i] * sign[i]) * _RAD2DEG) * comp[i]
            theta[i] = (((q[p, i] + dq) * sign[i] + theta0[i]) + geo_theta[i]) * _DEG2RAD
        _chain(theta, d_geo, a_geo, ca_geo, sa_geo, False, rots, origins, out, p)


def _only(model, cls):
    found = [e for e in model.effects if isinstance(e, cls)]
    return found[0] if len(found) == 1 and type(found[0]) is cls else None


def eligible(model) -> bool:
    """The model is one ``compiled_positions`` computes: joint compliance (one), at most one
    ``geometric``, any tool and base effects, nothing else (no learned residual)."""
    if model.residual is not None or _only(model, JointCompliance) is None:
        return False
    kinds = [e.kind for e in model.effects]
    if kinds.count("geometry") > 1 or (kinds.count("geometry") == 1 and _only(model, Geometric) is None):
        return False
    return all(k in ("joint", "geometry", "tool", "base") for k in kinds) and kinds.count("joint") == 1 \
        and not any(e.needs for e in model.effects)


def compiled_positions(model, q_deg: np.ndarray) -> np.ndarray | None:
    """Predicted measured positions (N, 3) at joints q (N, 6), bit for bit
    ``model.predict_prepared(model.prepare(q_deg=q))``; None where the model is not ``eligible``."""
    if not eligible(model):
        return None
    robot, values = model.robot, model.values
    compliance = _only(model, JointCompliance)
    comp = np.ascontiguousarray(values[model.indices_of(compliance)], dtype=float)
    geometric = _only(model, Geometric)
    geo = np.zeros((6, 4)) if geometric is None else np.asarray(values[model.indices_of(geometric)]).reshape(6, 4)
    masses = np.asarray(robot.mass_kg, dtype=float)
    com_local = np.asarray(robot.com_mm, dtype=float).reshape(6, 3)
    frame_of, owner = np.arange(1, 7), np.arange(6)
    if compliance.payload_kg:  # as kinematics.gravity_torque
        masses = np.append(masses, compliance.payload_kg)
        com_local = np.vstack([com_local, np.asarray(compliance.payload_com_mm, dtype=float)])
        frame_of, owner = np.append(frame_of, 6), np.append(owner, 5)
    d, a = dh_rows(robot.d_mm, 1, "d")[0], dh_rows(robot.a_mm, 1, "a")[0]
    alpha = np.deg2rad(dh_rows(robot.alpha_deg, 1, "alpha"))[0]
    # The geometric effect's DH columns, as Geometric.apply_dh then run_dh form them (one row: they do not vary).
    d_geo = np.ascontiguousarray(np.asarray(robot.d_mm, dtype=float) + geo[:, 1])
    a_geo = np.ascontiguousarray(np.asarray(robot.a_mm, dtype=float) + geo[:, 2])
    alpha_geo = np.deg2rad(np.asarray(robot.alpha_deg, dtype=float) + geo[:, 3])
    if geometric is None:
        d_geo, a_geo, alpha_geo = d, a, alpha
    q = np.ascontiguousarray(q_deg, dtype=float)
    sign = np.ascontiguousarray(robot.joint_sign, dtype=float) * np.ones(6)
    theta0 = np.ascontiguousarray(robot.theta0_deg, dtype=float) * np.ones(6)
    geo_theta = np.ascontiguousarray(geo[:, 0])
    flange = np.empty((len(q), 4, 4))
    run_chunked(len(q), lambda s, e: _compliant_flange_kernel(q[s:e], sign, theta0, comp, geo_theta, d, a, alpha, d_geo, a_geo, alpha_geo,
                                                                masses, com_local, frame_of, owner, GRAVITY, flange[s:e]))
    tool = model.tool_mm.copy()
    for effect in model.effects.of_kind("tool"):  # as ErrorModel._geometry
        tool = tool + effect.tool_basis() @ values[model.indices_of(effect)]
    rot, trans = model.base_transform()
    pos = (flange @ tool_transform(tool))[:, :3, 3] + 0.0  # + the (absent) Cartesian displacement, as predict_prepared
    return pos @ rot.T + trans
