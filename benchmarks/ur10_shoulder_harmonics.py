"""Series B's held-out residual against the shoulder joints, without and with their harmonics.

Run: .venv/bin/python benchmarks/ur10_shoulder_harmonics.py [path/to/ur10_ipa]
The split of `postproc validate B.csv --protocol points --every 2` (every other commanded
position held out with both arm configurations): physics (geometric, base_frame,
tool_offset, joint_compliance) fitted on the other half, then the same plus
joint_harmonics on joints 1 and 2 with orders 1-12. Prints both held-out errors and draws
benchmarks/results/ur10_shoulder_harmonics.png: the held-out 3-D error against joint 1
and joint 2 (binned means), before and after. About a minute on the shared 2-core machine.
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
from postproc.model.validate import FitSpec, every_kth_group, fit_model, group_column, with_order_columns  # noqa: E402
from postproc.progress import ProgressLine  # noqa: E402
from postproc.robot.robots import load_robot  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "benchmarks" / "results" / "ur10_shoulder_harmonics.png"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
SHOULDER = "joint_harmonics[joints=1,2;orders=1,2,3,4,5,6,7,8,9,10,11,12]"
MODELS = {"physics": PHYSICS, "physics + shoulder harmonics (orders 1-12)": PHYSICS + "," + SHOULDER}


def held_out_errors(b_csv: Path, say) -> tuple[dict[str, np.ndarray], np.ndarray]:
    robot = load_robot("ur10")
    meas = read_measurements(b_csv)
    test = every_kth_group(group_column(meas, "point", ""), 2)
    errors = {}
    for name, spec_text in MODELS.items():
        effects = parse_effects(spec_text)
        framed = with_order_columns(effects, meas)
        model = fit_model(FitSpec(robot, np.array([0.0, 0.0, 109.0]), effects), framed.subset(~test), say)
        errors[name] = np.linalg.norm(residuals(model, framed.subset(test)), axis=1)
    return errors, meas.q_deg[test]


def binned(x: np.ndarray, e: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    which = np.digitize(x, edges)
    centres = 0.5 * (edges[:-1] + edges[1:])
    means = np.array([e[which == k + 1].mean() if (which == k + 1).sum() >= 8 else np.nan for k in range(len(centres))])
    return centres, means


def draw(errors: dict[str, np.ndarray], q_deg: np.ndarray) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for ax, joint in zip(axes, (0, 1)):
        edges = np.linspace(q_deg[:, joint].min(), q_deg[:, joint].max() + 1e-9, 25)
        for name, e in errors.items():
            centres, means = binned(q_deg[:, joint], e, edges)
            ax.plot(centres, means, marker="o", label=f"{name}: mean {e.mean():.3f} mm")
        ax.set(xlabel=f"joint {joint + 1} angle (deg)", ylabel="mean 3-D error of held-out poses (mm)",
               title=f"Series B, half of the positions held out: by joint {joint + 1}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_ylim(bottom=0.0)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)


def main() -> None:
    data = data_folder(sys.argv[1] if len(sys.argv) > 1 else None)
    with tempfile.TemporaryDirectory() as tmp, ProgressLine("ur10 shoulder harmonics") as say:
        b_csv = imported(data, "B", Path(tmp) / "B.csv")
        errors, q_deg = held_out_errors(b_csv, say)
    for name, e in errors.items():
        print(f"{name}: mean {e.mean():.3f} median {np.median(e):.3f} p95 {np.percentile(e, 95):.3f} max {e.max():.3f} mm ({len(e)} held-out poses)")
    draw(errors, q_deg)
    print(f"figure: {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
