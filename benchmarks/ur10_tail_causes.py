"""What the first poses after a move to a new grid point of Series A are, and are not.

Run: .venv/bin/python benchmarks/ur10_tail_causes.py [path/to/ur10_ipa]
Uses the training poses of `postproc validate A.csv --protocol random` (seed 0) only: the
physics model (geometric, base_frame, tool_offset, joint_compliance) fitted on them, then
the out-of-fold residual of a `gpr` (--gp-features tcp+joints) in 5 folds inside them —
what the hybrid leaves on poses it did not see. Prints:
- that residual by the place of the pose in its visit of a grid point (0: the first after the move);
- the same orientation of a point measured among the first three poses against later;
- whether the first and second poses of one visit err in the same direction;
- least-squares fits of candidate laws on half of the first poses, scored on the other half
  (joint lost motion, Dahl lost motion over the path, gravity-torque hysteresis, lag along the move);
- the first poses' residual by the size of the move into the point.
About 3-6 min on a shared 2-core machine (five local-GP fits).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from ur10_series import data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.identify import fit, residuals
from postproc.model.learn.features import features
from postproc.model.learn.gp import GPRPredictor
from postproc.model.measurements import read_measurements
from postproc.model.validate import random_mask
from postproc.robot import kinematics as kin
from postproc.robot.robots import load_robot

PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
TOOL = np.array([0.0, 0.0, 109.0])


def out_of_fold(robot, q, resid, folds: int = 5) -> np.ndarray:
    X = features(robot, TOOL, q, "tcp+joints")
    fold = np.random.default_rng(1).permutation(len(q)) % folds
    out = np.empty_like(resid)
    for k in range(folds):
        print(f"  gpr fold {k + 1}/{folds}", end="\r", flush=True)
        est = GPRPredictor(anisotropic=True, random_state=0).fit(X[fold != k], resid[fold != k])
        out[fold == k] = resid[fold == k] - est.predict(X[fold == k])
    print()
    return out


def dahl_state(x: np.ndarray, rise: float) -> np.ndarray:
    """Dahl's lost-motion state (-1..1) per row and column of x along the rows: each step of
    size |dx| moves it towards sign(dx) by the share 1 - exp(-|dx| / rise) — the solution of
    Dahl's friction model, dz/dx = (1 - z sign(dx)) / rise, over one step (P. R. Dahl, "A solid
    friction model", The Aerospace Corporation, TOR-0158(3107-18)-1, 1968; as lost motion of
    strain-wave geared robot joints: M. Ruderman, T. Bertram, "Modeling and observation of
    hysteresis lost motion in elastic robot joints", 10th IFAC Symposium on Robot Control, 2012)."""
    dx = np.diff(x, axis=0, prepend=x[:1])
    direction, decay = np.sign(dx), np.exp(-np.abs(dx) / rise)
    state, out = np.zeros(x.shape[1]), np.empty_like(x)
    for i in range(len(x)):
        state = direction[i] + (state - direction[i]) * decay[i]
        out[i] = state
    return out


def main() -> None:
    data = data_folder(sys.argv[1] if len(sys.argv) > 1 else None)
    robot = load_robot("ur10")
    with tempfile.TemporaryDirectory() as tmp:
        meas = read_measurements(imported(data, "A", Path(tmp) / "A.csv"))
    train = ~random_mask(len(meas), 0.2, 0)
    model = fit(robot, TOOL, parse_effects(PHYSICS), meas.subset(train), cv_folds=0, seed=0).model
    q, point, pose = meas.q_deg, meas.extra["point"].astype(int), meas.extra["pose"].astype(int)
    resid = np.full((len(meas), 3), np.nan)
    resid[train] = out_of_fold(robot, q[train], -residuals(model, meas.subset(train)))
    norm = np.linalg.norm(resid, axis=1)

    new_visit = np.r_[True, point[1:] != point[:-1]]
    visit = np.cumsum(new_visit) - 1
    first_row = np.maximum.accumulate(np.where(new_visit, np.arange(len(q)), 0))
    place = np.arange(len(q)) - first_row  # 0: the first pose after the move to the point
    points, at = np.unique(point, return_inverse=True)
    orientation = pose - np.array([pose[point == p].min() for p in points])[at.ravel()]  # the orientation's index at its point
    print("out-of-fold hybrid residual (mm) by place in the visit:",
          ", ".join(f"{k}: {norm[train & (place == k)].mean():.3f}" for k in range(6)), f"| 3+: {norm[train & (place >= 3)].mean():.3f}")
    for o in range(4):
        early, late = train & (orientation == o) & (place < 3), train & (orientation == o) & (place >= 3)
        print(f"orientation {o}: among the first three {norm[early].mean():.3f} mm (n {early.sum()}), later {norm[late].mean() if late.any() else np.nan:.3f} mm (n {late.sum()})")
    pairs = [(np.nonzero(train & (visit == v) & (place == 0))[0], np.nonzero(train & (visit == v) & (place == 1))[0]) for v in range(visit.max() + 1)]
    pairs = np.array([(a[0], b[0]) for a, b in pairs if len(a) and len(b)])
    first, second = resid[pairs[:, 0]], resid[pairs[:, 1]]
    cosine = np.sum(first * second, axis=1) / np.linalg.norm(first, axis=1) / np.linalg.norm(second, axis=1)
    print(f"first vs second pose of a visit: mean cosine of their residuals {cosine.mean():.2f} over {len(pairs)} visits")

    tcp = kin.fk(robot, q, tool=TOOL)[:, :3, 3]
    jac = kin.jacobian(robot, q, tool=TOOL)[:, :3] * np.pi / 180.0  # mm per degree
    move_in = np.diff(q, axis=0, prepend=q[:1])[first_row]  # the joint move into the visit
    tcp_move = (tcp - tcp[np.maximum(np.arange(len(q)) - 1, 0)])[first_row]
    torque = kin.gravity_torque(robot, q)
    torque_step = np.diff(torque, axis=0, prepend=torque[:1])
    laws = {
        "joint offset x sign of the joint move into the point (lost motion)": jac * np.sign(move_in)[:, None, :],
        "joint offset x the joint move into the point": jac * move_in[:, None, :],
        **{f"joint offset x Dahl state, rise {r:g} deg": jac * dahl_state(q, r)[:, None, :] for r in (0.01, 1.0, 10.0, 100.0)},
        "joint offset x sign of the gravity-torque step": jac * np.sign(torque_step)[:, None, :],
        **{f"joint offset x Dahl state of the gravity torque, rise {r:g} N*m": jac * dahl_state(torque, r)[:, None, :] for r in (1.0, 5.0, 20.0)},
        "along the TCP move into the point": (tcp_move / np.maximum(np.linalg.norm(tcp_move, axis=1, keepdims=True), 1e-9))[:, :, None],
        "constant offset": np.repeat(np.eye(3)[None], len(q), axis=0),
    }
    firsts = train & (place == 0)
    half = np.random.default_rng(0).random(len(q)) < 0.5
    fit_rows, score_rows = firsts & half, firsts & ~half
    print(f"first poses: residual {norm[score_rows].mean():.3f} mm on the scoring half; after each law fitted on the other half:")
    for name, columns in laws.items():
        coef, *_ = np.linalg.lstsq(columns[fit_rows].reshape(-1, columns.shape[-1]), resid[fit_rows].ravel(), rcond=None)
        left = resid[score_rows] - columns[score_rows] @ coef
        print(f"  {name}: {np.linalg.norm(left, axis=1).mean():.3f} mm")
    largest = np.abs(move_in).max(axis=1)
    edges = np.percentile(largest[firsts], [0, 100 / 3, 200 / 3, 100])
    print("first poses by the largest joint move into the point:",
          ", ".join(f"{edges[i]:.0f}-{edges[i + 1]:.0f} deg: {norm[firsts & (largest >= edges[i]) & (largest <= edges[i + 1])].mean():.3f} mm" for i in range(3)))


if __name__ == "__main__":
    main()
