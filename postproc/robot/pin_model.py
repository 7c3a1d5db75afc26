"""A pinocchio model built from a robot file: the reference implementation for tests and benchmarks.

Pinocchio has no batched FK or Jacobian, so it is never used in a loop over a program;
``postproc.robot.kinematics`` is the production path and is tested against this model.
Each pinocchio joint coordinate equals the controller's joint value (radians), so the
joint sign and offset of the robot file are built into the joint placements and axes.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .robots import RobotModel


def _dh_fixed(d_mm: float, a_mm: float, alpha_deg: float) -> pin.SE3:
    """Tz(d) Tx(a) Rx(alpha) in metres."""
    alpha = np.deg2rad(alpha_deg)
    rot = pin.utils.rotate("x", alpha)
    return pin.SE3(rot, np.array([a_mm, 0.0, d_mm]) / 1000.0)


def build_model(robot: RobotModel, payload_kg: float = 0.0, payload_com_mm=(0.0, 0.0, 0.0)) -> pin.Model:
    """Pinocchio model with frame 'flange' at DH frame 6 and point-mass links at the robot file's centres of mass."""
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.81, 0.0, 0.0, 0.0]))
    parent = 0
    previous = pin.SE3.Identity()  # DH frame i-1 relative to the parent joint frame
    for i in range(6):
        placement = previous * pin.SE3(pin.utils.rotate("z", np.deg2rad(robot.theta0_deg[i])), np.zeros(3))
        axis = np.array([0.0, 0.0, float(robot.joint_sign[i])])
        joint_id = model.addJoint(
            parent,
            pin.JointModelRevoluteUnaligned(axis),
            placement,
            f"joint{i + 1}",
        )
        to_frame_i = _dh_fixed(robot.d_mm[i], robot.a_mm[i], robot.alpha_deg[i])
        com = to_frame_i.act(np.asarray(robot.com_mm[i], dtype=float) / 1000.0)
        model.appendBodyToJoint(joint_id, pin.Inertia(float(robot.mass_kg[i]), com, np.zeros((3, 3))), pin.SE3.Identity())
        if i == 5:
            if payload_kg:
                pay = to_frame_i.act(np.asarray(payload_com_mm, dtype=float) / 1000.0)
                model.appendBodyToJoint(joint_id, pin.Inertia(float(payload_kg), pay, np.zeros((3, 3))), pin.SE3.Identity())
            model.addFrame(pin.Frame("flange", joint_id, 0, to_frame_i, pin.FrameType.OP_FRAME))
        previous = to_frame_i
        parent = joint_id
    return model


def flange_pose(model: pin.Model, data: pin.Data, q_deg: np.ndarray) -> np.ndarray:
    """Flange pose (4, 4), mm, of one joint vector."""
    q = np.deg2rad(np.asarray(q_deg, dtype=float))
    pin.framesForwardKinematics(model, data, q)
    pose = data.oMf[model.getFrameId("flange")].homogeneous.copy()
    pose[:3, 3] *= 1000.0
    return pose


def flange_jacobian(model: pin.Model, data: pin.Data, q_deg: np.ndarray) -> np.ndarray:
    """Geometric Jacobian (6, 6) of the flange in base-aligned axes: mm/rad rows first, then rad/rad."""
    q = np.deg2rad(np.asarray(q_deg, dtype=float))
    jac = pin.computeFrameJacobian(model, data, q, model.getFrameId("flange"), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    out = jac.copy()
    out[:3] *= 1000.0
    return out


def gravity_torque(model: pin.Model, data: pin.Data, q_deg: np.ndarray) -> np.ndarray:
    """Torque gravity exerts on each joint (6,), N*m: minus the static holding torque of RNEA."""
    q = np.deg2rad(np.asarray(q_deg, dtype=float))
    return -pin.computeGeneralizedGravity(model, data, q)
