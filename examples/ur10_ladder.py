"""The explain loop on the real UR10: diagnose Series A, add the effects one by one, watch Series B.

Data: data/ur10_ipa (Landgraf et al., CASE 2021, MIT licence): a laser tracker measured
a UR10 at 11,911 poses (Series A, over four days) and, standing elsewhere, at 1,495 more
(Series B, another part of the workspace). The models are fitted on Series A (every
third pose, so the example runs in minutes on a small machine: 3,971 poses); Series B is
never fitted, only its tracker-to-base transform is re-registered (6 DOF) for each model.

1. ``diagnose`` the geometric model (geometry, base frame, tool offset, joint compliance)
   on Series A: the physical effects the catalog has for what is left, each with the
   share of held-out residual variance it explains, and the command that adds it.
2. The ladder: the effects added one by one, the error on Series B after each.
3. The figure: examples/ur10_ladder.png (or the folder given).

Run: .venv/bin/python examples/ur10_ladder.py [output folder, default out/] [path/to/ur10_ipa] [--quick]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

import postproc
from postproc.model.diagnose import Files, diagnose, grouped_findings, ladder
from postproc.model.effects import parse_effects
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.identify import fit

args = [a for a in sys.argv[1:] if a != "--quick"]
EVERY = 20 if "--quick" in sys.argv else 3  # --quick (the test suite): every 20th pose of Series A
out_dir = Path(args[0]) if args else Path("out")
root = Path(args[1]) if len(args) > 1 else Path(__file__).resolve().parents[2] / "shared" / "data" / "ur10_ipa"
out_dir.mkdir(parents=True, exist_ok=True)
robot = postproc.load_robot("ur10")
full_a, tool = read_series(root / "Series_A")
series_b, _ = read_series(root / "Series_B")
series_a = full_a.subset(np.arange(len(full_a)) % EVERY == 0)
GEOMETRIC = "base_frame,geometric,tool_offset,joint_compliance"
PHYSICS = ["link_bending", "nonlinear_stiffness[joints=2,3,4]", "base_tilt", "joint_harmonics"]
FOLDS = 3
t0 = time.perf_counter()
print(f"UR10, probe {tool.round(3).tolist()} mm; fit on Series A ({len(series_a)} of {len(full_a)} poses), validate on Series B ({len(series_b)} poses, re-registered)\n")

model = fit(robot, tool, parse_effects(GEOMETRIC), series_a, cv_folds=0).model
diag = diagnose(model, series_a, folds=FOLDS, candidates=PHYSICS, files=Files("ur10_A.json", "A.csv"))
print(f"diagnose {model.effects.spec()} on Series A: cross-validated RMS {diag.cv_rms_mm:.4f} mm")
print(f"{'candidate':<46}{'explained':>10}{'CV RMS mm':>11}{'p (Holm)':>10}  significant")
for c in diag.candidates:
    print(f"{c.effect:<46}{100 * c.explained:>9.1f}%{c.rms_if_added_mm:>11.4f}{c.p_adjusted:>10.1e}  {'yes' if c.significant else 'no'}")
for texts, command in grouped_findings(diag.findings):
    for text in texts:
        print(f"- {text}")
    if command:
        print(f"    run: {command}")

steps = GEOMETRIC.split(",") + [c.effect for c in diag.candidates]  # the physics in the order diagnose ranked it
rows = ladder(robot, tool, series_a, steps, folds=FOLDS, validation=series_b, reregister=True)
print(f"\nladder (Series B re-registered at every step)\n{'step':>4}  {'added':<46}{'A CV RMS':>9}{'B RMS':>8}{'B mean':>8}{'B max':>8}  mm")
for r in rows:
    print(f"{r['step']:>4}  {r['added']:<46}{r['cv_rms_mm']:>9.3f}{r['val_rms_mm']:>8.3f}{r['val_mean_mm']:>8.3f}{r['val_max_mm']:>8.3f}")
print(f"({time.perf_counter() - t0:.0f} s)")


def figure(rows, path: Path) -> None:
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = rows[1:]  # from the registered base frame on (the nominal row's CV is in the tracker's frame)
    x = np.arange(len(shown))
    fig, ax = plt.subplots(figsize=(10, 5.6), constrained_layout=True)
    ax.plot(x, [r["val_mean_mm"] for r in shown], "s-", color="#ff7f0e", lw=2, label="Series B mean error (re-registered)")
    ax.plot(x, [r["val_rms_mm"] for r in shown], "^--", color="#d62728", lw=1.5, label="Series B RMS error")
    ax.plot(x, [r["cv_rms_mm"] for r in shown], "o-", color="#1f77b4", lw=2, label=f"Series A RMS, {FOLDS}-fold cross-validated")
    ax.axhline(0.25, color="#2ca02c", ls=":", label="goal for physics alone: mean 0.25 mm")
    for xi, r in zip(x, shown):
        ax.annotate(f"{r['val_mean_mm']:.3f}", (xi, r["val_mean_mm"]), textcoords="offset points", xytext=(0, -15), ha="center", fontsize=8, color="#ff7f0e")
    ax.set_yscale("log")
    ax.set_ylim(0.2, 4.0)
    ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}" if round(v, 3) in (0.2, 0.3, 0.4, 0.6, 2.0, 3.0) else ""))
    ax.set_xticks(x)
    ax.set_xticklabels([("+ " if i else "") + r["added"] for i, r in enumerate(shown)], rotation=25, ha="right", fontsize=9)
    ax.set_ylabel("3-D position error (mm, log scale)")
    ax.set_title("UR10: effects added one by one on Series A, error on Series B")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


(out_dir / "ur10_ladder.json").write_text(json.dumps(rows, indent=1))
figure(rows, out_dir / "ur10_ladder.png")
print(f"figure: {out_dir / 'ur10_ladder.png'}")
