"""Bending of the long links (upper arm, forearm) under gravity: Euler-Bernoulli cantilevers.

Each long link is a cantilever clamped at its proximal joint: the upper arm from the axis
of joint 2 to the axis of joint 3 (DH frames 1 -> 2), the forearm from the axis of joint 3
to the wrist centre (frames 2 -> 4). Every link mass on or beyond the beam loads it: a
link on the beam with its weight F at the distance a along it (its centre of mass
projected on the beam axis, clipped to 0..L) and a link beyond the tip with its weight at
a = L; either one also with the moment M = (c - x) x F of its centre of mass c about the
point x where it is applied. Only the components across the beam bend it (the axial force
and the twisting moment are left out). For a cantilever of length L and flexural rigidity
EI the tip deflects and turns by

    load P across the beam at a:   delta = P a^2 (3L - a) / (6 EI),   theta = P a^2 / (2 EI)
    moment M0 at a:                delta = M0 a (2L - a) / (2 EI),    theta = M0 a / EI

(Young, Budynas & Sadegh, Roark's Formulas for Stress and Strain, 8th ed., McGraw-Hill
2012, Table 8.1, cases 1a "concentrated intermediate load" and 3a "concentrated
intermediate moment", left end free, right end fixed; the same closed forms are in Gere &
Goodno, Mechanics of Materials, Appendix "Deflections and slopes of beams", cantilever
beams). The measured point moves by delta + theta x (p - tip). So the deflection grows
with the load moment and, through theta x (p - tip), with the arm's radius.

The parameter of each link is its bending compliance b = L / EI in rad/(N*m) — the tip
slope per unit tip moment — which the model is linear in. The deflection is evaluated on
the nominal chain (first order: the bending does not move the loads that cause it).
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import GRAVITY, joint_frames

from .base import Context, Effect, Param

# (parameter suffix, DH frame at the clamped end, DH frame at the tip, typical b in rad/(N*m)).
# Typical b (an assumption, not a measured value): EI ~ 4e6 N*m^2 over 0.6 m for a
# 160-kg-class upper arm and ~2.4e6 N*m^2 over 0.7 m for its forearm, i.e. a quarter to a
# half of the joint compliances (5-6e-7 rad/(N*m) on the KR160): a hollow casting bends.
SEGMENTS = (("upper_arm", 1, 2, 1.5e-7), ("forearm", 2, 4, 3e-7))


def _across(v: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The part of (N, 3) vectors v across the unit directions e (N, 3)."""
    return v - np.einsum("nk,nk->n", v, e)[:, None] * e


def segment_deflection(o_base: np.ndarray, o_tip: np.ndarray, loads: list, tcp: np.ndarray) -> np.ndarray:
    """(N, 3) mm displacement of the measured point per unit bending compliance b = L/EI.

    o_base, o_tip, tcp (N, 3) m; loads: (centre of mass (N, 3) m, weight (3,) N, beyond the tip?).
    """
    axis = o_tip - o_base
    length = np.linalg.norm(axis, axis=1)
    e = axis / np.maximum(length, 1e-9)[:, None]
    delta = np.zeros_like(o_base)
    theta = np.zeros_like(o_base)
    for centre, weight, beyond in loads:
        a = length if beyond else np.clip(np.einsum("nk,nk->n", centre - o_base, e), 0.0, length)
        point = o_base + a[:, None] * e
        force = _across(np.broadcast_to(weight, centre.shape), e)
        moment = _across(np.cross(centre - point, weight), e)
        a2, ll = a[:, None], length[:, None]
        delta += force * (a2**2 * (3 * ll - a2) / 6) + np.cross(moment, e) * (a2 * (2 * ll - a2) / 2)
        theta += np.cross(e, force) * (a2**2 / 2) + moment * a2
    inv_ei = 1.0 / np.maximum(length, 1e-9)[:, None]  # 1/EI per unit b = L/EI
    out = 1000.0 * (delta * inv_ei + np.cross(theta * inv_ei, tcp - o_tip))
    return np.where(length[:, None] > 1e-3, out, 0.0)  # no beam where the frames coincide


class LinkBending(Effect):
    name = "link_bending"
    payload_dependent = True  # gravity bends the arm more under a heavier load
    kind = "cartesian"
    summary = "the upper arm and forearm bend like cantilever beams under the weight they carry (Euler-Bernoulli)"
    finding = "residuals grow with the load moment on the arm and with its reach (the long links bend)"
    identifiability = (
        "The tip rotation caused by the moment at each link's end has the shape of the next joint's gravity "
        "deflection, so joint_compliance (c3 for the upper arm, the wrist's for the forearm) absorbs that part; "
        "what separates the bending is its deflection across the link, which grows with the shear load and the "
        "link length squared. With joint_compliance in the model the compliances are kept first and a bending "
        "compliance the data cannot separate is fixed at zero."
    )

    def params(self, robot) -> list[Param]:
        # A link is never negative-stiff, nor softer than 100 times its typical value.
        return [Param(f"{self.name}.{part}", "rad/(N*m)", typical, typical, lower=0.0, upper=100 * typical) for part, _, _, typical in SEGMENTS]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        rots, origins = joint_frames(robot, ctx.q_deg)
        tool = np.zeros(3) if ctx.tool_mm is None else np.asarray(ctx.tool_mm, dtype=float)
        tcp = (origins[:, 6] + rots[:, 6] @ tool) / 1000.0
        com = np.asarray(robot.com_mm, dtype=float).reshape(6, 3)
        centres = (origins[:, 1:] + np.einsum("nlij,lj->nli", rots[:, 1:], com)) / 1000.0  # link l fixed in frame l + 1
        basis = np.zeros((len(tcp), 3, len(SEGMENTS)))
        for s, (_, base, tip, _) in enumerate(SEGMENTS):
            loads = [(centres[:, l], robot.mass_kg[l] * GRAVITY, l + 1 > tip) for l in range(6) if l + 1 > base]
            basis[:, :, s] = segment_deflection(origins[:, base] / 1000.0, origins[:, tip] / 1000.0, loads, tcp)
        return basis

    def draw(self, param: Param, rng: np.random.Generator, magnitude: float) -> float:
        # A link's section is known to within about 30 % (castings, wall thickness).
        return abs(param.typical * (1.0 + 0.3 * rng.standard_normal()))
