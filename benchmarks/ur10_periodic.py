"""Joint-angle-periodic error on the UR10 (issue 31): a periodogram of Series A's physics
residual over sin/cos(k q_j), the terms its training poses support, and whether Series B
shows the same terms with the same amplitude and phase.

Run: .venv/bin/python benchmarks/ur10_periodic.py [path/to/ur10_ipa] [--split points|random]

1. The split of ``postproc validate A.csv --protocol points`` (every 5th commanded position
   held out with all its orientations); physics (geometric, base_frame, tool_offset,
   joint_compliance) fitted on the training poses.
2. Periodogram: for each joint j and order k = 1..420, the term
   ``delta q_j = a sin(k q_j) + b cos(k q_j)`` (joint_harmonics' column: dp/dq_j times the
   sinusoid) fitted alone to the training residual and scored on the held-out points (share
   of the held-out sum of squares it removes). UR joints use strain-wave gears; their ratio
   is commonly given as about 1:100 / 1:101 (we found no citable datasheet, so the scan
   covers every order up to 420 instead of a few): a transmission error would show near
   k = 101 (once per wave-generator turn) and k = 202 (twice: the dominant strain-wave
   component, Ghorbel, Gandhi & Alpeter 2001), and 420 covers twice that.
3. Selection on the training poses only (``postproc.model.harmonic_scan``): forward selection over joints 1-6 and orders
   1..60 (the periodogram shows nothing above), the base (physics) columns profiled out;
   the number of terms (up to 120) by 5-fold cross-validation grouped by commanded
   position inside the training poses (one-standard-error rule). Prints the ``joint_harmonics[terms=...]``
   option to confirm with ``postproc validate``.
4. Each chosen term fitted alone on the whole of A and on the whole of B (another tracker
   placement, other poses): a joint's own cyclic error has the same amplitude and phase in
   both; a term that only stands in for a smooth error of the region does not.

Draws benchmarks/results/ur10_periodogram.png: the periodogram, and the held-out residual
(mapped to joint 2, mdeg) against the phase of joint 2's order-17 term, before and after
the chosen terms. About 4 minutes on the shared 2-core machine.
"""

from __future__ import annotations

import argparse
import tempfile
from itertools import pairwise
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from ur10_series import data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.harmonic_scan import (
    Residual,
    amplitude_phase,
    choose_terms,
    fitted_prediction,
    periodogram,
    term_columns,
)
from postproc.model.identify import cyclic_residual
from postproc.model.measurements import MeasurementSet, read_measurements
from postproc.model.validate import (
    FitSpec,
    every_kth_group,
    fit_model,
    group_column,
    random_mask,
    with_order_columns,
)
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "benchmarks" / "results" / "ur10_periodogram.png"
PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
TOOL_MM = np.array([0.0, 0.0, 109.0])
SCAN_ORDERS = np.arange(1, 421)
GEAR_ORDERS = (101, 202)  # once and twice per wave-generator turn of a 1:101 strain-wave gear
SELECT_ORDERS = np.arange(1, 61)
MAX_TERMS = 120
FOLDS = 5


def physics_residual(robot, meas: MeasurementSet, train: np.ndarray, say) -> Residual:
    effects = parse_effects(PHYSICS)
    meas = with_order_columns(effects, meas)
    return cyclic_residual(fit_model(FitSpec(robot, TOOL_MM, effects), meas.subset(train), say), meas)


def draw(gains: np.ndarray, res: Residual, test: np.ndarray, after: np.ndarray, term) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 4.8))
    for j in range(6):
        left.plot(SCAN_ORDERS, 100 * gains[j], lw=0.8, label=f"joint {j + 1}")
    for k in GEAR_ORDERS:
        left.axvline(k, color="grey", ls="--", lw=0.8)
    left.text(GEAR_ORDERS[0] * 0.95, left.get_ylim()[1] * 0.9, "strain-wave orders\n(1 and 2 x ratio 101)", fontsize=8, ha="right")
    left.set(xlabel="order k of sin/cos(k q_j) (cycles per joint revolution)", ylabel="held-out sum of squares removed (%)",
             title="Series A, every 5th position held out: one term each", xscale="log")
    left.grid(alpha=0.3)
    left.legend(fontsize=8)
    j, k = term
    phase = np.degrees(np.mod(k * res.q_rad[test, j - 1], 2 * np.pi))
    edges = np.linspace(0, 360, 19)
    centres = 0.5 * (edges[1:] + edges[:-1])
    g = (res.dp_dq[test, :, j - 1] ** 2).sum(axis=1)
    for name, r in (("physics", res.r[test]), ("physics + chosen harmonics (linearised)", after)):
        q_err = 1e3 * (res.dp_dq[test, :, j - 1] * r).sum(axis=1) / g  # least-squares joint-j error, mdeg
        means = [np.mean(q_err[(phase >= a) & (phase < b)]) for a, b in pairwise(edges)]
        right.plot(centres, means, marker="o", label=f"{name}: mean 3-D {np.linalg.norm(r, axis=1).mean():.3f} mm")
    right.axhline(0, color="grey", lw=0.8)
    right.set(xlabel=f"phase of order {k} of joint {j}, {k} q{j} mod 360 (deg)", ylabel=f"held-out residual seen as a joint-{j} error (mdeg)",
              title=f"Held-out positions: residual against joint {j}'s order-{k} phase")
    right.grid(alpha=0.3)
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", help="the ur10_ipa folder (default: the shared data's)")
    parser.add_argument("--split", choices=("points", "random"), default="points",
                        help="whose training poses choose the terms: validate --protocol points (default; draws the figure) or random (20 %%, seed 0)")
    args = parser.parse_args()
    data = data_folder(args.data)
    robot = load_robot("ur10")
    with tempfile.TemporaryDirectory() as tmp, ProgressLine("ur10 periodic error") as say:
        a = read_measurements(imported(data, "A", Path(tmp) / "A.csv"))
        b = read_measurements(imported(data, "B", Path(tmp) / "B.csv"))
        points = group_column(a, "point", "")
        test = every_kth_group(points, 5) if args.split == "points" else random_mask(len(a), 0.2, 0)
        res = physics_residual(robot, a, ~test, say)
        gains = periodogram(res, SCAN_ORDERS, ~test, test)
        candidates = [(j, int(k)) for j in range(1, 7) for k in SELECT_ORDERS]
        choice = choose_terms(res, points, ~test, candidates, MAX_TERMS, FOLDS, say=say)
        terms, cv_rms = list(choice.terms), choice.cv_rms_mm
        say("whole-series fits of each chosen term")
        whole_a = physics_residual(robot, a, np.ones(len(a), bool), say)
        whole_b = physics_residual(robot, b, np.ones(len(b), bool), say)
        ab = [(t, amplitude_phase(whole_a, t), amplitude_phase(whole_b, t)) for t in terms]
    report(gains, cv_rms, terms, ab)
    design = term_columns(res, terms)
    # the fit explains target = -r by the columns; what is left is r + that explanation
    after = res.r[test] + fitted_prediction(design, res.base, -res.r.reshape(-1), np.repeat(~test, 3), np.arange(design.shape[1]), np.repeat(test, 3)).reshape(-1, 3)
    print(f"held-out mean 3-D error (linearised around the physics fit): {np.linalg.norm(res.r[test], axis=1).mean():.3f} -> {np.linalg.norm(after, axis=1).mean():.3f} mm")
    if args.split == "points":
        draw(gains, res, test, after, (2, 17))
        print(f"figure: {FIGURE.relative_to(ROOT)}")


def report(gains, cv_rms, terms, ab) -> None:
    noise = np.percentile(gains[:, SCAN_ORDERS > 60], 99)
    print(f"periodogram (held-out share removed by one term; 99th percentile over orders 61-420, all joints: {100 * noise:.2f} %)")
    for j in range(6):
        top = np.argsort(-gains[j])[:3]
        gear = ", ".join(f"k={k}: {100 * gains[j, k - 1]:.2f} %" for k in (100, 101, 102, 200, 201, 202, 203, 204))
        print(f"  joint {j + 1}: best " + ", ".join(f"k={SCAN_ORDERS[t]} {100 * gains[j, t]:.1f} %" for t in top) + f"; gear orders {gear}")
    print("cross-validated RMS (training poses, grouped by position) by number of terms: "
          + " ".join(f"{n}:{v:.4f}" for n, v in enumerate(cv_rms) if n % 10 == 0 or n in (len(terms), int(np.argmin(cv_rms)))))
    print(f"chosen {len(terms)} terms: joint_harmonics[terms={','.join(f'{j}:{k}' for j, k in terms)}]")
    print("each term fitted alone on the whole series (amplitude mdeg, phase deg): A | B")
    for (j, k), (amp_a, ph_a), (amp_b, ph_b) in ab:
        print(f"  {j}:{k}: A {amp_a:5.1f} mdeg {ph_a:5.0f} deg | B {amp_b:5.1f} mdeg {ph_b:5.0f} deg")
    # phases of unrelated fits agree within +-30 deg one time in six
    apart = np.array([abs((a[1] - b[1] + 180.0) % 360.0 - 180.0) for _, a, b in ab])
    print(f"phase on A and B within 30 deg: {int((apart <= 30).sum())} of {len(ab)} terms (by chance: {len(ab) / 6:.1f})")


if __name__ == "__main__":
    main()
