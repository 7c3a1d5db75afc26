"""Where the held-out error of the UR10 hybrid sits, with pose features and with tcp+joints.

Run: .venv/bin/python benchmarks/ur10_gp_features.py [path/to/ur10_ipa]
The same split as `postproc validate A.csv --protocol random` (20 % of Series A, seed 0):
physics (geometric, base_frame, tool_offset, joint_compliance) fitted on the other 80 %,
then the gpr predictor on its residual with --gp-features pose (the default) and with
tcp+joints. Prints each one's held-out error split by where the tail is, and draws
benchmarks/results/ur10_gp_features.png: the held-out error against the pose's place in
its grid point's measurement order and against the probe's tilt to the tracker.
About 4-6 minutes on the shared 2-core machine (two local-expert GP fits on 9,529 poses).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from ur10_series import data_folder, imported  # noqa: E402

from postproc.model.effects import parse_effects  # noqa: E402
from postproc.model.identify import residuals  # noqa: E402
from postproc.model.measurements import read_measurements  # noqa: E402
from postproc.model.validate import FitSpec, fit_model, random_mask, with_order_columns  # noqa: E402
from postproc.progress import ProgressLine  # noqa: E402
from postproc.robot.robots import load_robot  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "benchmarks" / "results" / "ur10_gp_features.png"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
FIRST = 3  # the first poses measured at a grid point (the tilted orientations, right after the move there)
TILT_DEG = -75.0  # probe_ry below this: the orientations at the edge of the set (the first ones measured at a point)


def order_in_point(point: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """Each pose's place (0, 1, ...) in its grid point's measurement order."""
    rank = np.zeros(len(point), dtype=int)
    for p in np.unique(point):
        rows = np.nonzero(point == p)[0]
        rank[rows[np.argsort(time_s[rows], kind="stable")]] = np.arange(len(rows))
    return rank


def held_out_errors(a_csv: Path, say) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    robot = load_robot("ur10")
    effects = parse_effects(PHYSICS)
    meas = with_order_columns(effects, read_measurements(a_csv))
    test = random_mask(len(meas), 0.2, 0)
    train, held = meas.subset(~test), meas.subset(test)
    errors = {}
    for features in ("pose", "tcp+joints"):
        spec = FitSpec(robot, np.array([0.0, 0.0, 109.0]), effects, "gpr", {"features": features})
        model = fit_model(spec, train, say)
        errors[features] = np.linalg.norm(residuals(model, held), axis=1)
    rank = order_in_point(meas.extra["point"], meas.time_s)[test]
    return errors, rank, held.extra["probe_ry"]


def summary_lines(errors: dict[str, np.ndarray], rank: np.ndarray, tilt: np.ndarray) -> list[str]:
    first, tilted = rank < FIRST, tilt < TILT_DEG
    lines = [f"{len(rank)} held-out poses; first {FIRST} of their grid point {first.mean():.1%}, probe_ry < {TILT_DEG:g} deg {tilted.mean():.1%}, either {(first | tilted).mean():.1%}"]
    for name, e in errors.items():
        top = e >= np.percentile(e, 90)
        lines.append(f"gpr features {name}: mean {e.mean():.3f} median {np.median(e):.3f} p95 {np.percentile(e, 95):.3f} max {e.max():.3f} mm; "
                     f"first {FIRST} of a point {e[first].mean():.3f}, tilted {e[tilted].mean():.3f}, the rest {e[~(first | tilted)].mean():.3f} mm; "
                     f"of the worst 10 %, {(top & (first | tilted)).sum() / top.sum():.0%} are first-{FIRST} or tilted")
    return lines


def draw(errors: dict[str, np.ndarray], rank: np.ndarray, tilt: np.ndarray) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.6))
    places = np.arange(0, 23)
    edges = np.arange(-92.5, -37.4, 5.0)
    for name, e in errors.items():
        by_rank = [e[rank == k].mean() if (rank == k).any() else np.nan for k in places]
        left.plot(places, by_rank, marker="o", label=f"gpr, --gp-features {name} (mean {e.mean():.3f} mm)")
        which = np.digitize(tilt, edges)
        centres = 0.5 * (edges[:-1] + edges[1:])
        by_tilt = [e[which == k + 1].mean() if (which == k + 1).sum() >= 10 else np.nan for k in range(len(centres))]
        right.plot(centres, by_tilt, marker="o", label=f"gpr, --gp-features {name}")
    left.set(xlabel="place of the pose in its grid point's measurement order (0 = first, right after the move there)",
             ylabel="mean 3-D error of held-out poses (mm)", title="Series A, random 20 % held out: error by measurement order")
    right.set(xlabel="probe orientation probe_ry in the tracker frame (deg)", ylabel="mean 3-D error of held-out poses (mm)",
              title="the same, by the probe orientation (bins of 5 deg, >= 10 poses)")
    for ax in (left, right):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_ylim(bottom=0.0)
    left.xaxis.label.set_fontsize(8)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)


def main() -> None:
    data = data_folder(sys.argv[1] if len(sys.argv) > 1 else None)
    with tempfile.TemporaryDirectory() as tmp, ProgressLine("ur10 gp features") as say:
        a_csv = imported(data, "A", Path(tmp) / "A.csv")
        errors, rank, tilt = held_out_errors(a_csv, say)
    print("\n".join(summary_lines(errors, rank, tilt)))
    draw(errors, rank, tilt)
    print(f"figure: {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
