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
3. Selection on the training poses only: forward selection over joints 1-6 and orders
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
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from ur10_series import data_folder, imported

from postproc.model.effects import parse_effects
from postproc.model.identify import kin_joint_columns, residuals
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


@dataclass(frozen=True)
class Residual:
    """A physics fit's residual on a set, with what the harmonic columns need."""

    r: np.ndarray  # (N, 3) predicted - measured, mm
    dp_dq: np.ndarray  # (N, 3, 6) mm per degree
    base: np.ndarray  # (3N, n_params) the physics fit's identification Jacobian
    q_rad: np.ndarray  # (N, 6)


def physics_residual(robot, meas: MeasurementSet, train: np.ndarray, say) -> Residual:
    effects = parse_effects(PHYSICS)
    meas = with_order_columns(effects, meas)
    model = fit_model(FitSpec(robot, TOOL_MM, effects), meas.subset(train), say)
    prep = model.prepare(meas)
    _, jac = model.evaluate(prep)
    return Residual(residuals(model, meas, prep), kin_joint_columns(model, prep), jac.reshape(3 * len(meas), -1), np.radians(meas.q_deg))


def periodogram(res: Residual, train: np.ndarray, test: np.ndarray) -> np.ndarray:
    """(6, orders): share of the held-out sum of squares each single term removes, fitted
    on the training rows (the weighted projection of the residual on dp/dq_j)."""
    out = np.zeros((6, len(SCAN_ORDERS)))
    for j in range(6):
        g = (res.dp_dq[:, :, j] ** 2).sum(axis=1)
        u = -(res.dp_dq[:, :, j] * res.r).sum(axis=1)
        s, c = np.sin(np.outer(res.q_rad[:, j], SCAN_ORDERS)), np.cos(np.outer(res.q_rad[:, j], SCAN_ORDERS))
        a11, a22, a12 = ((g[train, None] * m[train]).sum(axis=0) for m in (s * s, c * c, s * c))
        b1, b2 = (u[train, None] * s[train]).sum(axis=0), (u[train, None] * c[train]).sum(axis=0)
        det = a11 * a22 - a12 ** 2
        fitted = ((a22 * b1 - a12 * b2) / det) * s[test] + ((a11 * b2 - a12 * b1) / det) * c[test]
        out[j] = (2 * fitted * u[test, None] - fitted ** 2 * g[test, None]).sum(axis=0) / (res.r[test] ** 2).sum()
    return out


def term_columns(res: Residual, terms) -> np.ndarray:
    """(3N, 2 * len(terms)): joint_harmonics' columns, sin then cos per term."""
    cols = []
    for j, k in terms:
        for wave in (np.sin, np.cos):
            cols.append((res.dp_dq[:, :, j - 1] * wave(k * res.q_rad[:, j - 1])[:, None]).reshape(-1))
    return np.column_stack(cols)


def reduced_normal(design: np.ndarray, base: np.ndarray, target: np.ndarray, rows: np.ndarray):
    """Gram and right-hand side of the design on ``rows`` with the base columns profiled out,
    and the maps that give the base coefficients back."""
    d, b, t = design[rows], base[rows], target[rows]
    g_bb = b.T @ b + 1e-9 * np.trace(b.T @ b) / b.shape[1] * np.eye(b.shape[1])
    maps = np.linalg.solve(g_bb, b.T @ np.column_stack([d, t]))
    gram = d.T @ d - (d.T @ b) @ maps[:, :-1]
    rhs = d.T @ t - (d.T @ b) @ maps[:, -1]
    return gram, rhs, maps


def forward_path(gram: np.ndarray, rhs: np.ndarray, n_terms: int, max_terms: int) -> list[int]:
    """Terms (pairs of columns 2t, 2t+1) added one at a time, each the one that lowers the
    training sum of squares most given those before it (the chosen columns profiled out of
    every candidate's 2 x 2 normal equations)."""
    chosen: list[int] = []
    pairs = np.arange(2 * n_terms).reshape(n_terms, 2)
    for _ in range(min(max_terms, n_terms)):
        cols = pairs[chosen].ravel()
        if len(cols):
            ridge = 1e-10 * np.trace(gram[np.ix_(cols, cols)]) / len(cols) * np.eye(len(cols))
            proj = np.linalg.solve(gram[np.ix_(cols, cols)] + ridge, gram[cols])  # (|S|, all)
            g_red, r_red = gram - gram[:, cols] @ proj, rhs - proj.T @ rhs[cols]
        else:
            g_red, r_red = gram, rhs
        blocks = g_red[pairs[:, :, None], pairs[:, None, :]] + 1e-12 * np.eye(2)
        r = r_red[pairs]
        gains = np.einsum("mi,mi->m", r, np.linalg.solve(blocks, r[..., None])[..., 0])
        gains[chosen] = -np.inf
        chosen.append(int(np.argmax(gains)))
    return chosen


def fitted_prediction(design, base, target, rows, cols, pred_rows) -> np.ndarray:
    gram, rhs, maps = reduced_normal(design[:, cols], base, target, rows)
    coef = np.linalg.solve(gram + 1e-10 * np.eye(len(cols)), rhs)
    return design[pred_rows][:, cols] @ coef + base[pred_rows] @ (maps[:, -1] - maps[:, :-1] @ coef)


def columns_of(path: list[int]) -> np.ndarray:
    return np.ravel([[2 * t, 2 * t + 1] for t in path]).astype(int)


def choose_terms(res: Residual, points: np.ndarray, train: np.ndarray, say) -> tuple[list[tuple[int, int]], np.ndarray]:
    """Forward selection on the training poses, the number of terms by cross-validation
    grouped by commanded position; returns the terms and the CV RMS per number of terms."""
    candidates = [(j, int(k)) for j in range(1, 7) for k in SELECT_ORDERS]
    design, target = term_columns(res, candidates), -res.r.reshape(-1)
    train_points = np.unique(points[train])
    fold_of_point = dict(zip(train_points, np.random.default_rng(0).permutation(len(train_points)) % FOLDS))
    fold = np.array([fold_of_point.get(p, -1) for p in points])
    sq = np.zeros((MAX_TERMS + 1, len(points)))
    for f in range(FOLDS):
        say(f"forward selection, cross-validation fold {f + 1}/{FOLDS}")
        fit_rows, held = np.repeat(train & (fold != f), 3), np.repeat(fold == f, 3)
        path = forward_path(*reduced_normal(design, res.base, target, fit_rows)[:2], len(candidates), MAX_TERMS)
        for size in range(MAX_TERMS + 1):
            pred = fitted_prediction(design, res.base, target, fit_rows, columns_of(path[:size]), held)
            sq[size, fold == f] = ((target[held] - pred) ** 2).reshape(-1, 3).sum(axis=1)
    per_point = np.array([[row[points == p].sum() for p in train_points] for row in sq])
    mse = per_point.sum(axis=1) / train.sum()
    best = int(np.argmin(mse))
    # one-standard-error rule, paired over the positions: the smallest model whose held-out
    # MSE is within one standard error of the best one's
    std_err = np.sqrt(len(train_points) * np.var(per_point - per_point[best], axis=1)) / train.sum()
    size = int(np.nonzero(mse <= mse[best] + std_err)[0][0])
    cv_rms = np.sqrt(mse)
    say("forward selection on all training poses")
    path = forward_path(*reduced_normal(design, res.base, target, np.repeat(train, 3))[:2], len(candidates), size)
    return [candidates[t] for t in path], cv_rms


def amplitude_phase(res: Residual, term) -> tuple[float, float]:
    """One term fitted alone (with the physics columns) on a whole set: amplitude (mdeg), phase (deg)."""
    design = term_columns(res, [term])
    x = np.linalg.lstsq(np.column_stack([design, res.base]), -res.r.reshape(-1), rcond=1e-10)[0]
    return 1e3 * float(np.hypot(x[0], x[1])), float(np.degrees(np.arctan2(x[1], x[0])))


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
        gains = periodogram(res, ~test, test)
        terms, cv_rms = choose_terms(res, points, ~test, say)
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
