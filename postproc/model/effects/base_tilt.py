"""A robot base that is not level: gravity tilted in the robot's base frame.

A base tilted by small angles (rx, ry) about the base x and y axes sees gravity rotated
by the opposite angles, g' = R^T g ~ g - w x g with w = (rx, ry, 0). Gravity torques are
linear in the gravity vector, so to first order

    delta tau_i = rx * tau_i(e_x x g) + ry * tau_i(e_y x g),
    tau_i(g) = z_{i-1} . sum_{l >= i} (c_l - o_{i-1}) x m_l g

(the recursive Newton-Euler static torque; Siciliano, Sciavicco, Villani & Oriolo,
Robotics: Modelling, Planning and Control, Springer 2009, eq. 3.111 and sec. 7.2, the
gravity term g(q) = -J_P^T m g0 of each link with g0 expressed in the base frame), and
each joint gives by delta q_i = c_i delta tau_i through its data-sheet compliance c_i =
1/k_i (the robot file's stiffness). The rigid rotation of the arm that the tilt also
causes is the base frame's (``base_frame``): against a measurement frame that is
registered anyway (a laser tracker) only the gravity part is new. Joint 1, unloaded on a
level base, is what a tilt loads most: its axis is no longer parallel to gravity
(ISO 9283:1998 sec. 6 asks the robot to be mounted level for exactly this reason).
"""

from __future__ import annotations

import numpy as np

from postproc.robot.kinematics import GRAVITY, joint_frames

from .base import Context, Effect, Param


def gravity_torque_for(robot, q_deg: np.ndarray, gravity: np.ndarray) -> np.ndarray:
    """(N, 6) N*m static torque of the link weights under the gravity vector ``gravity``
    (m/s^2, base frame), in the sense of the controller's joint values."""
    rots, origins = joint_frames(robot, q_deg)
    com = np.asarray(robot.com_mm, dtype=float).reshape(6, 3)
    centres = (origins[:, 1:] + np.einsum("nlij,lj->nli", rots[:, 1:], com)) / 1000.0  # link l fixed in frame l + 1
    weights = np.asarray(robot.mass_kg, dtype=float)[:, None] * np.asarray(gravity, dtype=float)[None, :]  # (6, 3) N
    torque = np.zeros((len(q_deg), 6))
    for i in range(6):
        lever = centres[:, i:] - origins[:, i, None] / 1000.0  # (N, 6 - i, 3) m
        moment = np.cross(lever, weights[i:]).sum(axis=1)
        torque[:, i] = np.einsum("nk,nk->n", rots[:, i, :, 2], moment)
    return torque * np.asarray(robot.joint_sign, dtype=float)


class BaseTilt(Effect):
    name = "base_tilt"
    payload_dependent = True  # the tilted gravity pulls a heavier load harder
    kind = "joint"
    summary = "the robot's base is not level: gravity pulls the joints sideways, so they give where a level robot's would not"
    finding = "residuals follow the torque a tilted gravity puts on the joints (joint 1 above all): the base is not level"
    identifiability = (
        "Only the joint deflection under the tilted gravity is this effect; the rigid rotation of the arm is the base "
        "frame's. The deflection is computed with the robot file's compliances (first order): with joint_compliance "
        "identified alongside, a compliance error scales the tilt's estimate by the same factor. Joint 1's gravity "
        "torque on a level base is zero, so the tilt is told apart from the joint compliances mainly by joint 1: "
        "without joint 1 moving over a wide range the two tilt angles trade against compliances c2..c5."
    )

    def params(self, robot) -> list[Param]:
        # A base set up with a spirit level is within about 0.05 deg; a floor-bolted one may be 0.5 deg out.
        return [Param(f"{self.name}.{axis}", "deg", 0.1, 0.1, lower=-5.0, upper=5.0) for axis in ("rx", "ry")]

    def prepare(self, ctx: Context, robot) -> np.ndarray:
        compliance = 1.0 / np.asarray(robot.stiffness_nm_per_rad, dtype=float)
        basis = np.zeros((len(ctx.q_deg), 6, 2))
        for p, axis in enumerate(np.eye(3)[:2]):
            # Gravity seen from a base tilted by +1 rad about `axis` is rotated by -1 rad: -(axis x g).
            tau = gravity_torque_for(robot, ctx.q_deg, -np.cross(axis, GRAVITY))
            basis[:, :, p] = np.deg2rad(1.0) * np.rad2deg(compliance * tau)  # degrees per degree of tilt
        return basis
