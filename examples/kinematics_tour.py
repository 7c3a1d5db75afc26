"""A straight milling pass on the KUKA KR160: joint path, controller configuration, and gravity sag.

Runs the foundation end to end on one toolpath: Cartesian targets -> analytic IK with a
continuous branch -> ABB/KUKA configuration data -> gravity torque through the seed's
joint stiffness -> the TCP deflection the robot would show (the error postproc exists to
compensate). Run: .venv/bin/python examples/kinematics_tour.py
"""

from __future__ import annotations

import numpy as np

import postproc
from postproc.robot import kinematics as kin
from postproc.robot.frames import abc_to_matrix, make_transform

robot = postproc.load_robot("kr160_r1570")
tool = np.array([0.0, 0.0, 200.0])  # spindle tip 200 mm along the flange z axis

# A 600 mm pass along y at x = 1200, z = 600, tool pointing straight down.
n = 7
tcp = np.column_stack([np.full(n, 1200.0), np.linspace(-300.0, 300.0, n), np.full(n, 600.0)])
rot = np.repeat(abc_to_matrix(np.array([[0.0, 180.0, 0.0]])), n, axis=0)
base_t_tcp = make_transform(rot, tcp)
flange_t_tool = np.eye(4)
flange_t_tool[:3, 3] = tool
base_t_flange = base_t_tcp @ np.linalg.inv(flange_t_tool)

solutions = postproc.ik(robot, base_t_flange)  # (n, 8, 6), NaN where a branch is unreachable
start = np.array([0.0, 0.0, 0.0, 0.0, 90.0, 0.0])
q, branch, ok = kin.select_path(robot, solutions, start)
assert ok.all(), "every target of the pass must be reachable on one branch"

check = postproc.fk(robot, q, tool=tool)[:, :3, 3]
status, turn = kin.kuka_status_turn(robot, q)

# Gravity torque through the joint stiffness, then to the TCP through the Jacobian.
tau = postproc.gravity_torque(robot, q)  # N*m
dq = tau / robot.stiffness_nm_per_rad  # rad
sag = np.einsum("nij,nj->ni", postproc.jacobian(robot, q, tool=tool)[:, :3], dq)  # mm

print(f"robot: {robot.description}; tool {tool.tolist()} mm; IK branch {branch[0]} kept along the pass")
print(f"FK(IK(target)) worst error: {np.abs(check - tcp).max():.2e} mm")
print()
header = f"{'y (mm)':>8} | " + " ".join(f"{'q' + str(j + 1):>8}" for j in range(6)) + f" | {'S':>2} {'T':>3} | {'tau2 N*m':>9} | sag dx, dy, dz (mm)"
print(header)
print("-" * len(header))
for i in range(n):
    joints = " ".join(f"{v:8.3f}" for v in q[i])
    print(
        f"{tcp[i, 1]:8.1f} | {joints} | {status[i]:2d} {turn[i]:3d} | {tau[i, 1]:9.1f} | "
        f"{sag[i, 0]:+.3f}, {sag[i, 1]:+.3f}, {sag[i, 2]:+.3f}"
    )
print()
print(f"gravity sag along the pass: {np.linalg.norm(sag, axis=1).min():.3f} to {np.linalg.norm(sag, axis=1).max():.3f} mm")
