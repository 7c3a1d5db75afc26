"""Seed 002's placement experiment rebuilt on the IRB6660-205/1.9 (Table 3, Fig. 7), then the search.

Run: .venv/bin/python examples/placement_seed002.py [OUT_DIR]   (figures go to OUT_DIR, default out/)

The seed mills a 1000 x 100 x 100 mm Al block at 20 placements (Table 3): x 1400 mm,
y 200...600 mm, the block turned by theta = 90, 60, 45 and 0 deg about base z, z 1170 mm.
At each, a straight pass of 5 cutter-contact points 10 mm apart on the top face, the tool
axis vertical (lead, tilt and the redundancy angle zero). Table 4 (tool and cut) was lost
in extraction: the cut here is examples/cut_aluminium.toml (20 mm bull nose, 3 flutes,
f 0.1 mm, ap 3 mm, ae 12 mm, Al6082-T6 coefficients), the tool tip sits 250 mm off the
flange axis and 200 mm below the flange (as milling spindles on this robot do; without an offset the turn of the
block about the tool axis would only turn axis 6 and change nothing). Joint stiffness is
the robot file's (an estimate: the seed's Table 2 was lost too).

Fig. 7's claim: the mean normal error follows the robot's normal compliance n^T C_tt n
(eq. 26) from placement to placement. The script prints both per placement, their
correlation, and the placement search over the seed's range against group 1.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from postproc import compliance as comp  # noqa: E402
from postproc import placement as pl  # noqa: E402
from postproc.process.forces import load_cut_params  # noqa: E402
from postproc.process.place_program import problem_from_program  # noqa: E402
from postproc.programs import parse_program  # noqa: E402
from postproc.report.placement_figures import error_maps  # noqa: E402
from postproc.robot.robots import load_robot  # noqa: E402

HERE = Path(__file__).resolve().parent
Z_MM = 1170.0
TABLE3 = [(1400.0, y, t) for t in (90.0, 60.0, 45.0, 0.0) for y in (200.0, 300.0, 400.0, 500.0, 600.0)]


def seed_pass(direction: str) -> str:
    """The seed's pass: 5 points 10 mm apart along the block's x (or y), tool axis down."""
    pts = [(10.0 * i, 50.0) if direction == "x" else (50.0, 10.0 * i) for i in range(5)]
    lines = ["DEF seed_pass( )", "$TOOL = {X -250, Y 0, Z 200, A 0, B 0, C 0}", "$BASE = {X 1400, Y 200, Z 1170, A 90, B 0, C 0}",
             f"PTP {{X {pts[0][0]:g}, Y {pts[0][1]:g}, Z 150, A 0, B 180, C 0}}"]
    lines += [f"LIN {{X {x:g}, Y {y:g}, Z 100, A 0, B 180, C 0}}" for x, y in pts]
    return "\n".join(lines + ["END", ""])


def problem(direction: str, robot, params):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"pass_{direction}.src"
        path.write_text(seed_pass(direction))
        tp = parse_program(path)
    return problem_from_program(tp, robot, params=params)


def table3(problems) -> tuple[np.ndarray, np.ndarray]:
    """Mean normal error (mm) and mean normal compliance (mm/N) per placement, averaged over the passes."""
    err, cn = np.zeros(len(TABLE3)), np.zeros(len(TABLE3))
    for prob in problems:
        for k, frame in enumerate(pl.placement_frames(np.array(TABLE3), Z_MM)):
            e, c, ok = pl.path_errors(prob, frame)
            assert ok, f"placement {k + 1} is not feasible"
            err[k] += comp.weighted_mean(e, prob.weights) / len(problems)
            cn[k] += comp.weighted_mean(c, prob.weights) / len(problems)
    return err, cn


def fig7(err, cn, path: Path) -> None:
    groups = np.arange(1, len(TABLE3) + 1)
    colours = np.repeat(["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"], 5)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    fig.subplots_adjust(left=0.06, right=0.98, top=0.85, bottom=0.15, wspace=0.3)
    axes[0].bar(groups, err * 1000, color=colours)
    axes[0].set(xlabel="placement (Table 3 group)", ylabel="mean normal error (µm)", title="(a) force-induced normal error")
    axes[1].bar(groups, cn * 1e6, color=colours)
    axes[1].set(xlabel="placement (Table 3 group)", ylabel="normal compliance nᵀC_tt n (µm/kN)", title="(b) normal compliance (eq. 26)")
    for ax in axes[:2]:
        ax.set_xticks(groups)
        ax.tick_params(axis="x", labelsize=8)
        ax.grid(axis="y", alpha=0.3)
    for t, c in zip((90, 60, 45, 0), ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")):
        sel = np.array([p[2] == t for p in TABLE3])
        axes[2].plot(cn[sel] * 1e6, err[sel] * 1000, "o", color=c, label=f"θ = {t}°")
    r = np.corrcoef(cn, err)[0, 1]
    axes[2].set(xlabel="normal compliance (µm/kN)", ylabel="mean normal error (µm)", title=f"(c) error against compliance, r = {r:.3f}")
    axes[2].grid(alpha=0.3)
    axes[2].legend()
    fig.suptitle("Seed 002 Fig. 7 rebuilt: IRB6660-205/1.9, x 1400 mm, z 1170 mm, y 200…600 mm per θ group")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
    out.mkdir(parents=True, exist_ok=True)
    robot = load_robot("irb6660_205_190")
    params = load_cut_params(HERE / "cut_aluminium.toml")
    problems = [problem("x", robot, params), problem("y", robot, params)]
    err, cn = table3(problems)
    print("group  x     y    theta  mean normal error (um)  normal compliance (um/kN)")
    for k, ((x, y, t), e, c) in enumerate(zip(TABLE3, err, cn)):
        print(f"{k + 1:5d}  {x:.0f}  {y:.0f}  {t:5.0f}  {e * 1000:22.2f}  {c * 1e6:25.1f}")
    r = np.corrcoef(cn, err)[0, 1]
    print(f"correlation of error and normal compliance over the 20 placements: r = {r:.3f}")
    g1, rest = err[:5].mean(), err[5:15].mean()
    print(f"groups 1-5 (theta 90) mean {g1 * 1000:.2f} um against groups 6-15 {rest * 1000:.2f} um")
    fig7(err, cn, out / "seed002_fig7.png")
    # The search over the seed's range (1400 x 800 mm x 90 deg) for the pass along x.
    prob = problems[0]
    res = pl.search(prob, np.arange(400.0, 1801.0, 50.0), np.arange(-400.0, 401.0, 50.0) + 400.0, np.arange(0.0, 91.0, 5.0), Z_MM)
    start = pl.path_errors(prob, pl.placement_frames(TABLE3[0], Z_MM)[0])
    start_mm = comp.weighted_mean(start[0], prob.weights)
    print(f"search: {res.evaluated} placements, best x {res.best[0]:.1f} y {res.best[1]:.1f} theta {res.best[2]:.1f}: "
          f"{res.best_mm * 1000:.2f} um against {start_mm * 1000:.2f} um at group 1 ({100 * (1 - res.best_mm / start_mm):.1f} % lower; seed: 61.0 %)")
    fig = error_maps(res, TABLE3[0])
    fig.savefig(out / "seed002_search.png", dpi=90)
    plt.close(fig)
    print(f"figures: {out / 'seed002_fig7.png'}, {out / 'seed002_search.png'}")


if __name__ == "__main__":
    main()
