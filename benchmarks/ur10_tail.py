"""The tail of Series A's random held-out poses, before and after --gp-features tcp+joints+travel.

Run: .venv/bin/python benchmarks/ur10_tail.py [path/to/ur10_ipa]
Fits each fold as `postproc validate A.csv --protocol random --robot ur10 --tool 0,0,109
--effects geometric,base_frame,tool_offset,joint_compliance --predictor gpr` does (the
same split, seed 0), once with --gp-features tcp+joints and once with tcp+joints+travel,
and plots the held-out error against what the travel features see: how many targets ago
the TCP last moved more than LONG_MOVE_MM (0: this pose is the first after such a move),
and the TCP travel of the move into the pose. Writes benchmarks/results/ur10_tail.png and
prints the figures (about 2-4 min per fit on a shared 2-core machine).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from ur10_series import bars_by_place, data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.identify import residuals
from postproc.model.measurements import read_measurements
from postproc.model.path_history import travel_mm
from postproc.model.validate import FitSpec, fit_model, random_mask, with_order_columns
from postproc.robot import kinematics as kin
from postproc.robot.robots import load_robot

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "benchmarks" / "results" / "ur10_tail.png"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
TOOL = np.array([0.0, 0.0, 109.0])
LONG_MOVE_MM = 10.0  # the grid points are 50 mm apart; the orientations of one point move the probe tip < 1 mm
SINCE_BINS = 6  # 0 .. 4 targets since the long move, and 5 or more


def targets_since_long_move(travel_into: np.ndarray) -> np.ndarray:
    """Per row (in measured order): how many targets ago the TCP last moved > LONG_MOVE_MM (capped)."""
    long_move = travel_into > LONG_MOVE_MM
    last = np.maximum.accumulate(np.where(long_move, np.arange(len(travel_into)), 0))
    return np.minimum(np.arange(len(travel_into)) - last, SINCE_BINS - 1)


def held_out_errors(meas, test, robot, features: str) -> tuple[np.ndarray, float]:
    spec = FitSpec(robot, TOOL, parse_effects(PHYSICS), "gpr", {"features": features}, seed=0)
    start = time.monotonic()
    model = fit_model(spec, meas.subset(~test), lambda message: print(f"  {features}: {message}", end="\r", flush=True))
    print()
    return np.linalg.norm(residuals(model, meas.subset(test)), axis=1), time.monotonic() - start


def main() -> None:
    data = data_folder(sys.argv[1] if len(sys.argv) > 1 else None)
    robot = load_robot("ur10")
    with tempfile.TemporaryDirectory() as tmp:
        meas = read_measurements(imported(data, "A", Path(tmp) / "A.csv"))
    meas = with_order_columns(parse_effects(PHYSICS), meas)
    test = random_mask(len(meas), 0.2, 0)
    travel = travel_mm(robot, TOOL, kin.fk(robot, meas.q_deg, tool=TOOL), meas.previous_q_deg)[:, 0]
    since = targets_since_long_move(travel)[test]
    errors = {}
    for features in ("tcp+joints", "tcp+joints+travel"):
        errors[features], seconds = held_out_errors(meas, test, robot, features)
        by_since = [errors[features][since == k].mean() for k in range(SINCE_BINS)]
        print(f"--gp-features {features}: mean {errors[features].mean():.4f} mm ({seconds:.0f} s); by targets since a long move: "
              + ", ".join(f"{k}{'+' if k == SINCE_BINS - 1 else ''}: {v:.3f}" for k, v in enumerate(by_since)))
    plot(errors, since, travel[test])


def plot(errors: dict, since: np.ndarray, travel_into: np.ndarray) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8))
    bars_by_place(left, errors, since, SINCE_BINS, lambda features, err: f"--gp-features {features} (mean {err.mean():.3f} mm)",
                  f"targets since the TCP last moved more than {LONG_MOVE_MM:.0f} mm\n(0: the first pose after the move; n: held-out poses)",
                  "Series A, random 20 % held out: error by history")
    edges = np.array([0.0, 0.1, 0.2, 0.5, 1.0, 10.0, 60.0, 200.0, 2000.0])
    bins = np.clip(np.digitize(travel_into, edges) - 1, 0, len(edges) - 2)
    present = [b for b in range(len(edges) - 1) if (bins == b).sum() >= 5]
    for features, err in errors.items():
        right.plot(range(len(present)), [err[bins == b].mean() for b in present], marker="o", label=f"--gp-features {features}")
    right.set_xticks(range(len(present)), [f"{edges[b]:g}-{edges[b + 1]:g}\n({int((bins == b).sum())})" for b in present], fontsize=8)
    right.set_xlabel("TCP travel of the move into the pose (mm)\n(held-out poses per bin)")
    right.set_ylabel("mean held-out 3-D error (mm)")
    right.set_title("error by the travel of the move into the pose")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)
    print(f"wrote {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
